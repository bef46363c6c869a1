"""The generic periodic jump system and its mean-system face (theory: moments, §10)."""

import copy
import pickle

import numpy as np
import control as ct
import pytest

from control_ncs import (JumpStateSpace, build, feedback, jss, lift,
                         mode_probabilities, moments)
from control_ncs.protocol import simulate_protocol

from helpers import assert_mean_within, random_jump, random_plant, scalar_plant

EQ14 = ((0, 0), (1, 0), (0, 1), (1, 1))


def phase_distribution_matches(sys, k, expected, atol=1e-12):
    """The modes of phase ``k`` of ``sys`` carry the same distribution over
    ``(A, B, C, D)`` as the list ``expected`` of ``(prob, A, B, C, D)``."""
    got = [(sys.modes.probabilities[k, i],) + sys.mode(k, i)
           for i in range(sys.nmodes)]

    def mass(table, mats):
        return sum(p for p, *M in table
                   if all(np.allclose(X, Y, atol=atol) for X, Y in zip(M, mats)))

    for _, *mats in expected + got:
        if not np.isclose(mass(got, mats), mass(expected, mats), atol=1e-12):
            return False
    return True


# -- construction and the N = 1 mean system --------------------------------
def test_mean_system_is_the_probability_weighted_mode_average():
    sys = random_jump(np.random.default_rng(0), n=3, N=1, M=3, m=2, p=2)
    p = sys.modes.probabilities[0]
    for face, stack in zip((sys.A, sys.B, sys.C, sys.D),
                           (sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D)):
        expect = sum(p[i] * stack[0, i] for i in range(3))
        assert np.allclose(face, expect, rtol=1e-13, atol=1e-13)


def test_jss_docstring_example_mean_is_point_four():
    # x⁺ = 2x + u, u = -2x with probability 0.8: E x⁺ = (0.2·2 + 0.8·0) E x
    sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    assert sys.A[0, 0] == pytest.approx(0.4, abs=1e-15)


def test_single_matrix_is_shared_by_all_modes_and_phases():
    A = [[[0.5, 0.0], [0.0, 0.1]], [[0.0, 1.0], [0.0, 0.0]]]
    sys = jss([A, A, A], [[1.0], [0.0]], [[1.0, 1.0]], [[0.0]],
              [[0.5, 0.5]] * 3)
    assert sys.period == 3 and sys.nmodes == 2
    for k in range(3):
        assert np.array_equal(sys.mode(k, 1)[1], [[1.0], [0.0]])
        assert np.array_equal(sys.mode(k, 1)[0], A[1])


def test_is_a_statespace_with_the_step_sampling_time():
    sys = random_jump(np.random.default_rng(1), n=2, N=1, dt=0.2)
    assert isinstance(sys, ct.StateSpace) and sys.dt == 0.2
    assert sys.dt_step == 0.2


def test_mode_and_mean_phase_accessors_wrap_the_phase():
    sys = random_jump(np.random.default_rng(2), n=2, N=3, M=2)
    A, B, C, D = sys.mode(4, 1)
    assert np.array_equal(A, sys.modes.A[1, 1])
    assert np.array_equal(D, sys.modes.D[1, 1])
    Abar = sys.mean_phase(5)[0]
    p = sys.modes.probabilities[2]
    assert np.allclose(Abar, p[0] * sys.modes.A[2, 0] + p[1] * sys.modes.A[2, 1])


# -- the lifted mean system (N > 1) ----------------------------------------
def manual_periodic_mean(sys, x0, w, periods):
    """Step the per-phase mean system by hand: states at period starts and
    outputs at every step."""
    N = sys.period
    x = np.array(x0, float)
    starts, outs = [], []
    for t in range(periods * N):
        Abar, Bbar, Cbar, Dbar = (sum(sys.modes.probabilities[t % N, i] * M[t % N, i]
                                      for i in range(sys.nmodes))
                                  for M in (sys.modes.A, sys.modes.B,
                                            sys.modes.C, sys.modes.D))
        if t % N == 0:
            starts.append(x.copy())
        outs.append(Cbar @ x + Dbar @ w[:, t])
        x = Abar @ x + Bbar @ w[:, t]
    starts.append(x)
    return np.array(starts).T, np.array(outs).T


def lifted_input(w, N):
    """Stack ``w`` (m, J·N) time-major per period: column j is
    ``[w[jN]; …; w[jN+N-1]]``."""
    m, T = w.shape
    return w.reshape(m, T // N, N).transpose(2, 0, 1).reshape(N * m, T // N)


def test_lifted_mean_system_matches_stepping_the_phases_by_hand():
    rng = np.random.default_rng(3)
    sys = random_jump(rng, n=3, N=3, M=2, m=2, p=2, radius=0.8)
    J, N = 4, 3
    w = rng.standard_normal((2, J * N))
    x0 = rng.standard_normal(3)
    starts, outs = manual_periodic_mean(sys, x0, w, J)
    resp = ct.forced_response(sys, T=np.arange(J), U=lifted_input(w, N), X0=x0)
    assert np.allclose(resp.states, starts[:, :J], atol=1e-12)
    # lifted outputs: column j = [z(jN); z(jN+1); …] time-major
    z_lifted = outs.reshape(2, J, N).transpose(2, 0, 1).reshape(N * 2, J)
    assert np.allclose(resp.outputs, z_lifted, atol=1e-12)


def test_lifted_mean_reproduces_exact_moments_at_period_boundaries():
    rng = np.random.default_rng(4)
    P = random_plant(rng, n=2, m1=1, sensor_schedule=[1, 2, 0],
                     actuator_schedule=[1, 1, 0], sensor_loss=0.2,
                     actuator_loss=0.1)
    CL = feedback(P, [[-0.5, -0.3]])
    N, J = CL.period, 5
    w = rng.standard_normal((1, N * J))
    x0 = np.array([1.0, -0.5])
    mom = moments(CL, N * J, inputs=w, initial_state=x0)
    resp = ct.forced_response(CL, T=np.arange(J), U=lifted_input(w, N), X0=x0)
    assert np.allclose(resp.states, mom.states_mean[:, ::N], atol=1e-12)
    zs = mom.outputs_mean.reshape(1, J, N).transpose(2, 0, 1).reshape(N, J)
    assert np.allclose(resp.outputs, zs, atol=1e-12)


def test_lifted_signals_are_named_time_major_and_dt_is_one_period():
    sys = random_jump(np.random.default_rng(5), n=2, N=2, m=2, p=1, dt=0.1)
    assert sys.input_labels == ["w[0][0]", "w[1][0]", "w[0][1]", "w[1][1]"]
    assert sys.output_labels == ["z[0][0]", "z[0][1]"]
    assert sys.dt == pytest.approx(0.2) and sys.dt_step == 0.1


def test_lift_of_a_constant_system_is_the_block_toeplitz_map():
    rng = np.random.default_rng(6)
    A, B = rng.standard_normal((2, 2)), rng.standard_normal((2, 1))
    C, D = rng.standard_normal((1, 2)), rng.standard_normal((1, 1))
    AL, BL, CL, DL = lift(*(np.array([X] * 3) for X in (A, B, C, D)))
    assert np.allclose(AL, A @ A @ A)
    assert np.allclose(BL, np.hstack([A @ A @ B, A @ B, B]))
    assert np.allclose(CL, np.vstack([C, C @ A, C @ A @ A]))
    assert np.allclose(DL, [[D[0, 0], 0, 0], [(C @ B)[0, 0], D[0, 0], 0],
                            [(C @ A @ B)[0, 0], (C @ B)[0, 0], D[0, 0]]])


# -- the nominal system and merging ----------------------------------------
def test_nominal_system_is_the_loss_free_loop():
    rng = np.random.default_rng(7)
    P = random_plant(rng, n=2, m1=1, sensor_loss=0.3, actuator_loss=0.4)
    K = np.array([[-0.4, -0.2]])
    nom = feedback(P, K).nominal()
    assert np.allclose(nom.A, P.A + P.B2 @ K @ P.C2)
    assert np.allclose(nom.C, P.C1 + P.D12 @ K @ P.C2)
    assert np.allclose(nom.B, P.B1) and np.allclose(nom.D, P.D11)


def test_nominal_needs_to_know_the_loss_free_mode():
    sys = random_jump(np.random.default_rng(8))
    with pytest.raises(ValueError, match="nominal"):
        sys.nominal()


def test_merged_adds_the_probabilities_of_coinciding_modes():
    A = np.array([[[0.5]], [[0.5]], [[0.1]]])
    sys = jss(A, [[1.0]], [[1.0]], [[0.0]], [0.2, 0.3, 0.5]).merged()
    assert sys.nmodes == 2
    assert phase_distribution_matches(sys, 0, [
        (0.5, [[0.5]], [[1.0]], [[1.0]], [[0.0]]),
        (0.5, [[0.1]], [[1.0]], [[1.0]], [[0.0]])])


def test_merging_all_four_network_modes_tolerates_rounding_above_one():
    """Found by hypothesis: at a silent phase the four eq. 14 modes merge,
    and for these losses their float sum is 1 + 2.2e-16."""
    a1, a2 = 0.030207406634994934, 0.65625
    total = 0.0
    for p in mode_probabilities(a1, a2).values():
        total += p           # left to right (Python 3.12's sum compensates)
    assert total > 1.0
    P = random_plant(np.random.default_rng(15), n=2,
                     sensor_schedule=[[1, 0], [0, 0]], sensor_loss=a1,
                     actuator_loss=a2)
    CL = feedback(P, [[-0.3, 0.1]])
    assert CL.modes.probabilities[1].max() == 1.0
    assert np.all((CL.modes.probabilities >= 0) & (CL.modes.probabilities <= 1))


def test_merging_keeps_the_mean_system():
    A = np.array([[[0.5]], [[0.5]], [[0.1]]])
    sys = jss(A, [[1.0]], [[1.0]], [[0.0]], [0.2, 0.3, 0.5])
    assert np.allclose(sys.merged().A, sys.A)


# -- closed loops built by feedback() --------------------------------------
def test_static_loop_has_the_two_modes_of_math_4():
    rng = np.random.default_rng(9)
    a1, a2 = 0.2, 0.3
    q = (1 - a1) * (1 - a2)
    P = random_plant(rng, n=2, m1=1, m2=2, sensor_schedule=[1, 2, 0],
                     actuator_schedule=[[1, 0], [1, 1], [0, 1]],
                     sensor_loss=a1, actuator_loss=a2)
    K = rng.standard_normal((2, 2))
    CL = feedback(P, K)
    S1 = [np.diag([1.0, 0]), np.diag([0, 1.0]), np.zeros((2, 2))]
    S2 = [np.diag([1.0, 0]), np.eye(2), np.diag([0, 1.0])]
    for k in range(3):
        F = S2[k] @ K @ S1[k]          # F_k = Σ2,k K_k Σ1,k
        closed = (P.A + P.B2 @ F, P.B1, P.C1 + P.D12 @ F, P.D11)
        opened = (P.A, P.B1, P.C1, P.D11)
        assert phase_distribution_matches(CL, k, [(q,) + closed,
                                                  (1 - q,) + opened])


def test_periodic_gains_make_the_loop_period_the_lcm():
    P = scalar_plant(1.5, sensor_schedule=[1, 1], actuator_loss=0.1)
    CL = feedback(P, [[[-1.0]], [[-1.2]], [[-0.8]]])
    assert CL.period == 6
    for k, kk in enumerate([-1.0, -1.2, -0.8] * 2):
        assert phase_distribution_matches(CL, k, [
            (0.9, [[1.5 + kk]], [[1.0]], [[1.0]], [[0.0]]),
            (0.1, [[1.5]], [[1.0]], [[1.0]], [[0.0]])])


def test_predictor_loop_has_the_modes_of_math_8b():
    rng = np.random.default_rng(10)
    a1, a2 = 0.25, 0.15
    s1, s2 = [1, 2, 0], [0, 0, 1]
    P = random_plant(rng, n=2, m1=1, sensor_schedule=s1, actuator_schedule=s2,
                     sensor_loss=a1, actuator_loss=a2, shared_channel=True)
    K = rng.standard_normal((1, 2))
    CL = feedback(P, K, controller="predictor")
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    I, Z = np.eye(2), np.zeros((2, 2))
    Sig1 = [np.diag([1.0, 0]), np.diag([0, 1.0]), Z]
    Sig2 = [0.0, 0.0, 1.0]
    prob = mode_probabilities(a1, a2)
    for k in range(3):
        expected = []
        # the transition k → k+1 depends on (θ1,k+1, θ2,k)
        for t1n, t2 in EQ14:
            R = t1n * Sig1[(k + 1) % 3]
            G = t2 * Sig2[k] * B2 @ K
            Acl = np.block([[A + G, R @ A], [Z, (I - R) @ A]])
            Bcl = np.vstack([R @ B1, (I - R) @ B1])
            Ccl = np.hstack([C1 + t2 * Sig2[k] * D12 @ K, C1])
            expected.append((prob[(t1n, t2)], Acl, Bcl, Ccl, D11))
        assert phase_distribution_matches(CL, k, expected)


def test_feedback_equals_closing_the_built_jump_plant():
    P = random_plant(np.random.default_rng(11), n=2, sensor_loss=0.1,
                     actuator_loss=0.2)
    K = np.array([[-0.3, 0.1]])
    JP = build(P)
    assert feedback(P, K).equals(JP.close(K[None]))
    assert JP.gain_shape() == (1, 1, 2)


def test_feedback_records_what_built_it():
    P = random_plant(np.random.default_rng(12), n=2)
    CL = feedback(P, [[0.1, 0.2, 0.3]], controller="predictor",
                  actuator="hold")
    assert CL.info["controller"] == "predictor"
    assert CL.info["actuator"] == "hold"
    assert np.array_equal(CL.info["gains"], [[[0.1, 0.2, 0.3]]])


# -- the StateSpace face is E z (theory: moments) -----------------------------------
def test_step_response_equals_the_monte_carlo_mean_of_the_loop():
    """control.step_response of the N = 1 loop vs 20000 event-level paths
    with w = 1: every time point within 4 sample standard errors."""
    rng = np.random.default_rng(13)
    P = random_plant(rng, n=2, m1=1, radius=1.05, sensor_loss=0.2,
                     actuator_loss=0.25)
    K = -ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0]
    CL = feedback(P, K)
    T = 25
    resp = ct.step_response(CL, T=np.arange(T))
    sim = simulate_protocol(P.A, P.B1, P.B2, P.C1, P.D11, P.D12, [[1, 1]],
                            [[1]], 0.2, 0.25, K[None], T,
                            inputs=np.ones((1, T)), trials=20000, rng=rng)
    assert_mean_within(sim["z"][:, 0, :], resp.outputs, n_se=4)
    # and the comparison has power: the loss-free loop's response differs
    nominal = ct.step_response(CL.nominal(), T=np.arange(T)).outputs
    assert np.max(np.abs(nominal - resp.outputs)) > 0.05


# -- python protocol -------------------------------------------------------
def closed_loop_example():
    P = random_plant(np.random.default_rng(14), n=2, sensor_schedule=[1, 2],
                     sensor_loss=0.1, actuator_loss=0.2, dt=0.05)
    return feedback(P, [[-0.2, -0.1, 0.3]], controller="predictor",
                    actuator="hold")


def test_pickle_round_trip_is_equal_and_keeps_type_names_and_info():
    CL = closed_loop_example()
    back = pickle.loads(pickle.dumps(CL))
    assert type(back) is JumpStateSpace and back.equals(CL)
    assert back.name == CL.name and back.jump_states == CL.jump_states
    assert back.dt == CL.dt and back.info["controller"] == "predictor"
    assert np.array_equal(back.nominal_mode, CL.nominal_mode)
    for X, Y in zip((back.A, back.B, back.C, back.D), (CL.A, CL.B, CL.C, CL.D)):
        assert np.array_equal(X, Y)


@pytest.mark.parametrize("duplicate", [copy.copy, copy.deepcopy])
def test_copies_are_equal_and_keep_the_type(duplicate):
    CL = closed_loop_example()
    dup = duplicate(CL)
    assert type(dup) is JumpStateSpace and dup.equals(CL) and dup is not CL


def test_equals_sees_different_probabilities():
    A = [[[0.5]], [[0.1]]]
    one = jss(A, [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5])
    two = jss(A, [[1.0]], [[1.0]], [[0.0]], [0.4, 0.6])
    assert not one.equals(two)
    assert one.equals(jss(A, [[1.0]], [[1.0]], [[0.0]], [0.5, 0.5]))


def test_repr_and_str_say_what_it_is():
    CL = closed_loop_example()
    r, s = repr(CL), str(CL)
    assert r.startswith("<JumpStateSpace") and "period 2" in r and "modes" in r
    assert s.startswith("<JumpStateSpace>:")   # python-control's layout
    assert "jump linear system" in s and "controller='predictor'" in s
    assert "Mean system lifted over one period" in s
