"""Output feedback through an estimator at the controller (theory: output feedback).

The builder ``controller='estimator'`` (gains ``K_k`` on ``x̂``, estimator
gains ``L_k``), its separation property and closed forms, the event-level
protocol, and ``estimator_gain`` (the exact LMI, verified exactly).
"""

import pickle

import control as ct
import numpy as np

import control_ncs as ncs
import pytest
from control.exception import ControlArgument, ControlDimension

from control_ncs import (PeriodicGain, ScheduleWarning, SynthesisError,
                         feedback, jss, moments, ms_radius, nss, passivesyn)
from control_ncs.strategies import require_state_measured
from control_ncs.estimator import estimation_error_loop, estimator_gain
from control_ncs.protocol import simulate_protocol

from helpers import (assert_mean_within, fourth_moment_rate,
                     plant_state_selector, random_plant)


def two_state(lam, a1=0.0, a2=0.0, **network):
    """x⁺ = diag(λ, 0.5) x + [1; 1] u (+ w), y = x1: one unstable
    eigenvalue λ, seen by the single output, reached by the single input."""
    return nss(np.diag([lam, 0.5]), [[1.0, 1.0], [0.3, 1.0]],
               [[1.0, 1.0], [1.0, 0.0]], np.zeros((2, 2)), True, nmeas=1,
               ncon=1, sensor_loss=a1, actuator_loss=a2, **network)


def output_plant(rng, **network):
    """Three states, two sensors y = C2 x (C2 random), two actuators."""
    A = rng.standard_normal((3, 3))
    A *= 1.1 / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((3, 3))
    C = rng.standard_normal((3, 3))
    D = np.zeros((3, 3))
    D[0, 0] = 0.5
    return nss(A, B, C, D, True, nmeas=2, ncon=2, **network)


def hat_loop(P, K):
    """x̂⁺ = (A + θ2,k B2 Σ2,k K) x̂, written from theory: output feedback directly."""
    N = P.period
    A = np.array([[P.A + t2 * P.B2 @ P.actuator_schedule.selection(k) @ K
                   for t2 in (0, 1)] for k in range(N)])
    a2 = P.actuator_loss
    return jss(A, np.ones((3, 1)), np.ones((1, 3)), 0,
               np.tile([a2, 1 - a2], (N, 1)))


# -- the builder -------------------------------------------------------------
@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_identity_measurement_and_gain_reproduce_the_predictor(actuator):
    P = random_plant(np.random.default_rng(0), n=2,
                     sensor_schedule=[1, 2, 0], actuator_schedule=[0, 0, 1],
                     sensor_loss=0.2, actuator_loss=0.3)
    K = [[-0.5, 0.2, 0.1]] if actuator == "hold" else [[-0.5, 0.2]]
    pred = feedback(P, K, controller="predictor", actuator=actuator)
    est = feedback(P, K, controller="estimator", actuator=actuator,
                   estimator_gain=np.eye(2))
    assert est.modes == pred.modes
    assert est.jump_states == pred.jump_states


def test_loop_rate_is_the_larger_of_the_error_and_estimate_loops():
    """Separation (theory: output feedback), with sensor and actuator schedules, any L, K."""
    rng = np.random.default_rng(5)
    P = output_plant(rng, sensor_schedule=[[1, 0], [0, 1]],
                     actuator_schedule=[[1, 1], [0, 1]], sensor_loss=0.15,
                     actuator_loss=0.25)
    for _ in range(3):
        L = 0.4 * rng.standard_normal((3, 2))
        K = 0.4 * rng.standard_normal((2, 3))
        CL = feedback(P, K, controller="estimator", estimator_gain=L)
        e = ms_radius(estimation_error_loop(P, L))
        hat = ms_radius(hat_loop(P, K))
        assert ms_radius(CL) == pytest.approx(max(e, hat), rel=1e-9)


@pytest.mark.parametrize("lam, a1, a2", [
    (2.0, 0.24, 0.10), (2.0, 0.10, 0.24), (2.0, 0.26, 0.10),
    (2.0, 0.10, 0.26), (1.5, 0.43, 0.43), (1.5, 0.45, 0.2)])
def test_explicit_gains_attain_max_of_alpha1_and_alpha2_lambda2(lam, a1, a2):
    """L = [1; 0], K = [-λ, 0] cancel λ on arrival: both loops are
    triangular, rate max(α1 λ², α2 λ², 0.5²). Near α λ² = 1 on both sides."""
    CL = feedback(two_state(lam, a1, a2), [[-lam, 0.0]],
                  controller="estimator", estimator_gain=[[1.0], [0.0]])
    rate = max(a1 * lam**2, a2 * lam**2, 0.25)
    assert ms_radius(CL) == pytest.approx(rate, rel=1e-10)
    assert (ms_radius(CL) < 1) == (a1 * lam**2 < 1 and a2 * lam**2 < 1)


def test_no_gains_beat_max_of_alpha1_and_alpha2_lambda2():
    """E e1⁺² ≥ α1 λ² e1² whatever L, E x̂1⁺² ≥ α2 λ² x̂1² whatever K: over a
    grid of gains the rate never drops below max(α1, α2) λ² = 1.04."""
    lam, a1, a2 = 2.0, 0.26, 0.2
    P = two_state(lam, a1, a2)
    rates = [ms_radius(feedback(P, [[-k, c]], controller="estimator",
                                estimator_gain=[[l], [0.3]]))
             for k in np.linspace(1, 3, 9) for l in np.linspace(0.5, 1.5, 9)
             for c in (0.0, 0.2)]
    assert min(rates) >= a1 * lam**2 * (1 - 1e-12)
    assert min(rates) == pytest.approx(a1 * lam**2, rel=1e-10)


# -- against the event-level protocol ----------------------------------------
def protocol_case(actuator):
    """Zero actuator: three states, two sensors y = C2 x over a period-3
    schedule. Hold actuator (its state has n + m2 + n coordinates, and the
    fourth-moment check costs O(n⁸)): the two-state plant without schedule,
    gains whose fourth moment stays close to the second's square."""
    if actuator == "zero":
        P = output_plant(np.random.default_rng(6),
                         sensor_schedule=[[1, 0], [0, 1], [1, 1]],
                         actuator_schedule=[[1, 0], [0, 1], [0, 0]],
                         sensor_loss=0.1, actuator_loss=0.1)
        K = -ct.dlqr(P.A, P.B2, np.eye(3), np.eye(2))[0]
        return P, K, estimator_gain(P).gains
    P = two_state(1.3, 0.1, 0.1)
    return P, np.array([[-0.4, 0.0, 0.0]]), estimator_gain(P).gains


@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_exact_moments_match_the_event_level_simulation(actuator):
    P, K, L = protocol_case(actuator)
    n = P.nstates
    CL = feedback(P, K, controller="estimator", actuator=actuator,
                  estimator_gain=L)
    steps = 20
    assert ms_radius(CL) < 1
    assert (fourth_moment_rate(CL) / ms_radius(CL) ** 2) ** steps < 10
    x0 = np.array([1.0, -0.5, 0.3])[:n]
    xi0 = np.zeros(len(CL.jump_states))
    xi0[[i for i, s in enumerate(CL.jump_states) if s.endswith("_hat")]] = x0
    w = np.sin(0.4 * np.arange(steps + 1))[None]
    mom = moments(CL, steps + 1, inputs=w, initial_state=xi0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, 0.1, 0.1,
        np.tile(K, (P.period, 1, 1)), steps,
        controller="estimator", actuator=actuator, C2=P.C2,
        estimator_gains=L, inputs=w[:, :steps], initial_state=x0,
        initial_estimate=x0, trials=20000, rng=np.random.default_rng(8))
    S = plant_state_selector(CL, n)
    x = sim["x"]
    assert_mean_within(x, S @ mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       np.einsum("ia,abt,jb->ijt", S,
                                 mom.states_second_moment, S), 5)
    assert_mean_within(sim["z"], mom.outputs_mean[:, :steps], 5)


# -- estimator_gain -------------------------------------------------------------
@pytest.mark.parametrize("a1", [0.1, 0.24])
def test_estimator_gain_is_verified_by_the_exact_error_rate(a1):
    P = two_state(2.0, a1)
    L = estimator_gain(P)
    assert L.ms_radius == pytest.approx(ms_radius(estimation_error_loop(P, L)),
                                        rel=1e-12)
    assert a1 * 4 * (1 - 1e-9) <= L.ms_radius < 1


def test_estimator_gain_respects_the_decay_bound():
    P = two_state(2.0, 0.1)
    L = estimator_gain(P, decay=0.8)
    assert ms_radius(estimation_error_loop(P, L)) < 0.64


def test_estimator_gain_works_through_a_sensor_schedule():
    P = output_plant(np.random.default_rng(6), sensor_schedule=[[1, 0],
                                                                [0, 1]],
                     sensor_loss=0.2)
    L = estimator_gain(P)
    assert L.gains.shape == (2, 3, 2)
    assert ms_radius(estimation_error_loop(P, L)) < 1
    # a silent sensor is never used: the gain's column for it is zero
    assert np.all(L.gains[0][:, 1] == 0) and np.all(L.gains[1][:, 0] == 0)


def test_loss_beyond_alpha1_lambda2_is_proven_infeasible():
    with pytest.raises(SynthesisError, match="at least 1.04") as err:
        estimator_gain(two_state(2.0, 0.26))
    assert err.value.reason == "infeasible"


def test_undetectable_plant_is_refused_before_solving():
    """The unstable state 1 is not measured by y = x2, and does not reach
    it: no estimator can see it."""
    P = nss(np.diag([2.0, 0.5]), [[1.0, 1.0], [1.0, 1.0]],
            [[1.0, 1.0], [0.0, 1.0]], np.zeros((2, 2)), True, nmeas=1, ncon=1)
    with pytest.raises(ValueError, match="not detectable through the sensor "
                       r"schedule.*eigenvalue 2"):
        estimator_gain(P)


def test_a_sensor_never_scheduled_makes_the_plant_undetectable():
    with pytest.warns(ScheduleWarning):
        P = output_plant(np.random.default_rng(6), sensor_schedule=[[0, 0]])
    with pytest.raises(ValueError, match="not detectable"):
        estimator_gain(P)


def test_estimator_gain_with_a_negated_lqr_gain_closes_a_stable_loop():
    P = output_plant(np.random.default_rng(7), sensor_loss=0.1,
                     actuator_loss=0.1)
    L = estimator_gain(P)
    Klqr, _, _ = ct.dlqr(P.A, P.B2, np.eye(3), np.eye(2))
    CL = feedback(P, -Klqr, estimator_gain=L)     # u = -Klqr x̂
    assert CL.info["controller"] == "estimator"
    assert ms_radius(CL) < 1


# -- bad input ----------------------------------------------------------------
def test_estimator_without_its_gain_is_refused():
    with pytest.raises(ControlArgument, match="estimator_gain: controller="
                       "'estimator' needs"):
        feedback(two_state(2.0), [[-2.0, 0.0]], controller="estimator")


def test_estimator_gain_of_the_wrong_shape_is_refused():
    with pytest.raises(ControlDimension, match=r"estimator_gain: expected "
                       r"L_k of shape \(2, 1\)"):
        feedback(two_state(2.0), [[-2.0, 0.0]], estimator_gain=np.eye(2))


def test_estimator_gain_is_refused_for_a_static_controller():
    with pytest.raises(ControlArgument, match="only controller='estimator'"):
        feedback(two_state(2.0), [[-2.0]], controller="static",
                 estimator_gain=[[1.0], [0.0]])


@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_state_feedback_design_without_y_equal_x_says_use_the_estimator(
        controller):
    with pytest.raises(ControlArgument, match="state-feedback gains need y "
                       "= x; use controller='estimator'"):
        require_state_measured(two_state(2.0), controller)


def test_continuous_time_plant_estimator_gain_input_is_checked():
    with pytest.raises(ControlArgument, match="P: expected a NetworkedState"):
        estimator_gain(ct.ss([[1.0]], [[1.0]], [[1.0]], [[0.0]], True))


# -- passivesyn(controller='estimator') -----------------------------------------
def measured_first(a1=0.1, a2=0.1, **network):
    """x⁺ = [[1.2, 1], [0, 0.5]] x + w + u, z = x1 + w, y = x1 (C2 = [1 0]):
    the unstable state is measured, the input reaches it through x2."""
    return nss([[1.2, 1.0], [0.0, 0.5]], [[1.0, 0.0], [0.3, 1.0]],
               [[1.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]], True,
               nmeas=1, ncon=1, sensor_loss=a1, actuator_loss=a2, **network)


def estimate_loop(P, K):
    """x̂⁺ = (A + θ2,k B2 Σ2,k K_k) x̂ (zero actuator), from theory: output feedback."""
    N = K.period
    A = np.array([[P.A + t2 * P.B2 @ P.actuator_schedule.selection(k) @ K[k]
                   for t2 in (0, 1)] for k in range(N)])
    n, a2 = P.nstates, P.actuator_loss
    return jss(A, np.ones((n, 1)), np.ones((1, n)), 0,
               np.tile([a2, 1 - a2], (N, 1)))


def test_passivesyn_estimator_with_identity_reproduces_the_predictor():
    P = random_plant(np.random.default_rng(3), n=2, sensor_loss=0.1,
                     actuator_loss=0.1)
    Kp, _, eta_p = passivesyn(P, controller="predictor", decay=0.99)
    Ke, _, eta_e = passivesyn(P, controller="estimator", decay=0.99,
                              estimator_gain=np.eye(2))
    assert Ke.controller == "estimator"
    assert np.array_equal(Ke.estimator_gain, np.eye(2)[None])
    assert eta_e == pytest.approx(eta_p, abs=1e-6)
    assert Ke.result.certificate.eta == pytest.approx(
        Kp.result.certificate.eta, abs=1e-6)


def test_passivesyn_designs_a_verified_estimator_controller_for_y_c2_x():
    P = measured_first()
    K, CL, eta = passivesyn(P, controller="estimator", decay=0.99)
    assert K.result.certificate.verified
    assert K.estimator_gain.shape == (1, 2, 1)
    assert ms_radius(CL) < 0.99 ** 2
    # the gain object alone closes the same loop
    assert ms_radius(feedback(P, K)) == pytest.approx(ms_radius(CL),
                                                      rel=1e-12)
    assert feedback(P, K).modes == CL.modes


def test_designed_loop_rate_is_the_larger_of_error_and_estimate_loops():
    P = measured_first(0.15, 0.2)
    K, CL, _ = passivesyn(P, controller="estimator", decay=0.99)
    e = ms_radius(estimation_error_loop(P, K.estimator_gain))
    hat = ms_radius(estimate_loop(P, K))
    assert ms_radius(CL) == pytest.approx(max(e, hat), rel=1e-9)


def test_closed_form_inside_alpha_lambda2_below_one_gets_a_verified_design():
    """λ = 2, α1 λ² = α2 λ² = 0.8 < 1."""
    P = two_state(2.0, 0.2, 0.2)
    K, CL, _ = passivesyn(P, controller="estimator")
    assert K.result.certificate.verified
    assert max(0.2, 0.2) * 4 * (1 - 1e-9) <= ms_radius(CL) < 1


@pytest.mark.parametrize("a1, a2", [(0.26, 0.1), (0.1, 0.26)])
def test_closed_form_outside_alpha_lambda2_below_one_is_proven_infeasible(
        a1, a2):
    """α1 λ² = 1.04 (no estimator) or α2 λ² = 1.04 (no gain on x̂)."""
    with pytest.raises(SynthesisError) as err:
        passivesyn(two_state(2.0, a1, a2), controller="estimator")
    assert err.value.reason == "infeasible"


def test_given_estimator_gain_with_an_unstable_error_loop_is_infeasible():
    """L = [1; 0] leaves the error rate α1 λ² = 1.04: by separation no K."""
    with pytest.raises(SynthesisError, match="separation") as err:
        passivesyn(two_state(2.0, 0.26, 0.1), controller="estimator",
                   estimator_gain=[[1.0], [0.0]])
    assert err.value.reason == "infeasible"
    assert err.value.figures["error_loop_ms_radius"] == pytest.approx(1.04)


def test_passivesyn_accepts_an_estimator_gain_object():
    P = measured_first()
    L = estimator_gain(P)
    K, CL, _ = passivesyn(P, controller="estimator", estimator_gain=L)
    assert np.array_equal(K.estimator_gain, L.gains)
    assert K.result.certificate.verified


def test_estimator_gain_of_another_period_gives_the_common_period():
    P = measured_first()
    L = np.array([[[0.9], [0.1]], [[1.0], [0.0]]])
    K, CL, _ = passivesyn(P, controller="estimator", estimator_gain=L)
    assert K.period == 2 and np.array_equal(K.estimator_gain, L)
    assert ms_radius(feedback(P, K)) == pytest.approx(ms_radius(CL),
                                                      rel=1e-12)


def test_unstabilisable_plant_is_refused_before_solving(monkeypatch):
    """The unstable state 1 is measured but no input reaches it."""
    import control_ncs.lmi as lmi

    def never(*args, **kwargs):
        raise AssertionError("solved")
    monkeypatch.setattr(lmi, "solve", never)
    P = nss(np.diag([2.0, 0.5]), [[1.0, 0.0], [1.0, 1.0]],
            [[1.0, 1.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]], True,
            nmeas=1, ncon=1)
    with pytest.raises(ValueError, match="not stabilisable through the "
                       r"actuator schedule.*eigenvalue 2"):
        passivesyn(P, controller="estimator")


def test_an_actuator_never_scheduled_makes_the_plant_unstabilisable():
    with pytest.warns(ScheduleWarning):
        P = measured_first(actuator_schedule=[[0]])
    with pytest.raises(ValueError, match="not stabilisable"):
        passivesyn(P, controller="estimator")


def test_undetectable_plant_is_refused_by_passivesyn_before_solving():
    P = nss(np.diag([2.0, 0.5]), [[1.0, 1.0], [1.0, 1.0]],
            [[1.0, 1.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 0.0]], True,
            nmeas=1, ncon=1)
    with pytest.raises(ValueError, match="not detectable"):
        passivesyn(P, controller="estimator")


@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_passivesyn_state_feedback_without_y_equal_x_says_use_the_estimator(
        controller):
    with pytest.raises(ControlArgument, match="state-feedback gains need y "
                       "= x; use controller='estimator'"):
        passivesyn(measured_first(), controller=controller)


def test_invertible_non_identity_c2_is_refused_for_static_gains_by_name():
    P = nss([[1.2]], [[1.0, 1.0]], [[1.0], [2.0]], [[1.0, 0.0], [0.0, 0.0]],
            True, nmeas=1, ncon=1)
    with pytest.raises(ControlArgument, match="state-feedback gains need y = x"):
        passivesyn(P)


def test_passivesyn_refuses_an_estimator_gain_for_other_controllers():
    P = random_plant(np.random.default_rng(3), n=2)
    with pytest.raises(ControlArgument, match="estimator_gain: only "
                       "controller='estimator'"):
        passivesyn(P, controller="predictor", estimator_gain=np.eye(2))


def test_passivesyn_estimator_gain_of_the_wrong_shape_is_refused():
    with pytest.raises(ControlDimension, match="estimator_gain: expected"):
        passivesyn(measured_first(), controller="estimator",
                   estimator_gain=np.eye(2))


# -- PeriodicGain carries the estimator gain ----------------------------------
def test_periodic_gain_keeps_a_read_only_estimator_gain():
    K = PeriodicGain([[-1.0, 0.2]], "estimator", estimator_gain=[[1.0], [0.0]])
    assert K.estimator_gain.shape == (1, 2, 1)
    with pytest.raises(ValueError):
        K.estimator_gain[0, 0, 0] = 2.0
    assert PeriodicGain([[-1.0]]).estimator_gain is None


def test_periodic_gain_equality_and_pickling_include_the_estimator_gain():
    K = PeriodicGain([[-1.0, 0.2]], "estimator", estimator_gain=[[1.0], [0.0]])
    other = PeriodicGain([[-1.0, 0.2]], "estimator",
                         estimator_gain=[[0.5], [0.0]])
    assert K != other
    assert K != PeriodicGain([[-1.0, 0.2]], "estimator")
    back = pickle.loads(pickle.dumps(K))
    assert back == K and not back.estimator_gain.flags.writeable
    assert "estimator_gain" in repr(K)


def test_periodic_gain_refuses_an_estimator_gain_for_other_controllers():
    with pytest.raises(ControlArgument, match="estimator_gain: only "
                       "controller='estimator'"):
        PeriodicGain([[-1.0, 0.2]], "predictor", estimator_gain=[[1.0], [0.0]])


def test_feedback_uses_the_estimator_gain_a_periodic_gain_carries():
    P = two_state(2.0, 0.2, 0.2)
    L = [[1.0], [0.0]]
    K = PeriodicGain([[-2.0, 0.0]], "estimator", estimator_gain=L)
    assert feedback(P, K).modes == feedback(
        P, [[-2.0, 0.0]], controller="estimator", estimator_gain=L).modes


def test_passivesyn_refuses_the_lti_controller_by_name():
    """An LTI controller is analysed, not designed: before this refusal the
    call solved an LMI and reported a misleading infeasibility."""
    with pytest.raises(ControlArgument, match="controller: passivesyn "
                       "designs gains"):
        passivesyn(two_state(2.0), controller="lti")


@pytest.mark.parametrize("actuator, gains", [
    ("zero", [[-1.0, 0.2]]), ("hold", [[-1.0, 0.2, 0.1]])])
def test_periodic_gain_refuses_an_estimator_gain_of_another_state_size(
        actuator, gains):
    with pytest.raises(ControlDimension, match="estimator_gain: expected L_k "
                       "with 2 rows"):
        PeriodicGain(gains, "estimator", actuator, estimator_gain=[[1.0]])


def test_estimator_design_summary_names_the_estimator_gain():
    K, _, _ = passivesyn(measured_first(), controller="estimator",
                         decay=0.99)
    assert "estimator gain L_k of shape (1, 2, 1)" in K.result.summary()


def test_estimator_design_with_hold_actuators_closes_the_same_loop():
    P = measured_first()
    K, CL, _ = passivesyn(P, controller="estimator", actuator="hold",
                          decay=0.99)
    assert K.result.certificate.verified and K.gains.shape == (1, 1, 3)
    assert feedback(P, K).modes == CL.modes


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(margin=-1.0), ValueError, "margin"),
    (dict(time_limit=0.0), ValueError, "time_limit"),
    (dict(solver="NOSUCHSOLVER"), ControlArgument,
     "solver: 'NOSUCHSOLVER'")])
def test_estimator_design_checks_its_options_before_solving(monkeypatch,
                                                            kwargs, error,
                                                            words):
    import control_ncs.lmi as lmi

    def never(*args, **kw):
        raise AssertionError("solved")
    monkeypatch.setattr(lmi, "solve", never)
    with pytest.raises(error, match=words):
        passivesyn(measured_first(), controller="estimator", options=kwargs)


def test_badly_scaled_plant_gets_an_estimator_and_a_verified_design():
    # a well-scaled plant under x = diag(1e3, 1e-3) x̃, measured through
    # y = x1: the estimator LMI is solved in balanced
    # coordinates and its gain checked in the plant's own
    import control_ncs as ncs
    P = ncs.nss([[0.9, 5e5], [2e-7, 1.2]], [[1e3, 1e3], [1e-3, 1e-3]],
                [[1e-3, 1e3], [1, 0]], [[1, 0], [0, 0]], nmeas=1, ncon=1,
                sensor_loss=0.05, actuator_loss=0.1)
    L = ncs.estimator_gain(P)
    assert L.ms_radius < 1
    assert ncs.ms_radius(ncs.estimation_error_loop(P, L)) == L.ms_radius
    K, CL, eta = ncs.passivesyn(P, controller="estimator", decay=0.99)
    assert K.result.certificate.verified and ncs.ms_radius(CL) < 0.99 ** 2


# -- bursty (Markov) sensor links ----------------------------------------------
def bursty_scalar(fail, recover, a=1.3):
    link = ncs.gilbert_elliott(fail=fail, recover=recover)
    P = ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, sensor_loss=link)
    return P, link.transition


def scalar_markov_error_rate(a, L, T):
    """Second moment of e⁺ = (1 - θ⁺ L) a e over the chain of θ⁺, written
    out: q⁺_j = Σ_i T[i, j] m_i² q_i with m_0 = a (lost), m_1 = (1 - L) a."""
    m2 = np.array([a ** 2, ((1.0 - L) * a) ** 2])
    op = T.T * m2[None, :]
    return max(abs(np.linalg.eigvals(op)))


def test_error_loop_over_a_bursty_sensor_link_has_the_markov_rate():
    """The i.i.d. formula at the stationary loss said 0.5633 here; bursts of
    ten steps make the error loop unstable."""
    P, T = bursty_scalar(0.05, 0.1)
    loop = ncs.estimation_error_loop(P, [[1.0 / 1.3]])
    assert loop.modes.transition is not None
    rate = ncs.ms_radius(loop)
    assert rate == pytest.approx(scalar_markov_error_rate(1.3, 1 / 1.3, T),
                                 rel=1e-12)
    assert rate == pytest.approx(1.5215295851895, rel=1e-12)


def test_no_estimator_gain_is_proven_when_the_link_stays_down_too_long():
    P, T = bursty_scalar(0.05, 0.1)
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.estimator_gain(P)
    assert info.value.reason == "infeasible"
    assert info.value.figures["lower_bound"] == pytest.approx(0.9 * 1.69)


def test_estimator_over_a_bursty_link_reaches_the_closed_form_optimum():
    """Deadbeat (L = 1) resets the error at every arrival, so the rate is
    that of staying down, T[0,0] a², which no gain can beat."""
    P, T = bursty_scalar(0.05, 0.5)
    L = ncs.estimator_gain(P)
    assert L.ms_radius == pytest.approx(T[0, 0] * 1.69, rel=1e-6)
    assert L.ms_radius == ncs.ms_radius(ncs.estimation_error_loop(P, L.gains))
    assert L.lyapunov.shape == (1, 2, 1, 1)


@pytest.mark.parametrize("loss", [0.2, 0.35])
def test_a_bursty_link_with_equal_rows_gives_the_bernoulli_estimator(loss):
    P, _ = bursty_scalar(loss, 1.0 - loss, a=1.2)
    Q = P.with_network(sensor_loss=loss)
    rate_markov = ncs.ms_radius(ncs.estimation_error_loop(P, [[0.7]]))
    rate_iid = ncs.ms_radius(ncs.estimation_error_loop(Q, [[0.7]]))
    assert rate_markov == pytest.approx(rate_iid, rel=1e-12)
    assert ncs.estimator_gain(P).ms_radius == pytest.approx(
        ncs.estimator_gain(Q).ms_radius, rel=1e-5)


def test_markov_error_loop_moments_match_monte_carlo():
    P, _ = bursty_scalar(0.1, 0.4, a=1.1)
    loop = ncs.estimation_error_loop(P, [[0.6]])
    steps = 25
    exact = ncs.moments(loop, steps, initial_state=[1.0])
    paths = ncs.simulate(loop, steps, initial_state=[1.0], trials=40000,
                         seed=3)
    second = np.mean(paths.outputs[0] ** 2, axis=0)
    want = exact.outputs_cov[0, 0] + exact.outputs_mean[0] ** 2
    sigma = np.std(paths.outputs[0] ** 2, axis=0) / np.sqrt(40000)
    assert np.all(np.abs(second - want) <= 5 * sigma + 1e-12)


def test_estimator_over_bursty_links_matches_the_event_level_protocol():
    """The whole loop (estimator, gain, both links bursty) against packets:
    the protocol draws each link's Gilbert–Elliott chain itself."""
    ge1 = ncs.gilbert_elliott(fail=0.1, recover=0.5)
    ge2 = ncs.gilbert_elliott(fail=0.05, recover=0.6)
    P = output_plant(np.random.default_rng(6),
                     sensor_schedule=[[1, 0], [0, 1], [1, 1]],
                     actuator_schedule=[[1, 0], [0, 1], [0, 0]],
                     sensor_loss=ge1, actuator_loss=ge2)
    K = -ct.dlqr(P.A, P.B2, np.eye(3), np.eye(2))[0]
    L = estimator_gain(P)
    assert L.ms_radius == ms_radius(estimation_error_loop(P, L.gains))
    CL = feedback(P, K, controller="estimator", estimator_gain=L)
    assert CL.modes.transition is not None and ms_radius(CL) < 1
    steps, n = 20, P.nstates
    x0 = np.array([1.0, -0.5, 0.3])
    xi0 = np.zeros(len(CL.jump_states))
    xi0[[i for i, s in enumerate(CL.jump_states) if s.endswith("_hat")]] = x0
    w = np.sin(0.4 * np.arange(steps + 1))[None]
    mom = moments(CL, steps + 1, inputs=w, initial_state=xi0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, ge1, ge2,
        np.tile(K, (P.period, 1, 1)), steps,
        controller="estimator", C2=P.C2, estimator_gains=L.gains,
        inputs=w[:, :steps], initial_state=x0, initial_estimate=x0,
        trials=20000, rng=np.random.default_rng(8))
    S = plant_state_selector(CL, n)
    assert_mean_within(sim["x"], S @ mom.states_mean, 5)
    assert_mean_within(sim["z"], mom.outputs_mean[:, :steps], 5)
