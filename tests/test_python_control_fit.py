"""control_ncs fits python-control like a native.

python-control's own calls on a closed loop keep the randomness where the
result is exact (mode by mode, theory: moments, §10), refuse clearly where it is
not, and the package's objects print, warn and accept inputs as
python-control's do.
"""

import pickle

import numpy as np
import pytest
import control as ct
from control.exception import ControlArgument

import control_ncs as cn
import control_ncs as ncs
from control_ncs.connect import jump_feedback

DT = 0.1


def plant(**network):
    A = [[1.1, 0.2], [0.0, 0.9]]
    B = [[0.5, 0.1, 1.0], [1.0, 0.0, 0.5]]
    C = [[1, 0], [0, 1], [1, 0], [0, 1]]
    D = [[0.2, 0, 0], [0, 0.1, 0.3], [0, 0, 0], [0, 0, 0]]
    return cn.nss(A, B, C, D, DT, nmeas=2, ncon=1, sensor_loss=0.1,
                  actuator_loss=0.2, name="reactor", **network)


def lossy_loop():
    return cn.feedback(plant(), [[-0.8, -0.3]])


def scheduled_loop():
    return cn.feedback(plant(sensor_schedule=[1, 2]), [[-0.8, -0.3]])


def filter_G(direct=True):
    """A deterministic 2×2 filter z → w, with or without feedthrough."""
    Dg = [[0.2, 0.1], [0.0, 0.3]] if direct else np.zeros((2, 2))
    return ct.ss([[0.3]], [[1.0, 0.5]], [[0.4], [0.1]], Dg, DT, name="G")


def switching_loop():
    """B and C both switch with the mode: the mean of a loop through a
    feedthrough is not the loop of the means (0.25 vs 0.29)."""
    return cn.jss([[[0.5]], [[0.5]]], [[[1.0]], [[0.0]]], [[[1.0]], [[0.0]]],
                  [[0.0]], [0.5, 0.5])


def assert_same_jump_system(S1, S2, atol=1e-12):
    assert isinstance(S1, cn.JumpStateSpace) and isinstance(
        S2, cn.JumpStateSpace)
    np.testing.assert_array_equal(S1.modes.probabilities,
                                  S2.modes.probabilities)
    for X in "ABCD":
        np.testing.assert_allclose(getattr(S1.modes, X), getattr(S2.modes, X),
                                   atol=atol)
    assert S1.dt_step == S2.dt_step


def assert_modewise(result, sys, op):
    """Every mode of ``result`` is python-control's ``op`` of that mode."""
    assert isinstance(result, cn.JumpStateSpace)
    np.testing.assert_array_equal(result.modes.probabilities,
                                  sys.modes.probabilities)
    for k in range(sys.period):
        for i in range(sys.nmodes):
            want = op(ct.ss(*sys.mode(k, i), sys.dt_step))
            for got, X in zip(result.mode(k, i), (want.A, want.B, want.C,
                                                  want.D)):
                np.testing.assert_allclose(got, X, atol=1e-12)


# -- 1. hashable, identity equality, as python-control's systems --------------
def test_jump_system_is_a_dict_key_by_identity():
    CL = lossy_loop()
    twin = cn.jss(CL.modes.A, CL.modes.B, CL.modes.C, CL.modes.D,
                  CL.modes.probabilities, CL.dt_step,
                  nominal=CL.nominal_mode, inputs=CL.jump_inputs,
                  outputs=CL.jump_outputs)
    table = {CL: "loop", twin: "twin"}
    assert table[CL] == "loop" and table[twin] == "twin"
    assert CL != twin and twin.equals(CL)
    assert hash(CL) == hash(CL)


def test_networked_plant_is_hashable_by_identity():
    P = plant()
    assert {P: 1}[P] == 1 and P != plant() and P.equals(plant())


def test_control_interconnect_accepts_a_jump_system_and_sees_its_mean():
    CL = lossy_loop()
    W = ct.ss([[0.8]], [[1.0]], [[0.2]], [[0.0]], DT, name="W",
              inputs="d", outputs=CL.jump_inputs[0])
    connections = dict(inplist=["d", CL.jump_inputs[1]],
                       outlist=CL.jump_outputs)
    mean = ct.interconnect([W, CL], **connections)
    exact = cn.interconnect([W, CL], **connections)
    # no algebraic loop through mode-dependent matrices: exact for E z
    for X in "ABCD":
        np.testing.assert_allclose(getattr(mean, X), getattr(exact, X),
                                   atol=1e-12)


# -- 2. algebra keeps the randomness ----------------------------------------
@pytest.mark.parametrize("direct", [False, True], ids=["proper", "feedthrough"])
def test_control_feedback_is_jump_feedback(direct):
    CL, G = lossy_loop(), filter_G(direct)
    loop = ct.feedback(CL, G)
    assert_same_jump_system(loop, jump_feedback(CL, G))
    assert loop.jump_inputs == CL.jump_inputs
    assert loop.jump_states == CL.jump_states + ["G.x[0]"]


@pytest.mark.parametrize("sign", [-1, 1])
def test_control_feedback_of_a_periodic_loop_is_jump_feedback(sign):
    CL, G = scheduled_loop(), filter_G()
    assert CL.period == 2
    assert_same_jump_system(ct.feedback(CL, G, sign=sign),
                            jump_feedback(CL, G, sign=sign))


def test_feedback_through_an_algebraic_loop_keeps_the_exact_ms_radius():
    sys, gain = switching_loop(), ct.ss([], [], [], [[0.5]], True)
    loop = ct.feedback(sys, gain)
    exact = jump_feedback(sys, gain)
    assert_same_jump_system(loop, exact)
    assert cn.ms_radius(loop) == pytest.approx(cn.ms_radius(exact), abs=1e-12)
    # the mean's loop, once returned silently, has another radius
    of_means = cn.ms_radius(ct.feedback(sys.mean(), gain))
    assert abs(of_means - cn.ms_radius(loop)) > 0.01


def test_feedback_through_an_algebraic_loop_matches_monte_carlo():
    sys, gain = switching_loop(), ct.ss([], [], [], [[0.5]], True)
    loop = ct.feedback(sys, gain)
    m = cn.moments(loop, 6, initial_state=[1.0])
    paths = cn.simulate(loop, 6, initial_state=[1.0], trials=20000, seed=1)
    se = paths.outputs.std(axis=1) / np.sqrt(paths.trials)
    err = np.abs(paths.outputs.mean(axis=1) - m.outputs_mean)
    assert np.all(err <= 5 * se + 1e-12)
    second = (paths.outputs ** 2).mean(axis=1)
    want = m.outputs_cov[0, 0] + m.outputs_mean[0] ** 2
    se2 = (paths.outputs ** 2).std(axis=1) / np.sqrt(paths.trials)
    assert np.all(np.abs(second - want) <= 5 * se2 + 1e-12)


OPERATIONS = {
    "CL * G": (lambda CL, G: CL * G, lambda S, G: S * G),
    "G * CL": (lambda CL, G: G * CL, lambda S, G: G * S),
    "CL + G": (lambda CL, G: CL + G, lambda S, G: S + G),
    "G + CL": (lambda CL, G: G + CL, lambda S, G: G + S),
    "CL - G": (lambda CL, G: CL - G, lambda S, G: S - G),
    "G - CL": (lambda CL, G: G - CL, lambda S, G: G - S),
    "series(CL, G)": (lambda CL, G: ct.series(CL, G),
                      lambda S, G: ct.series(S, G)),
    "series(G, CL)": (lambda CL, G: ct.series(G, CL),
                      lambda S, G: ct.series(G, S)),
    "parallel(G, CL)": (lambda CL, G: ct.parallel(G, CL),
                        lambda S, G: ct.parallel(G, S)),
    "append(CL, G)": (lambda CL, G: ct.append(CL, G),
                      lambda S, G: ct.append(S, G)),
    "feedback(CL, G)": (lambda CL, G: ct.feedback(CL, G),
                        lambda S, G: ct.feedback(S, G)),
}


@pytest.mark.parametrize("loop", [lossy_loop, scheduled_loop],
                         ids=["N=1", "N=2"])
@pytest.mark.parametrize("name", list(OPERATIONS))
def test_python_control_operation_is_built_mode_by_mode(name, loop):
    jump_op, mode_op = OPERATIONS[name]
    CL, G = loop(), filter_G()
    result = jump_op(CL, G)
    assert_modewise(result, CL, lambda S: mode_op(S, G))
    assert result.nominal_mode.tolist() == CL.nominal_mode.tolist()
    assert result.dt_step == CL.dt_step


@pytest.mark.parametrize("op", [lambda CL: -CL, lambda CL: 2.0 * CL,
                                lambda CL: CL * 0.5, lambda CL: CL - 1.0,
                                lambda CL: np.array([[1.0, 2.0]]) @ np.eye(2)
                                * CL[:, 0]],
                         ids=["neg", "scalar*", "*scalar", "-scalar", "array*"])
def test_scalar_and_array_operands_stay_jump_systems(op):
    CL = lossy_loop()
    assert isinstance(op(CL), cn.JumpStateSpace)


def test_negation_is_mode_by_mode():
    CL = lossy_loop()
    assert_modewise(-CL, CL, lambda S: -S)


def test_series_keeps_the_mean_square_radius_of_the_exact_construction():
    # a stable deterministic filter in series does not change mean-square
    # stability: the radius is the larger of the two
    CL, G = lossy_loop(), filter_G(direct=False)
    assert cn.ms_radius(ct.series(G, CL)) == pytest.approx(
        max(cn.ms_radius(CL), 0.3 ** 2), rel=1e-9)


def test_indexing_selects_per_step_signals_mode_by_mode():
    CL = scheduled_loop()
    one = CL[1, 0]
    assert_modewise(one, CL, lambda S: S[1, 0])
    assert one.jump_outputs == [CL.jump_outputs[1]]
    assert one.jump_inputs == [CL.jump_inputs[0]]
    assert CL[:, 1:].jump_inputs == CL.jump_inputs[1:]


def test_moments_of_a_series_are_the_exact_mean_of_the_series():
    CL, G = lossy_loop(), filter_G()
    S = G * CL
    r = cn.moments(S, 8, inputs=np.ones((2, 8)))
    want = ct.forced_response(S.mean(), np.arange(8) * DT,
                              np.ones((2, 8))).outputs
    np.testing.assert_allclose(r.outputs_mean, want, atol=1e-12)


def test_transfer_function_on_the_right_is_converted():
    CL = lossy_loop()
    H = ct.tf([0.2], [1.0, -0.5], DT)
    assert_modewise(CL[0, 0] * H, CL[0, 0], lambda S: S * ct.ss(H))


def test_two_jump_systems_are_refused_with_the_reason():
    CL = lossy_loop()
    for op in (lambda: CL * CL, lambda: CL + CL, lambda: ct.feedback(
            CL, CL[:, :]), lambda: ct.append(CL, CL), lambda: CL ** 2):
        with pytest.raises(ControlArgument, match="jump system"):
            op()
    with pytest.raises(ControlArgument, match="independent"):
        CL * CL


def test_networked_plant_operand_is_refused():
    with pytest.raises(ControlArgument, match="NetworkedStateSpace"):
        lossy_loop() * plant()


def test_lifted_operand_is_refused_with_the_base_rate_hint():
    CL = scheduled_loop()
    with pytest.raises(ValueError, match="base rate"):
        ct.feedback(CL, cn.lift_lti(filter_G(), 2))


def test_continuous_time_operand_is_refused():
    with pytest.raises(ValueError, match="continuous-time"):
        lossy_loop()[0, 0] * ct.tf([1], [1, 1])


def test_inverse_is_mode_by_mode():
    sys = cn.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[[2.0]], [[4.0]]],
                 [0.3, 0.7])
    assert_modewise(sys ** -1, sys, lambda S: S ** -1)


def test_series_names_are_applied_to_the_per_step_signals():
    CL, G = lossy_loop(), filter_G()
    S = ct.series(CL, G, inputs=["a", "b"], outputs=["c", "d"], name="S")
    assert S.name == "S" and S.jump_inputs == ["a", "b"]
    assert S.input_labels == ["a", "b"] and S.jump_outputs == ["c", "d"]


# -- 3. interconnect by names, mode by mode ------------------------------------
def disturbance_model(CL):
    return ct.ss([[0.8]], [[1.0]], [[0.2]], [[0.0]], DT, name="W",
                 inputs="d", outputs=CL.jump_inputs[0])


def test_interconnect_by_names_is_the_series_mode_by_mode():
    CL = lossy_loop()
    W = disturbance_model(CL)
    sys = cn.interconnect([W, CL], inplist=["d", CL.jump_inputs[1]],
                          outlist=CL.jump_outputs, name="shaped")
    assert sys.name == "shaped" and sys.nmodes == CL.nmodes
    shaped = CL * ct.append(W, ct.ss([], [], [], [[1.0]], DT))
    assert cn.ms_radius(sys) == pytest.approx(cn.ms_radius(shaped), rel=1e-12)
    r1 = cn.moments(sys, 6, inputs=np.ones((2, 6)))
    r2 = cn.moments(shaped, 6, inputs=np.ones((2, 6)))
    np.testing.assert_allclose(r1.outputs_mean, r2.outputs_mean, atol=1e-12)
    np.testing.assert_allclose(r1.outputs_cov, r2.outputs_cov, atol=1e-12)


def test_interconnect_closes_an_algebraic_loop_in_each_mode():
    sys, gain = switching_loop(), ct.ss([], [], [], [[0.5]], True)
    sys.update_names(name="J", inputs="w", outputs="z")
    gain.update_names(name="K", inputs="z", outputs="v")
    summer = ct.summing_junction(["r", "v"], "w", name="sum")
    loop = cn.interconnect([sys, gain, summer], inplist="r", outlist="z")
    assert cn.ms_radius(loop) == pytest.approx(
        cn.ms_radius(jump_feedback(sys, gain, sign=1)), rel=1e-12)


def test_interconnect_of_a_periodic_loop_keeps_its_phases():
    CL = scheduled_loop()
    sys = cn.interconnect([disturbance_model(CL), CL],
                          inplist=["d", CL.jump_inputs[1]],
                          outlist=CL.jump_outputs)
    assert sys.period == 2 and sys.dt == 2 * DT and sys.dt_step == DT
    np.testing.assert_array_equal(sys.modes.probabilities,
                                  CL.modes.probabilities)


def test_interconnect_refuses_two_jump_systems():
    CL = lossy_loop()
    other = cn.jss(CL.modes.A, CL.modes.B, CL.modes.C, CL.modes.D,
                   CL.modes.probabilities, DT, name="other")
    with pytest.raises(ControlArgument, match="independent"):
        cn.interconnect([CL, other])


def test_interconnect_without_a_jump_system_points_to_control():
    with pytest.raises(ControlArgument, match="control.interconnect"):
        cn.interconnect([filter_G()])


def test_interconnect_unknown_keyword_raises_type_error():
    CL = lossy_loop()
    with pytest.raises(TypeError):
        cn.interconnect([CL], bogus=1)


# -- 4. period N > 1: the base-rate view -----------------------------------
def test_phase_is_the_base_rate_mean_of_that_phase():
    CL = scheduled_loop()
    for k in range(CL.period):
        S = CL.phase(k)
        assert type(S) is ct.StateSpace and S.dt == DT
        assert S.input_labels == CL.jump_inputs
        for got, want in zip((S.A, S.B, S.C, S.D), CL.mean_phase(k)):
            np.testing.assert_array_equal(got, want)
    assert CL.phase(3).A.tolist() == CL.phase(1).A.tolist()


def test_phase_of_a_one_phase_loop_is_its_mean():
    CL = lossy_loop()
    np.testing.assert_array_equal(CL.phase(0).A, CL.A)


# -- 6. inputs like python-control's ------------------------------------------
def test_schedule_that_never_lets_a_sensor_send_warns_naming_it():
    with pytest.warns(cn.ScheduleWarning, match=r"sensor 2 \(y\[1\]\) never "
                      r"sends") as record:
        plant(sensor_schedule=[0, 1])
    # stacklevel names the caller's line, not a line inside control_ncs
    assert record[0].filename == __file__


def test_schedule_that_never_lets_an_actuator_send_warns_naming_it():
    P = ct.ss([[0.5]], [[1.0, 1.0, 1.0]], [[1.0], [1.0]], np.zeros((2, 3)),
              True, inputs=["w", "u1", "u2"], outputs=["z", "y"])
    with pytest.warns(cn.ScheduleWarning, match=r"actuator 2 \(u2\)"):
        cn.nss(P, nmeas=1, ncon=2, actuator_schedule=[0, 1])


def test_schedule_where_every_node_sends_does_not_warn():
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P = plant(sensor_schedule=[1, 2, 0])
        P2 = pickle.loads(pickle.dumps(P))
    assert P2.period == 3


def test_unpickling_does_not_warn_again():
    import warnings
    with pytest.warns(cn.ScheduleWarning):
        P = plant(sensor_schedule=[0, 1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pickle.loads(pickle.dumps(P))


# -- 5. results like python-control's and SciPy's -----------------------------
def test_closed_loop_is_named_after_its_plant():
    assert lossy_loop().name == "reactor (closed loop)"
    assert cn.build(plant()).close(np.array([[[-0.8, -0.3]]])).name == \
        "reactor (closed loop)"


def _results():
    """One of every public result, at sizes where whole arrays are long."""
    CL = scheduled_loop()
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    r = cn.step_response(CL, 200, input=0, trials=300, keep_paths=50, seed=0)
    return dict(
        certificate=cn.verify.check_certificate(G, [[1.0]], 0.3),
        passivity=cn.passivity_certificate(G),
        refuted=cn.passivity_certificate(G, 0.4),
        lmi_route=cn.passivity_certificate(CL, 0.0),
        moments=cn.moments(CL, 200, inputs=np.ones((2, 200))),
        paths=cn.simulate(CL, 200, trials=300, seed=0),
        ensemble=r,
        schedule=cn.schedule(np.arange(60) % 3, 2),
        modes=CL.modes,
        jump=CL,
        plant=plant(sensor_schedule=[1, 2, 0]),
        jump_plant=cn.build(plant()),
    )


def test_repr_of_every_public_result_fits_in_a_screen():
    for name, obj in _results().items():
        text = repr(obj)
        assert len(text) <= 2000 and text.count("\n") < 25, name
        assert type(obj).__name__ in text, name


def test_every_result_has_a_short_summary():
    for name, obj in _results().items():
        if not hasattr(obj, "summary"):
            continue
        text = obj.summary()
        assert isinstance(text, str) and text.count("\n") < 25, name
        assert len(text) <= 2000, name


def test_verdicts_share_verdict_status_and_message():
    res = _results()
    for name, verdict, status in (("certificate", True, "certified"),
                                  ("passivity", True, "certified"),
                                  ("refuted", False, "infeasible")):
        obj = res[name]
        assert obj.verdict is verdict and obj.status == status, name
        assert isinstance(obj.message, str) and obj.message, name
    assert "proven" in res["refuted"].message


def test_certificate_that_fails_says_why_in_its_message():
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    cert = cn.verify.check_certificate(G, [[1.0]], 0.4)
    assert not cert.verdict and not cert.success
    assert cert.status == "not_verified"
    assert "λmax(Θ_k)" in cert.message and "not_verified" in repr(cert)
    assert "λmax(Θ_k)" in cert.summary()


def test_cvxpy_inaccuracy_warning_does_not_leak_from_passivity(monkeypatch):
    import warnings
    import cvxpy as cp
    real = cp.Problem.solve

    def warning_solve(self, *args, **kwargs):
        # cvxpy's own warning whenever its status is 'optimal_inaccurate',
        # raised where cvxpy raises it: inside Problem.solve
        warnings.warn("Solution may be inaccurate. Try another solver, "
                      "adjusting the solver settings, or solve with "
                      "verbose=True for more information.", UserWarning,
                      stacklevel=2)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(cp.Problem, "solve", warning_solve)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = cn.passivity_certificate(lossy_loop()[:, :], 0.0)
    assert result.method == "lmi" and result.status in (
        "certified", "infeasible", "inaccurate", "not_verified",
        "solver_failed", "feedthrough", "not_mss")


def test_ensemble_plot_title_says_mean():
    import matplotlib.pyplot as plt
    r = cn.step_response(lossy_loop(), 10, input=0, trials=20, seed=0)
    assert "mean" in r.title
    cplt = cn.plot_ensemble(r)
    assert "mean" in cplt.figure._suptitle.get_text()
    plt.close("all")


def test_moments_plot_title_says_mean():
    data = cn.moments(lossy_loop(), 5, initial_state=[1.0, 0.0]).to_response()
    assert "mean" in data.title


def test_transfer_function_is_accepted_where_a_system_is():
    H = ct.tf([1.0, 0.0], [1.0, -0.5], True)
    assert cn.ms_radius(H) == pytest.approx(0.25)
    r = cn.moments(H, 4, inputs=np.ones((1, 4)))
    want = ct.forced_response(ct.ss(H), np.arange(4), np.ones(4)).outputs
    np.testing.assert_allclose(r.outputs_mean[0], want, atol=1e-12)
    paths = cn.simulate(H, 4, np.ones((1, 4)), trials=2, seed=0)
    np.testing.assert_allclose(paths.outputs[0, 0], want, atol=1e-12)


def test_synthesis_result_prints_like_the_other_results():
    K, CL, eta = cn.passivesyn(plant(sensor_schedule=[1, 2]))
    assert CL.name == "reactor (closed loop)"
    result = K.result
    text = repr(result)
    assert len(text) <= 2000 and text.count("\n") < 25
    assert result.verdict is True and result.success is True
    assert result.status == ("certified" if eta >= 0 else "certified_shortage")
    assert isinstance(result.message, str) and result.message


def test_unity_feedback_of_a_square_loop_is_jump_feedback():
    CL = lossy_loop()
    assert_same_jump_system(ct.feedback(CL, 1), jump_feedback(CL, 1))
    assert_same_jump_system(ct.feedback(CL, 0.5, sign=1),
                            jump_feedback(CL, 0.5, sign=1))


def test_mismatched_operand_names_the_sizes():
    from control.exception import ControlDimension
    G3 = ct.ss([], [], [], np.ones((3, 3)), DT)
    with pytest.raises(ControlDimension, match="2 inputs and 2 outputs"):
        lossy_loop() * G3


def test_networked_plant_is_not_analysed_as_a_deterministic_loop():
    P = plant()
    for analyse in (cn.ms_radius, lambda S: cn.moments(S, 3),
                    lambda S: cn.simulate(S, 3, trials=2, seed=0)):
        with pytest.raises(ControlArgument, match="close it first"):
            analyse(P)


# -- final review: named errors where the change left raw ones ----------------
def test_phase_needs_an_integer_phase():
    from control.exception import ControlArgument
    with pytest.raises(ControlArgument, match="int phase"):
        lossy_loop().phase(1.5)


@pytest.mark.parametrize("key, match", [
    ((5, 0), r"output index 5 is out of range for \d+ outputs"),
    ((0, -3), "input index -3 is out of range"),
    ((slice(3, 5), 0), "selects no output"),
])
def test_indexing_out_of_range_raises_control_dimension(key, match):
    """python-control raises ControlDimension for such an index too (with
    a message about B's shape); ours names the index and the size."""
    from control.exception import ControlDimension
    with pytest.raises(ControlDimension, match=match):
        lossy_loop()[key]


def test_python_controls_step_response_of_a_periodic_loop_is_per_period():
    """What the README's table says: for N > 1, ct.step_response gives the
    lifted mean (one sample per period, outputs per phase), not E z at the
    base rate; ncs.step_response and ncs.moments give E z at every step."""
    import numpy as np
    P = cn.nss([[1.1, 0.1], [0.0, 0.9]], [[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
               [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
               [[0.5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
               nmeas=2, ncon=1, sensor_schedule=[1, 2], sensor_loss=0.1)
    CL = cn.feedback(P, [[[-0.5, 0.0]], [[0.0, -0.2]]])
    lifted = ct.step_response(CL, np.arange(21))
    assert CL.period == 2
    assert lifted.outputs.shape[0] == 2 * len(CL.jump_outputs)
    exact = cn.moments(CL, 41, inputs=np.vstack([np.ones(41), np.zeros(41)]))
    mean = cn.step_response(CL, 41, input=0, trials=10, seed=0)
    np.testing.assert_allclose(mean.exact.outputs_mean, exact.outputs_mean)
    # the lifted response's phase-0 output after 20 periods is not E z(40)
    assert not np.isclose(lifted.outputs[0, 0, -1], exact.outputs_mean[0, -1])


def test_response_methods_of_a_jump_system_are_the_exact_ensemble_responses():
    """``CL.step_response()`` is ``ncs.step_response(CL)`` (exact ``E z``
    at the base rate), not python-control's lifted per-period face."""
    CL = ncs.jss([[[[0.5]], [[0.9]]], [[[0.2]], [[1.1]]]], [[1.0]], [[1.0]],
                 [[0.0]], [[0.3, 0.7], [0.5, 0.5]])
    ours = CL.step_response(20, trials=8, seed=3)
    ref = ncs.step_response(CL, 20, trials=8, seed=3)
    np.testing.assert_array_equal(ours.exact.outputs_mean,
                                  ref.exact.outputs_mean)
    np.testing.assert_array_equal(ours.sample_mean, ref.sample_mean)
    lifted = ct.step_response(CL, np.arange(11) * 2)
    assert lifted.outputs.shape[0] == 2      # one output per phase
