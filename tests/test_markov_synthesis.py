"""Synthesis over bursty (Markov) links: gains K_{k,ℓ} on the previous mode
(theory: Markov losses), the LMI written once for i.i.d. and Markov modes, the closed
forms of §11, and the pair-mode closed loop against sampling and the
event-level protocol."""

import dataclasses
import pickle

import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension

import control_ncs as ncs
from control_ncs import (PeriodicGain, SynthesisError, feedback,
                         gilbert_elliott, moments, ms_radius, passivesyn,
                         simulate)
from control_ncs.openloop import JumpPlant
from control_ncs.protocol import simulate_protocol
from control_ncs.verify import check_certificate

from helpers import assert_mean_within, plant_state_selector


def scalar(a, actuator, sensor=0.0):
    """``x⁺ = a x + w + u``, ``z = x + w``, ``y = x``: passivity is never the
    bottleneck (``D11 = 1``), so a certified gain exists iff a mean-square
    stabilising one does."""
    return ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   sensor_loss=sensor, actuator_loss=actuator)


def two_state():
    """A 2-state plant, both links bursty, full information."""
    return ncs.nss([[1.1, 0.4], [0.0, 0.8]],
                   [[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]],
                   [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
                   [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0, 0, 0], [0, 0, 0]],
                   nmeas=2, ncon=1,
                   sensor_loss=gilbert_elliott(fail=0.1, recover=0.6),
                   actuator_loss=gilbert_elliott(fail=0.15, recover=0.5))


def t_oo(T1, T2):
    """``T`` of the joint chain restricted to the modes with θ1 θ2 = 0."""
    T = np.kron(T1, T2)        # state order (θ1, θ2) = 00, 01, 10, 11
    return T[:3, :3]


# -- the gain object and the pair-mode closed loop ----------------------------
def test_mode_dependent_gain_says_so_and_survives_pickling():
    K = PeriodicGain(np.arange(8.0).reshape(1, 4, 1, 2))
    assert K.mode_dependent and K.modes == 4 and K.period == 1
    assert K[3].shape == (4, 1, 2) and np.asarray(K).shape == (1, 4, 1, 2)
    assert pickle.loads(pickle.dumps(K)) == K
    assert K != PeriodicGain(np.arange(8.0).reshape(4, 1, 2))
    assert "previous modes=4" in repr(K)
    assert not PeriodicGain([[1.0]]).mode_dependent
    assert PeriodicGain([[1.0]]).modes is None


def test_equal_gains_per_previous_mode_give_the_phase_gain_loop():
    P = two_state()
    K = np.array([[-1.0, -0.3]])
    CL, CLp = feedback(P, K), feedback(P, np.tile(K, (1, 4, 1, 1)))
    assert CLp.modes.transition is not None
    assert ms_radius(CLp) == pytest.approx(ms_radius(CL), rel=1e-9)


def test_pair_modes_move_from_l_i_to_i_j_with_the_plants_transition():
    """Pairs (ℓ, i) with the input lost in i (θ1 θ2 = 0) do not depend on
    ℓ and are lumped: 3 + 4 modes; each moves to the modes of current plant
    mode j with probability T[i, j] and applies K_ℓ when delivered."""
    P = two_state()
    K = np.random.default_rng(0).standard_normal((1, 4, 1, 2))
    CL = feedback(P, K)
    plant = ncs.build(P)
    T = plant.transition[0]
    cur = CL.info["pair_modes"][0]
    assert CL.nmodes == 7 and sorted(cur.tolist()) == [0, 1, 2, 3, 3, 3, 3]
    Tp = CL.modes.transition[0]
    for s, i in enumerate(cur):
        for j in range(4):
            assert Tp[s, cur == j].sum() == pytest.approx(T[i, j], abs=1e-15)
    delivered = [CL.modes.A[0, s] for s in np.flatnonzero(cur == 3)]
    for ell in range(4):
        A = plant.A[0, 3] + plant.Bu[0, 3] @ K[0, ell] @ plant.E[0]
        assert any(np.array_equal(A, D) for D in delivered)


def test_mode_dependent_gains_on_iid_links_are_allowed_as_extra_information():
    """Sensor perfect, actuator Bernoulli 0.2, x⁺ = a x + u: with
    ``S_ℓ = E[x² 1{σ_{k-1} = ℓ}]`` for ℓ = (1, 0) lost, (1, 1) delivered,
    ``S⁺_lost = 0.2 a² (S_lost + S_del)``,
    ``S⁺_del = 0.8 ((a + K_lost)² S_lost + (a + K_del)² S_del)``."""
    a, k_lost, k_del = 2.0, -1.0, -1.5
    P = scalar(a, 0.2)
    # (θ1, θ2) order 00, 10, 01, 11: index θ1 + 2 θ2
    K = np.array([0.0, k_lost, 0.0, k_del]).reshape(1, 4, 1, 1)
    op = np.array([[0.2 * a * a, 0.2 * a * a],
                   [0.8 * (a + k_lost) ** 2, 0.8 * (a + k_del) ** 2]])
    assert ms_radius(feedback(P, K)) == pytest.approx(
        max(abs(np.linalg.eigvals(op))), rel=1e-9)
    # the same gain for every ℓ is the i.i.d. loop
    same = feedback(P, np.full((1, 4, 1, 1), -1.5))
    assert ms_radius(same) == pytest.approx(ms_radius(feedback(P, [[-1.5]])),
                                            rel=1e-9)


def test_feedback_refuses_gains_for_another_number_of_modes():
    with pytest.raises(ControlDimension, match="K: expected gains"):
        feedback(scalar(2.0, 0.2), np.zeros((1, 3, 1, 1)))


def test_periodic_gain_refuses_five_dimensions():
    with pytest.raises(ControlDimension, match="gains"):
        PeriodicGain(np.zeros((1, 1, 4, 1, 1)))


# -- closed forms (theory: Markov losses) ----------------------------------------------------
@pytest.mark.parametrize("fail", [0.05, 0.6])
@pytest.mark.parametrize("recover, feasible", [(0.78, True), (0.72, False)])
def test_actuator_chain_has_a_gain_iff_one_minus_r_times_a2_below_one(
        fail, recover, feasible):
    """a = 2: (1 − r) a² = 0.88 or 1.12, whatever f."""
    P = scalar(2.0, gilbert_elliott(fail=fail, recover=recover))
    if feasible:
        K, CL, eta = passivesyn(P)
        assert K.result.certificate.verified and ms_radius(CL) < 1
        assert K.mode_dependent and K.result.gain_kind == "mode"
    else:
        with pytest.raises(SynthesisError) as err:
            passivesyn(P)
        assert err.value.reason == "infeasible"
        rate = err.value.figures["ms_radius_without_control"]
        assert rate == pytest.approx((1 - recover) * 4.0, rel=1e-9)


@pytest.mark.parametrize("fail, recover", [(0.05, 0.74), (0.5, 0.9)])
def test_k_equal_minus_a_attains_one_minus_r_times_a2(fail, recover):
    a = 1.5
    P = scalar(a, gilbert_elliott(fail=fail, recover=recover))
    assert ms_radius(feedback(P, [[-a]])) == pytest.approx(
        (1 - recover) * a * a, rel=1e-9)
    assert ms_radius(feedback(P, np.full((1, 4, 1, 1), -a))) == \
        pytest.approx((1 - recover) * a * a, rel=1e-9)


def test_decay_certifies_a_rate_below_r2_on_a_bursty_link():
    a, recover = 2.0, 0.85          # (1 − r) a² = 0.6
    P = scalar(a, gilbert_elliott(fail=0.2, recover=recover))
    K, CL, eta = passivesyn(P, decay=0.8)
    assert ms_radius(CL) < 0.64 and K.result.certificate.verified
    with pytest.raises(SynthesisError) as err:
        passivesyn(P, decay=0.77)   # 0.77² = 0.593 < 0.6: a proof
    assert err.value.reason == "infeasible"


@pytest.mark.parametrize("links, feasible", [
    (((0.1, 0.8), (0.1, 0.8)), True),
    (((0.1, 0.3), (0.1, 0.3)), False)])
def test_both_links_markov_need_a2_times_rho_of_t_oo_below_one(links,
                                                                feasible):
    a = 1.6
    (f1, r1), (f2, r2) = links
    s, u = gilbert_elliott(fail=f1, recover=r1), gilbert_elliott(fail=f2,
                                                                 recover=r2)
    bound = a * a * max(abs(np.linalg.eigvals(t_oo(s.transition,
                                                   u.transition))))
    assert (bound < 1) == feasible
    P = scalar(a, u, sensor=s)
    if feasible:
        K, CL, _ = passivesyn(P)
        assert ms_radius(CL) < 1 and K.result.certificate.verified
    else:
        with pytest.raises(SynthesisError) as err:
            passivesyn(P)
        assert err.value.reason == "infeasible"
        assert err.value.figures["ms_radius_without_control"] == \
            pytest.approx(bound, rel=1e-9)


def test_bursts_matter_six_percent_in_bursts_loses_to_27_percent_spread():
    """theory: Markov losses: a = 2; f = 0.05, r = 0.74 (6 % loss, long bursts) cannot be
    stabilised; f = 0.3, r = 0.8 (27 %, short bursts) can, although
    Bernoulli at 27 % cannot."""
    bursty = gilbert_elliott(fail=0.05, recover=0.74)
    spread = gilbert_elliott(fail=0.3, recover=0.8)
    assert bursty.loss < 0.07 and spread.loss > 0.27
    with pytest.raises(SynthesisError):
        passivesyn(scalar(2.0, bursty))
    K, CL, _ = passivesyn(scalar(2.0, spread))
    assert ms_radius(CL) < 1
    with pytest.raises(SynthesisError):
        passivesyn(scalar(2.0, spread.loss))


# -- equal rows: the Bernoulli results ---------------------------------------
def with_equal_rows(plant):
    """The i.i.d. plant with its transition written out (equal rows)."""
    return dataclasses.replace(plant, transition=plant.transitions())


@pytest.mark.parametrize("gain", ["mode", "phase"])
def test_equal_rows_reproduce_the_bernoulli_design(gain):
    P = ncs.nss([[1.3, 0.4], [0.0, 0.8]], [[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]],
                [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0, 0, 0], [0, 0, 0]],
                nmeas=2, ncon=1, sensor_loss=0.1, actuator_loss=0.2)
    plant = ncs.build(P)
    K0, _, eta0 = passivesyn(plant, decay=0.95, options={"solver": "CLARABEL"})
    K1, CL1, eta1 = passivesyn(with_equal_rows(plant), decay=0.95,
                               gain=gain, options={"solver": "CLARABEL"})
    assert eta1 == pytest.approx(eta0, rel=1e-4, abs=1e-5)
    gains = K1.gains if gain == "phase" else K1.gains[:, 0]
    if gain == "mode":
        # one class of previous modes: one gain for every ℓ
        assert np.all(K1.gains == K1.gains[:, :1])
    assert np.allclose(gains, K0.gains, rtol=1e-3, atol=1e-4)
    assert K1.result.certificate.verified


# -- gains per phase only (sufficient) ----------------------------------------
def test_phase_gains_on_markov_links_are_certified_and_never_beat_mode_gains():
    P = two_state()
    Km, _, eta_m = passivesyn(P, decay=0.98)
    Kp, CLp, eta_p = passivesyn(P, decay=0.98, gain="phase")
    assert Kp.gains.shape == (1, 1, 2) and not Kp.mode_dependent
    assert Kp.result.gain_kind == "phase" and Km.result.gain_kind == "mode"
    assert Kp.result.certificate.verified and ms_radius(CLp) < 0.98 ** 2
    assert eta_p <= eta_m + 1e-6 * max(1.0, abs(eta_m))


def test_phase_gains_on_iid_links_are_the_iid_design():
    P = scalar(2.0, 0.2)
    K0, _, eta0 = passivesyn(P, decay=0.9)
    K1, _, eta1 = passivesyn(P, decay=0.9, gain="phase")
    assert eta1 == eta0 and np.array_equal(K1.gains, K0.gains)
    assert K0.result.gain_kind == K1.result.gain_kind == "phase"
    assert "gain_kind = 'phase'" in repr(K0.result)


def test_phase_gains_with_a_common_x_are_certified_too():
    P = two_state()
    K, CL, _ = passivesyn(P, decay=0.98, gain="phase",
                          options={"structure": "block"})
    assert K.result.structure == "block" and K.result.certificate.verified


def two_mode_plant(a=1.2, e=0.05):
    """x⁺ = a x + b_i u with b = +1 in mode 0, −1 in mode 1, a sticky chain
    (switch w.p. e): knowing the previous mode, K_ℓ = −a b_ℓ leaves the rate
    4 a² e; a gain per phase cannot use the sign."""
    A = np.full((1, 2, 1, 1), a)
    Bu = np.array([1.0, -1.0]).reshape(1, 2, 1, 1)
    Bw = np.ones((1, 2, 1, 1))
    Cz, Du, Dw = np.ones((1, 2, 1, 1)), np.zeros((1, 2, 1, 1)), \
        np.ones((1, 2, 1, 1))
    T = np.array([[[1 - e, e], [e, 1 - e]]])
    return JumpPlant(A, Bu, Bw, Cz, Du, Dw, np.ones((1, 1, 1)),
                     [[0.5, 0.5]], transition=T,
                     controller="static", actuator="zero")


def test_knowing_the_previous_mode_stabilises_what_no_phase_gain_can():
    plant = two_mode_plant()
    K, CL, _ = passivesyn(plant)
    assert K.mode_dependent and ms_radius(CL) < 1
    assert ms_radius(plant.close(np.array([[[[-1.2]], [[1.2]]]]))) == \
        pytest.approx(4 * 1.44 * 0.05, rel=1e-9)
    # every phase-only gain: rate ≥ a² > 1 (scan), and the LMI finds none
    rates = [ms_radius(plant.close(np.full((1, 1, 1), k)))
             for k in np.linspace(-3, 3, 61)]
    assert min(rates) >= 1.44 - 1e-9
    with pytest.raises(SynthesisError):
        passivesyn(plant, gain="phase")


# -- the certificate, exactly ----------------------------------------------------
def test_the_pair_certificate_passes_the_public_exact_check():
    P = two_state()
    K, CL, eta = passivesyn(P, decay=0.98)
    cert = K.result.certificate
    again = check_certificate(CL, cert.P, eta, decay=0.98)
    assert again.verified
    X = K.result.X                     # X_{k,ℓ} per previous mode
    assert X.shape == (1, 4, 2, 2)
    # P_{k,(ℓ',ℓ)} = X_{k,ℓ}⁻¹: a previous pair mode whose plant mode is ℓ
    previous = CL.info["pair_modes"][-1]
    for s, ell in enumerate(previous):
        assert np.allclose(np.asarray(cert.P)[0, s], np.linalg.inv(X[0, ell]),
                           rtol=1e-6, atol=1e-9)


def test_fixed_eta_on_markov_links_is_certified_as_asked():
    P = two_state()
    K, CL, eta = passivesyn(P, eta=-1.0)
    assert eta == -1.0 and check_certificate(CL, K.result.certificate.P,
                                             -1.0).verified


def test_predictor_on_markov_links_gets_a_verified_gain():
    P = two_state().with_network(sensor_schedule=[1, 2, 0],
                                 actuator_schedule=[0, 0, 1],
                                 shared_channel=True)
    # the LMI's gains K_{k,ℓ} (the default call may refine a gain per phase)
    K, CL, _ = passivesyn(P, controller="predictor", decay=0.999,
                          method="lmi")
    assert K.result.certificate.verified and ms_radius(CL) < 0.999 ** 2
    assert K.gains.shape[:2] == (3, 4)


@pytest.mark.parametrize("decay", [1.0, 0.98])
def test_coupled_riccati_equations_match_the_lmi_on_markov_links(decay):
    P = two_state()
    Kr, CLr, eta_r = passivesyn(P, decay=decay, options={"solver": "riccati"})
    Kl, _, eta_l = passivesyn(P, decay=decay, options={"solver": "CLARABEL"})
    assert Kr.result.report.solver == "RICCATI" and Kr.mode_dependent
    assert Kr.result.certificate.verified and ms_radius(CLr) < decay ** 2
    # both certified; the bisection stops within rtol = 1e-4 of the supremum
    assert eta_r == pytest.approx(eta_l, rel=1e-3, abs=1e-3)


def test_coupled_riccati_diverges_iff_the_closed_form_says_no_gain():
    """(1 − r) a² = 0.96: decay 0.97 asks for 0.9409 (no gain: the coupled
    iteration diverges, a proof), decay 0.985 for 0.970 (it converges).
    Called directly: passivesyn's own bound would refuse first."""
    from control_ncs.riccati import riccati_synthesis
    plant = ncs.build(scalar(2.0, gilbert_elliott(fail=0.3, recover=0.76)))
    with pytest.raises(SynthesisError) as err:
        riccati_synthesis(plant, -10.0, decay=0.97)
    assert err.value.reason == "infeasible"
    res = riccati_synthesis(plant, -10.0, decay=0.985)
    assert res.gains.shape == (1, 4, 1, 1) and res.P.shape == (1, 4, 1, 1)
    assert ms_radius(plant.close(res.gains)) < 0.985 ** 2


def test_riccati_with_phase_gains_falls_back_to_the_lmi_and_says_so():
    P = two_state()
    K, CL, _ = passivesyn(P, decay=0.98, gain="phase",
                          options={"solver": "riccati"})
    assert K.result.report.solver != "RICCATI" and not K.mode_dependent
    assert "LMI" in K.result.note and K.result.note in K.result.summary()
    assert K.result.certificate.verified


# -- the pair-mode loop against sampling and the protocol ----------------------
def test_monte_carlo_matches_exact_moments_of_a_pair_mode_loop():
    P = two_state()
    K, CL, _ = passivesyn(P, decay=0.95)
    steps, x0 = 12, np.array([1.0, -0.5])
    w = np.vstack([np.sin(0.5 * np.arange(steps)), np.ones(steps)])
    mom = moments(CL, steps, inputs=w, initial_state=x0)
    sim = simulate(CL, steps, inputs=w, initial_state=x0, trials=20000,
                   seed=3)
    x = np.moveaxis(sim.states, 1, 0)        # [trial, state, time]
    assert_mean_within(x, mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       mom.states_second_moment, 5)


def test_event_level_protocol_validates_the_loop_with_mode_gains():
    P = two_state()
    K, CL, _ = passivesyn(P, decay=0.95)
    steps, x0 = 15, np.array([1.0, -0.5])
    t = np.arange(steps + 1)
    w = np.vstack([np.cos(0.3 * t), 0.5 * np.sin(0.2 * t)])
    mom = moments(CL, steps + 1, inputs=w, initial_state=x0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, P.sensor_link, P.actuator_link,
        K.gains, steps, inputs=w[:, :steps], initial_state=x0,
        trials=20000, rng=np.random.default_rng(5))
    x = sim["x"]
    assert_mean_within(x, mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       mom.states_second_moment, 5)


def test_event_level_protocol_validates_the_predictor_with_mode_gains():
    """The predictor's previous mode is (θ1,k, θ2,k-1) (theory: Markov losses): the
    protocol applies K_{k,ℓ} with it and matches the pair-mode loop."""
    P = two_state()
    K, CL, _ = passivesyn(P, controller="predictor", decay=0.95,
                          method="lmi")
    assert K.mode_dependent
    steps, x0 = 15, np.array([1.0, -0.5])
    t = np.arange(steps + 1)
    w = np.vstack([np.cos(0.3 * t), 0.5 * np.sin(0.2 * t)])
    xi0 = np.zeros(len(CL.jump_states))
    hat = [i for i, name in enumerate(CL.jump_states) if name.endswith("_hat")]
    xi0[hat] = x0                       # x̂0 = x0, e0 = 0
    mom = moments(CL, steps + 1, inputs=w, initial_state=xi0)
    S = plant_state_selector(CL, 2)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, P.sensor_link, P.actuator_link,
        K.gains, steps, controller="predictor", inputs=w[:, :steps],
        initial_state=x0, initial_estimate=x0, trials=20000,
        rng=np.random.default_rng(6))
    x = sim["x"]
    assert_mean_within(x, S @ mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       np.einsum("ia,abt,jb->ijt", S,
                                 mom.states_second_moment, S), 5)


def test_protocol_refuses_mode_gains_of_the_wrong_shape():
    with pytest.raises(ValueError, match="gains must have shape"):
        simulate_protocol([[2.0]], [[0.0]], [[1.0]], [[1.0]], [[0.0]],
                          [[0.0]], [[1]], [[1]], 0.1, 0.1,
                          np.zeros((1, 3, 1, 1)), 2)


# -- bad input ------------------------------------------------------------------
def test_unknown_gain_kind_is_refused_by_name():
    with pytest.raises(ControlArgument, match="gain"):
        passivesyn(scalar(2.0, 0.1), gain="previous")


def test_a_jump_plant_with_a_bad_transition_is_refused_by_name():
    plant = dataclasses.replace(two_mode_plant(),
                                transition=[[[0.5, 0.6], [0.5, 0.5]]])
    with pytest.raises(ValueError, match="transition"):
        passivesyn(plant)


# -- what the controller really observes of the previous mode -----------------
@pytest.mark.parametrize("network, controller, hidden", [
    # static gain, sensors silent at phase 1: θ1 of ℓ at phase 0 is unseen
    (dict(sensor_schedule=[[1, 1], [0, 0]]), "static", [0]),
    # predictor on a shared channel: at phase 2 neither bit of ℓ is seen
    (dict(sensor_schedule=[1, 2, 0], actuator_schedule=[0, 0, 1],
          shared_channel=True), "predictor", [2]),
])
def test_mode_gains_never_use_a_bit_of_the_previous_mode_that_is_not_seen(
        network, controller, hidden):
    # review finding: K_{k,ℓ} differed between previous modes that no arrival
    # or acknowledgement distinguishes, and the η claimed was not that of any
    # controller that can be built
    P = two_state().with_network(**network)
    K, CL, eta = ncs.passivesyn(P, controller=controller, decay=0.999,
                                method="lmi")
    assert K.mode_dependent and K.result.gain_kind == "mode"
    for k in hidden:
        assert np.allclose(K.gains[k], K.gains[k][0])
    assert "idle" in K.result.note
    # the loop closed from the gain alone is the one certified
    assert ncs.feedback(P, K, controller=controller).equals(CL)
    assert eta <= ncs.get_input_ff_index(CL) + 1e-6


def test_feedback_refuses_mode_gains_that_use_an_unseen_bit():
    P = two_state().with_network(sensor_schedule=[[1, 1], [0, 0]])
    gains = np.zeros((2, 4, 1, 2))
    gains[0, 1] = [[-0.5, -0.5]]       # ℓ = (1, 0) vs (0, 0): θ1 unseen
    with pytest.raises(ControlArgument, match="cannot tell these modes apart"):
        ncs.feedback(P, ncs.PeriodicGain(gains))
    gains[1, 1] = [[-0.5, -0.5]]       # phase 1: ℓ = (θ1,0, θ2,0), both seen
    gains[0, 1] = 0.0
    assert not ncs.feedback(P, ncs.PeriodicGain(gains)).modes.is_iid


def test_fully_observed_links_keep_gains_per_previous_mode():
    K, CL, eta = ncs.passivesyn(two_state(), decay=0.999)
    assert not K.result.note
    assert not np.allclose(K.gains[0], K.gains[0][0])


def test_refinement_on_markov_links_designs_phase_gains_only():
    P = two_state().with_network(sensor_schedule=[[1, 1], [0, 0]])
    with pytest.raises(ControlArgument, match="gain='phase'"):
        ncs.passivesyn(P, method="refine")
    K, CL, eta = ncs.passivesyn(P, method="refine", gain="phase",
                                decay=0.999, eta=-10.0)
    assert not K.mode_dependent and K.result.certificate.verified
    assert ncs.ms_radius(CL) < 0.999 ** 2
    # 'auto' keeps the LMI with gains per previous mode on Markov links
    K2, _, _ = ncs.passivesyn(P, decay=0.999, eta=-10.0)
    assert K2.mode_dependent and K2.result.method == "lmi"


@pytest.mark.parametrize("network, controller", [
    (dict(sensor_schedule=[[1, 1], [0, 0]]), "static"),
    (dict(sensor_schedule=[1, 2, 0], actuator_schedule=[0, 0, 1],
          shared_channel=True), "predictor"),
])
def test_default_call_on_markov_links_is_never_below_the_lmi(network,
                                                             controller):
    """Where the LMI is only sufficient the default call also refines a gain
    per phase, and keeps whichever certifies more."""
    P = two_state().with_network(**network)
    _, _, eta_lmi = ncs.passivesyn(P, controller=controller, decay=0.999,
                                   method="lmi")
    K, CL, eta = ncs.passivesyn(P, controller=controller, decay=0.999)
    assert K.result.certificate.verified
    assert eta >= eta_lmi - 1e-9 * max(1.0, abs(eta_lmi))
    assert ncs.feedback(P, K, controller=controller).equals(CL)
