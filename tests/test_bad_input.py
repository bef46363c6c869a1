"""Every bad input raises the documented exception, naming the argument."""

import numpy as np
import control as ct
import pytest
from control.exception import ControlArgument, ControlDimension

from control_ncs import (build, feedback, is_mss, jss, mode_probabilities,
                         moments, ms_radius, nss, schedule)


# n = 2, w ∈ R¹, u ∈ R¹, z ∈ R¹, y = x ∈ R²
A = np.array([[1.1, 0.2], [0.0, 0.7]])
B = np.array([[1.0, 0.5], [0.3, 2.0]])
C = np.array([[1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
D = np.array([[0.4, 0.1], [0.0, 0.0], [0.0, 0.0]])


def plant(**kw):
    args = dict(nmeas=2, ncon=1)
    args.update(kw)
    return nss(A, B, C, D, **args)


def jump_args():
    return dict(A=[[[0.5]], [[0.1]]], B=[[1.0]], C=[[1.0]], D=[[0.0]],
                probabilities=[0.4, 0.6])


# -- shapes (ControlDimension) ----------------------------------------------
@pytest.mark.parametrize("name, mats", [
    ("A", (np.ones((2, 3)), B, C, D)),              # not square
    ("B", (A, np.ones((3, 2)), C, D)),              # rows ≠ n
    ("C", (A, B, np.ones((3, 3)), D)),              # columns ≠ n
    ("D", (A, B, C, np.ones((3, 3)))),              # not p × m
    ("A", (np.ones((2, 2, 2)), B, C, D)),           # not a matrix
])
def test_plant_with_inconsistent_shapes_raises_control_dimension(name, mats):
    with pytest.raises(ControlDimension, match=f"^{name}:"):
        nss(*mats, nmeas=2, ncon=1)


@pytest.mark.parametrize("kw, name", [
    (dict(nmeas=4), "nmeas"), (dict(nmeas=0), "nmeas"),
    (dict(ncon=3), "ncon"), (dict(ncon=0), "ncon"),
])
def test_nmeas_ncon_out_of_range_raise_control_dimension(kw, name):
    with pytest.raises(ControlDimension, match=f"^{name}:"):
        plant(**kw)


@pytest.mark.parametrize("missing", ["nmeas", "ncon"])
def test_missing_nmeas_or_ncon_raises_control_argument(missing):
    kw = dict(nmeas=2, ncon=1)
    del kw[missing]
    with pytest.raises(ControlArgument, match=f"^{missing}: required"):
        nss(A, B, C, D, **kw)
    with pytest.raises(ControlArgument, match=f"^{missing}: required"):
        nss(ct.ss(A, B, C, D, True), **kw)


@pytest.mark.parametrize("value", [1.5, "2", True])
def test_non_integer_nmeas_raises_control_argument(value):
    with pytest.raises(ControlArgument, match="^nmeas:"):
        plant(nmeas=value)


def test_nss_with_wrong_number_of_positional_arguments_raises():
    with pytest.raises(ControlArgument, match="nss"):
        nss(A, B, nmeas=2, ncon=1)
    with pytest.raises(ControlArgument, match="^sys:"):
        nss("not a system", nmeas=2, ncon=1)


@pytest.mark.parametrize("kw, name", [
    (dict(A=[[[0.5, 0.1]], [[0.1, 0.2]]]), "A"),    # modes not square
    (dict(B=[[1.0, 0.0], [0.0, 1.0]]), "B"),        # rows ≠ n
    (dict(C=[[1.0, 2.0]]), "C"),                    # columns ≠ n
    (dict(D=[[0.0, 1.0]]), "D"),                    # not p × m
    (dict(A=np.zeros((3, 1, 1))), "A"),             # 3 modes, 2 probabilities
])
def test_jump_system_with_inconsistent_shapes_raises_control_dimension(kw,
                                                                       name):
    args = jump_args()
    args.update(kw)
    with pytest.raises(ControlDimension, match=f"^{name}:"):
        jss(**args)


def test_jump_system_with_wrong_number_of_names_raises_control_dimension():
    with pytest.raises(ControlDimension, match="^states:"):
        jss(**jump_args(), states=["a", "b"])


@pytest.mark.parametrize("kw, name", [
    (dict(initial_state=[1.0, 2.0]), "initial_state"),
    (dict(inputs=np.ones((2, 5))), "inputs"),
    (dict(noise_covariance=np.eye(2)), "noise_covariance"),
    (dict(initial_covariance=np.eye(3)), "initial_covariance"),
])
def test_moments_with_wrong_shapes_raise_control_dimension(kw, name):
    with pytest.raises(ControlDimension, match=f"^{name}:"):
        moments(jss(**jump_args()), 5, **kw)


@pytest.mark.parametrize("timepts", [0, 2.5, [0.0, 1.0, 3.0],
                                     [2.0, 3.0, 4.0]])   # phases start at 0
def test_moments_with_bad_time_points_raise_value_error(timepts):
    with pytest.raises(ValueError, match="^timepts:"):
        moments(jss(**jump_args()), timepts)


# -- schedules (ValueError) --------------------------------------------------
@pytest.mark.parametrize("spec", [[3, 1], [-1, 0], [1.5, 0]])
def test_schedule_index_out_of_range_or_fractional_raises(spec):
    with pytest.raises(ValueError, match="^sensor_schedule:"):
        plant(sensor_schedule=spec)


@pytest.mark.parametrize("spec", [
    [[1, 0, 1]],            # three columns for two sensors
    [[1, 0], [1]],          # rows of unequal width
    [[2, 0]],               # not 0/1
    np.zeros((0, 2)),       # no phase
    [],                     # empty index vector
    "1, 2",                 # not numeric
])
def test_schedule_matrix_of_wrong_width_or_content_raises(spec):
    with pytest.raises(ValueError, match="^sensor_schedule:"):
        plant(sensor_schedule=spec)


def test_actuator_schedule_errors_name_the_actuator_schedule():
    with pytest.raises(ValueError, match="^actuator_schedule:"):
        plant(actuator_schedule=[0, 2])
    with pytest.raises(ValueError, match="^actuator_schedule:"):
        plant(actuator_schedule=[[1, 1]])


def test_schedule_object_for_another_node_count_raises():
    with pytest.raises(ValueError, match="^sensor_schedule:"):
        plant(sensor_schedule=schedule([1, 2, 3], nodes=3))


# -- probabilities (ValueError) ------------------------------------------------
@pytest.mark.parametrize("value", [-0.1, 1.5, np.nan, "x"])
@pytest.mark.parametrize("name", ["sensor_loss", "actuator_loss"])
def test_loss_probability_outside_unit_interval_raises(name, value):
    with pytest.raises(ValueError, match=f"^{name}:"):
        plant(**{name: value})


def test_mode_probabilities_outside_unit_interval_raise():
    with pytest.raises(ValueError, match="^sensor_loss:"):
        mode_probabilities(1.2, 0.0)
    with pytest.raises(ValueError, match="^actuator_loss:"):
        mode_probabilities(0.0, -0.5)


@pytest.mark.parametrize("p", [[-0.1, 1.1], [0.5, 0.6], [[0.5, 0.5], [0.2, 0.2]]])
def test_jump_probabilities_outside_unit_interval_or_not_summing_raise(p):
    args = jump_args()
    args["probabilities"] = p
    with pytest.raises(ValueError, match="^probabilities:"):
        jss(**args)


# -- time base -------------------------------------------------------------
@pytest.mark.parametrize("dt", [0, None, -1.0])
def test_continuous_time_plant_is_rejected_with_advice(dt):
    with pytest.raises(ValueError, match="sample_system" if dt != -1.0
                       else "^dt:"):
        nss(A, B, C, D, dt, nmeas=2, ncon=1)


@pytest.mark.parametrize("call, name", [
    (lambda: nss(ct.ss(A, B, C, D), nmeas=2, ncon=1), "dt"),
    (lambda: ms_radius(ct.ss(A, B[:, :1], C, D[:, :1])), "sys.dt"),
    (lambda: moments(ct.ss(A, B[:, :1], C, D[:, :1]), 3), "sys.dt"),
    (lambda: jss(**jump_args(), dt=0), "dt"),
])
def test_continuous_time_systems_are_rejected_with_advice(call, name):
    with pytest.raises(ValueError, match=f"^{name}: .*control.sample_system"):
        call()


# -- plant content -------------------------------------------------------------
@pytest.mark.parametrize("name", ["A", "B", "C", "D"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_matrices_raise_value_error(name, bad):
    mats = dict(A=A.copy(), B=B.copy(), C=C.copy(), D=D.copy())
    mats[name][0, 0] = bad
    with pytest.raises(ValueError, match=f"^{name}: entries must be finite"):
        nss(mats["A"], mats["B"], mats["C"], mats["D"], nmeas=2, ncon=1)


def test_control_feedthrough_into_the_measurement_raises():
    Dbad = D.copy()
    Dbad[2, 1] = 0.3                                        # D22
    with pytest.raises(ValueError, match="^D: .*D22 = 0"):
        nss(A, B, C, Dbad, nmeas=2, ncon=1)


def test_noise_into_the_measurement_is_the_plants_d21():
    Dn = D.copy()
    Dn[1, 0] = 0.3                                          # D21
    P = nss(A, B, C, Dn, nmeas=2, ncon=1)
    assert P.D21[0, 0] == 0.3 and P.D21.shape == (2, 1)


def test_shared_channel_violation_raises_naming_the_phases():
    with pytest.raises(ValueError, match=r"^shared_channel:.*phases \[1\]"):
        plant(sensor_schedule=[1, 2], actuator_schedule=[0, 1],
              shared_channel=True)
    with pytest.raises(ValueError, match="^shared_channel:"):
        plant(shared_channel=True)      # None = everyone, every step


# -- keywords (TypeError) ------------------------------------------------------
@pytest.mark.parametrize("call", [
    lambda: nss(A, B, C, D, nmeas=2, ncon=1, bogus=1),
    lambda: jss(**jump_args(), bogus=1),
    lambda: feedback(plant(), [[0.1, 0.2]], bogus=1),
    lambda: ms_radius(jss(**jump_args()), bogus=1),
    lambda: is_mss(jss(**jump_args()), bogus=1),
    lambda: moments(jss(**jump_args()), 3, bogus=1),
    lambda: plant().with_network(bogus=1),
], ids=["nss", "jss", "feedback", "ms_radius", "is_mss", "moments",
        "with_network"])
def test_unknown_keywords_raise_type_error_naming_them(call):
    with pytest.raises(TypeError, match="bogus"):
        call()


# -- feedback and analysis arguments -------------------------------------------
def test_static_gain_under_a_shared_channel_points_to_the_predictor():
    P = plant(sensor_schedule=[1, 2, 0], actuator_schedule=[0, 0, 1],
              shared_channel=True)
    with pytest.raises(ValueError, match="never closes.*'predictor'"):
        feedback(P, [[0.1, 0.2]])
    feedback(P, [[0.1, 0.2]], controller="predictor")   # and that one works


def test_static_gain_without_any_closing_phase_is_refused_too():
    P = plant(sensor_schedule=[1, 0], actuator_schedule=[0, 1])
    with pytest.raises(ValueError, match="predictor"):
        feedback(P, [[0.1, 0.2]])


def test_predictor_needs_the_full_state_measured():
    P = nss(A, B, C[:2], D[:2], nmeas=1, ncon=1)      # y = x[0] only
    with pytest.raises(ControlArgument, match="C2"):
        feedback(P, [[0.1, 0.2]], controller="predictor")
    with pytest.raises(ControlArgument, match="C2"):
        build(P, "predictor")


@pytest.mark.parametrize("K, kw", [
    ([[0.1]], {}),                                    # static needs (1, 2)
    ([[0.1, 0.2, 0.3]], {}),
    ([[0.1, 0.2]], dict(controller="predictor", actuator="hold")),  # (1, 3)
    (np.zeros((2, 2, 2)), {}),                        # two actuators?
    ([0.1, 0.2], {}),                                 # a vector
    (np.zeros((1, 1, 1, 2)), {}),                     # 4-D
])
def test_wrong_gain_shapes_raise_control_dimension(K, kw):
    with pytest.raises(ControlDimension, match="^K:"):
        feedback(plant(), K, **kw)


def test_non_finite_gain_raises_value_error():
    with pytest.raises(ValueError, match="^K:"):
        feedback(plant(), [[np.nan, 0.0]])


@pytest.mark.parametrize("kw, name", [
    (dict(controller="pid"), "controller"), (dict(actuator="last"), "actuator"),
])
def test_unknown_controller_or_actuator_raises_control_argument(kw, name):
    with pytest.raises(ControlArgument, match=f"^{name}:"):
        feedback(plant(), [[0.1, 0.2]], **kw)
    with pytest.raises(ControlArgument, match=f"^{name}:"):
        build(plant(), **kw)


def test_feedback_needs_a_networked_plant():
    with pytest.raises(ControlArgument, match="^P:"):
        feedback(ct.ss(A, B, C, D, True), [[0.1, 0.2]])


def test_build_period_must_be_a_multiple_of_the_network_period():
    with pytest.raises(ValueError, match="^period:"):
        build(plant(sensor_schedule=[1, 2]), period=3)


def test_analysis_of_something_that_is_not_a_system_raises():
    with pytest.raises(ControlArgument, match="^sys:"):
        ms_radius(np.eye(2))
    with pytest.raises(ControlArgument, match="^sys:"):
        moments("sys", 3)


def test_unknown_ms_radius_method_raises_control_argument():
    with pytest.raises(ControlArgument, match="^method:"):
        ms_radius(jss(**jump_args()), method="lyapunov")


def test_bad_nominal_mode_raises_value_error():
    with pytest.raises(ValueError, match="^nominal:"):
        jss(**jump_args(), nominal=[2])


def test_check_certificate_rejects_a_certificate_of_the_wrong_shape():
    import control as ct
    from control_ncs import check_certificate
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    with pytest.raises(ControlDimension, match="^P:"):
        check_certificate(G, np.ones((3, 3)), 0.1)


def test_schedule_plot_needs_a_networked_plant():
    import control as ct
    from control_ncs import schedule_plot
    with pytest.raises(ControlArgument, match="^P:"):
        schedule_plot(ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], True))


# -- options of the routes added for speed (named ValueErrors) ------------------
def scalar_synthesis_plant():
    return nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
               nmeas=1, ncon=1, actuator_loss=0.1)


def _riccati(**settings):
    """passivesyn's options for the Riccati route with these settings."""
    return dict(options=dict(solver="riccati", solver_options=settings))


@pytest.mark.parametrize("name, kwargs", [
    ("rtol", _riccati(rtol="x")),
    ("rtol", _riccati(rtol=None)),
    ("max_sweeps", _riccati(max_sweeps="x")),
    ("max_sweeps", _riccati(max_sweeps=True)),
    ("max_sweeps", _riccati(max_sweeps=float("inf"))),
    ("margin", dict(options=dict(solver="riccati", margin="x"))),
    ("margin", dict(options=dict(margin=-1.0))),
    ("decay", dict(decay=1.5)),
    ("decay", dict(decay="x")),
    ("eta", dict(eta=float("nan"))),
])
def test_passivesyn_bad_option_raises_naming_it(name, kwargs):
    from control_ncs import passivesyn
    with pytest.raises(ValueError, match=f"^{name}: "):
        passivesyn(scalar_synthesis_plant(), **kwargs)


@pytest.mark.parametrize("name, args, kwargs", [
    ("ifp_index", ("x",), {}),
    ("ifp_index", (float("nan"),), {}),
    ("decay", (), dict(decay=-0.9)),
    ("decay", (), dict(decay=1.5)),
    ("margin", (), dict(margin=0.0)),
])
@pytest.mark.parametrize("method", ["auto", "lmi"])
def test_passivity_certificate_bad_argument_raises_naming_it(name, args,
                                                             kwargs, method):
    from control_ncs import passivity_certificate
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    with pytest.raises(ValueError, match=f"^{name}: "):
        passivity_certificate(G, *args, method=method, **kwargs)


def test_passivity_of_a_system_without_state_raises_control_dimension():
    from control_ncs import get_input_ff_index
    with pytest.raises(ControlDimension, match="^sys: "):
        get_input_ff_index(ct.ss([], [], [], [[1.0]], True), strict=True)
    # python-control's meaning needs no state: a static gain of 1
    assert get_input_ff_index(ct.ss([], [], [], [[1.0]], True)) == 1.0


def test_frequency_test_with_no_frequencies_raises_naming_omega():
    from control_ncs import frequency_ff_index
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    with pytest.raises(ValueError, match="^omega: "):
        frequency_ff_index(G, omega=[])


def test_riccati_synthesis_of_a_statespace_raises_control_argument():
    from control_ncs.riccati import riccati_synthesis
    with pytest.raises(ControlArgument, match="^plant: "):
        riccati_synthesis(ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True))


@pytest.mark.parametrize("workers", [0, 1.5, "2"])
def test_simulate_bad_workers_raise_before_allocating(workers):
    from control_ncs import simulate
    with pytest.raises(ValueError, match="^workers: "):
        simulate(jss(**jump_args()), 5, trials=10**9, workers=workers)


# -- sizes that cannot be served are refused at once, naming the argument ----
def scalar_loop():
    P = nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.5, 0.0], [0.0, 0.0]],
            nmeas=1, ncon=1, actuator_loss=0.1)
    return P, feedback(P, [[-1.0]])


def test_schedule_search_over_a_hopeless_period_is_refused_at_once(
        monkeypatch):
    import control_ncs._schedules as schedules
    import control_ncs.sweeps as sweeps
    from control_ncs import schedule_search
    P, _ = scalar_loop()
    # counted over the divisors of the period (one totient each), not over
    # its 10^6 rotations one by one; no schedule is ever listed
    calls = []
    totient = schedules._totient
    monkeypatch.setattr(schedules, "_totient",
                        lambda n: calls.append(n) or totient(n))
    monkeypatch.setattr(sweeps, "_canonical_schedules", _never_reached)
    divisors = [d for d in range(1, 10**3 + 1) if 10**6 % d == 0]
    for limit in (5000, None):
        calls.clear()
        with pytest.raises(ValueError, match="^period: 1000000 gives about 10"):
            schedule_search(P, 10**6, limit=limit, progress=False)
        assert 0 < len(calls) <= 2 * len(divisors)


def _never_reached(*args, **kwargs):
    raise AssertionError("the schedules were listed")


def test_lift_lti_of_a_hopeless_period_is_refused_before_allocating():
    from control_ncs import lift_lti
    G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], True)
    with pytest.raises(ValueError, match="^period: period N = 1000000 is too"):
        lift_lti(G, 10**6)


@pytest.mark.parametrize("period", [0, -1, 1.5, True])
def test_build_refuses_a_period_that_is_not_a_positive_int(period):
    P, _ = scalar_loop()
    with pytest.raises(ValueError, match="^period: expected an int >= 1"):
        build(P, "static", period=period)


def test_unknown_keyword_is_refused_also_when_the_loop_is_not_mss():
    from control_ncs import passivity_certificate
    P = nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.1, 0.0], [0.0, 0.0]],
            nmeas=1, ncon=1, actuator_loss=0.9)
    CL = feedback(P, [[0.0]])
    assert not is_mss(CL)
    with pytest.raises(TypeError, match="foo"):
        passivity_certificate(CL, foo=1)
