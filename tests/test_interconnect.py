"""Interconnections with deterministic LTI systems (control_ncs.connect).

theory: moments: the mean of a jump system interconnected with a deterministic LTI
system is the interconnection of the means.
"""

import pickle

import matplotlib.pyplot as plt
import numpy as np
import pytest
import control as ct
from control.exception import ControlArgument, ControlDimension

import control_ncs as cn
import control_ncs as ncs
from control_ncs.connect import jump_feedback, lift_lti
from control_ncs.responses import simulate, step_response

A = [[1.1, 0.2], [0.0, 0.9]]
B = [[0.5, 0.1, 1.0], [1.0, 0.0, 0.5]]
C = [[1, 0], [0, 1], [1, 0], [0, 1]]
D = [[0.2, 0, 0], [0, 0.1, 0.3], [0, 0, 0], [0, 0, 0]]
K = [[-0.8, -0.3]]
DT = 0.1


def plant(**network):
    return cn.nss(A, B, C, D, DT, nmeas=2, ncon=1, sensor_loss=0.1,
                  actuator_loss=0.2, **network)


LOOPS = {
    "static-zero": lambda: cn.feedback(plant(), K),
    "static-hold": lambda: cn.feedback(plant(), K, actuator="hold"),
    "predictor-zero": lambda: cn.feedback(plant(), K, controller="predictor"),
    "predictor-hold": lambda: cn.feedback(plant(), [[-0.8, -0.3, 0.0]],
                                          controller="predictor",
                                          actuator="hold"),
    "static-scheduled": lambda: cn.feedback(plant(sensor_schedule=[1, 2]), K),
    "predictor-shared-channel": lambda: cn.feedback(
        plant(sensor_schedule=[1, 2, 0], actuator_schedule=[0, 0, 1],
              shared_channel=True), K, controller="predictor"),
}


def loop(kind):
    CL = LOOPS[kind]()
    assert cn.ms_radius(CL) < 1
    return CL


def filter_G(direct=True):
    """A deterministic 2×2 filter z → w, with or without feedthrough."""
    Dg = [[0.2, 0.1], [0.0, 0.3]] if direct else np.zeros((2, 2))
    return ct.ss([[0.3]], [[1.0, 0.5]], [[0.4], [0.1]], Dg, DT, name="G")


def assert_same_system(S1, S2, atol=1e-12):
    for X in "ABCD":
        np.testing.assert_allclose(getattr(S1, X), getattr(S2, X), atol=atol)
    assert S1.dt == S2.dt


@pytest.fixture(autouse=True)
def _close_figures():
    plt.close("all")
    yield
    plt.close("all")


# -- the mean is the interconnection of the means -----------------------------
@pytest.mark.parametrize("direct", [False, True], ids=["proper", "feedthrough"])
@pytest.mark.parametrize("kind", ["static-zero", "static-hold",
                                  "predictor-zero", "predictor-hold"])
def test_mean_of_jump_feedback_is_control_feedback(kind, direct):
    CL, G = loop(kind), filter_G(direct)
    assert_same_system(jump_feedback(CL, G), ct.feedback(CL.mean(), G))


@pytest.mark.parametrize("kind", ["static-scheduled",
                                  "predictor-shared-channel"])
def test_periodic_mean_is_control_feedback_with_the_lifted_filter(kind):
    CL, G = loop(kind), filter_G()
    assert_same_system(jump_feedback(CL, G),
                       ct.feedback(CL.mean(), lift_lti(G, CL.period)))


@pytest.mark.parametrize("sign", [-1, 1])
def test_every_mode_is_the_feedback_of_that_mode(sign):
    CL, G = loop("static-scheduled"), filter_G()
    L = jump_feedback(CL, G, sign=sign)
    assert L.period == CL.period and L.nmodes == CL.nmodes
    np.testing.assert_array_equal(L.modes.probabilities,
                                  CL.modes.probabilities)
    for k in range(CL.period):
        for i in range(CL.nmodes):
            mode = ct.ss(*CL.mode(k, i), DT)
            expected = ct.feedback(mode, G, sign=sign)
            for got, want in zip(L.mode(k, i), (expected.A, expected.B,
                                                expected.C, expected.D)):
                np.testing.assert_allclose(got, want, atol=1e-12)


def test_control_feedback_step_response_is_the_sample_mean_of_the_loop():
    # theory: moments through python-control alone: the step response of
    # control.feedback(CL, G) is E z of the sampled interconnection.
    CL, G = loop("static-zero"), filter_G()
    T = 20
    t = np.arange(T) * DT
    mean = ct.step_response(ct.feedback(CL.mean(), G), t, input=0).outputs[:, 0]
    r = step_response(jump_feedback(CL, G), t, input=0, trials=8000, seed=4,
                      quantiles=())
    np.testing.assert_allclose(r.exact_mean, mean, atol=1e-12)
    assert np.all(np.abs(r.sample_mean - mean) <= 5 * r.standard_error + 1e-12)


def test_scheduled_loop_sample_mean_is_the_lifted_feedback_response():
    # N = 2: the lifted face sees an input pulse at phase 0 of each period.
    CL, G = loop("static-scheduled"), filter_G()
    GL = lift_lti(G, 2)
    periods = 8
    lifted = ct.forced_response(ct.feedback(CL.mean(), GL),
                                np.arange(periods) * 0.2,
                                np.vstack([np.ones((1, periods)),
                                           np.zeros((3, periods))]))
    w = np.zeros((2, 2 * periods))
    w[0, ::2] = 1.0
    paths = simulate(jump_feedback(CL, G), 2 * periods, w, trials=8000,
                     seed=6)
    mean = lifted.outputs.reshape(2, 2, periods).transpose(1, 2, 0).reshape(
        2, -1)                                         # [z[0][k]...] → z(t)
    se = paths.outputs.std(axis=1) / np.sqrt(paths.trials)
    assert np.all(np.abs(paths.outputs.mean(axis=1) - mean) <= 5 * se + 1e-12)


def test_feedback_of_means_is_inexact_through_an_algebraic_loop():
    # Documented limit: B and C both switch with the mode and other has
    # feedthrough, so the input at time t depends on the mode drawn at t.
    sys = cn.jss([[[0.5]], [[0.5]]], [[[1.0]], [[0.0]]], [[[1.0]], [[0.0]]],
                 [[0.0]], [0.5, 0.5])
    gain = ct.ss([], [], [], [[0.5]], True)
    exact = jump_feedback(sys, gain)
    assert not np.allclose(exact.A, ct.feedback(sys.mean(), gain).A)
    # jump_feedback is the right one: compare with sampling
    paths = simulate(exact, 6, initial_state=[1.0], trials=20000, seed=1)
    se = paths.outputs.std(axis=1) / np.sqrt(paths.trials)
    want = ct.initial_response(exact.mean(), np.arange(6), [1.0]).outputs
    assert np.all(np.abs(paths.outputs.mean(axis=1) - want) <= 5 * se + 1e-12)
    # strictly proper other: exact again
    delayed = ct.ss([[0.0]], [[1.0]], [[0.5]], [[0.0]], True)
    assert_same_system(jump_feedback(sys, delayed),
                       ct.feedback(sys.mean(), delayed))


# -- arguments -----------------------------------------------------------------
def test_unity_and_static_gain_feedback():
    sys = cn.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.5]], [0.3, 0.7])
    assert_same_system(jump_feedback(sys), ct.feedback(sys, 1))
    assert_same_system(jump_feedback(sys, [[0.4]], sign=1),
                       ct.feedback(sys, 0.4, sign=1))


def test_transfer_function_is_accepted():
    sys = cn.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7],
                 dt=DT)
    H = ct.tf([0.2], [1.0, -0.5], DT)
    assert_same_system(jump_feedback(sys, H), ct.feedback(sys, H))


def test_result_is_a_picklable_jump_system_with_its_history():
    CL, G = loop("predictor-zero"), filter_G()
    L = jump_feedback(CL, G, name="loop")
    assert isinstance(L, cn.JumpStateSpace)
    assert L.name == "loop"
    assert L.jump_inputs == CL.jump_inputs
    assert L.jump_outputs == CL.jump_outputs
    assert L.jump_states == CL.jump_states + ["G.x[0]"]
    assert L.info["controller"] == "predictor"
    assert L.info["feedback"]["sign"] == -1
    assert pickle.loads(pickle.dumps(L)).equals(L)
    np.testing.assert_array_equal(L.nominal_mode, CL.nominal_mode)


def test_ill_posed_loop_is_rejected():
    sys = cn.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[[1.0]], [[2.0]]],
                 [0.3, 0.7])
    with pytest.raises(ValueError, match="not well posed in mode 0"):
        jump_feedback(sys, 1.0, sign=1)


def test_mismatched_sampling_time_is_rejected():
    CL = loop("static-zero")
    with pytest.raises(ValueError, match="dt"):
        jump_feedback(CL, ct.ss([[0.3]], [[1.0, 0.5]], [[0.4], [0.1]],
                                np.zeros((2, 2)), 0.2))


def test_continuous_time_other_is_rejected():
    CL = loop("static-zero")
    with pytest.raises(ValueError, match="continuous"):
        jump_feedback(CL, ct.ss([[-1.0]], [[1.0, 0.5]], [[0.4], [0.1]],
                                np.zeros((2, 2))))


def test_wrong_dimensions_are_rejected():
    with pytest.raises(ControlDimension, match="other"):
        jump_feedback(loop("static-zero"), ct.ss([], [], [], [[1.0]], DT))


def test_random_other_is_rejected():
    CL = loop("static-zero")
    with pytest.raises(ControlArgument, match="deterministic"):
        jump_feedback(CL, CL)


def test_unknown_keyword_raises_type_error():
    with pytest.raises(TypeError, match="bogus"):
        jump_feedback(loop("static-zero"), filter_G(), bogus=True)
    with pytest.raises(TypeError, match="bogus"):
        lift_lti(filter_G(), 2, bogus=True)


def test_lifting_one_step_is_the_system_itself():
    G = filter_G()
    assert_same_system(lift_lti(G, 1), G)
    with pytest.raises(ValueError, match="period"):
        lift_lti(G, 0)


# -- python-control on the mean face -------------------------------------------
def test_python_control_analysis_runs_on_the_face():
    CL = loop("static-zero")
    SISO = CL[0, 0]                          # a plain StateSpace of the mean
    assert ct.bode_plot(SISO).axes.shape == (2, 1)
    ct.nyquist_plot(SISO)
    np.testing.assert_allclose(ct.frequency_response(CL, [1.0]).frdata,
                               ct.frequency_response(CL.mean(), [1.0]).frdata)
    assert ct.ispassive(CL) == ct.ispassive(CL.mean())


def test_interconnect_closes_an_algebraic_loop_inside_each_mode():
    """Feedthrough both ways (``D = 0.5 or 1.5`` in the jump system, 0.3 in
    ``G``): python-control's own interconnect stops ("algebraic loop
    detected"); ours closes the loop mode by mode, as jump_feedback."""
    J = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[[0.5]], [[1.5]]],
                [0.3, 0.7], inputs="w", outputs="z", name="J")
    G = ct.ss([[0.2]], [[1.0]], [[1.0]], [[0.3]], True, inputs="z",
              outputs="v", name="G")
    S = ct.summing_junction(["r", "v"], "w", name="S", dt=True)
    with pytest.raises(RuntimeError, match="algebraic loop"):
        ct.interconnect([J.mode_system(0, 0), G, S], inplist=["r"],
                        outlist=["J.z"])
    L = ncs.interconnect([J, G, S], inplist=["r"], outlist=["J.z"])
    ref = ncs.jump_feedback(J, G, sign=1)
    assert L.nmodes == ref.nmodes == 2
    for i in range(2):
        Lm, Rm = L.mode_system(0, i), ref.mode_system(0, i)
        # same input-output map (state order may differ): compare Markov
        # parameters
        for t in range(4):
            a = Lm.D if t == 0 else Lm.C @ np.linalg.matrix_power(
                Lm.A, t - 1) @ Lm.B
            b = Rm.D if t == 0 else Rm.C @ np.linalg.matrix_power(
                Rm.A, t - 1) @ Rm.B
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    assert ncs.ms_radius(L) == pytest.approx(ncs.ms_radius(ref), rel=1e-10)


def test_interconnect_refuses_a_singular_algebraic_loop():
    J = ncs.jss([[[0.5]]], [[1.0]], [[1.0]], [[1.0]], [1.0], inputs="w",
                outputs="z", name="J")
    G = ct.ss([], [], [], [[1.0]], True, inputs="z", outputs="v", name="G")
    S = ct.summing_junction(["r", "v"], "w", name="S", dt=True)
    with pytest.raises(ValueError, match="algebraic loop is singular"):
        ncs.interconnect([J, G, S], inplist=["r"], outlist=["J.z"])
