"""The model layer at its boundary: inputs refused where they enter, objects that
cannot be corrupted, periods with a bound, and the model helpers shared with
analysis and synthesis."""

import warnings

import numpy as np
import control as ct
import pytest
from control.exception import ControlArgument, ControlDimension

from control_ncs import build, feedback, jss, nss
from control_ncs._lifting import MAX_LIFTED_ENTRIES, lift, lifted_names


# n = 2, w ∈ R¹, u ∈ R¹, z ∈ R¹, y = x ∈ R²
A = np.array([[1.1, 0.2], [0.0, 0.7]])
B = np.array([[1.0, 0.5], [0.3, 2.0]])
C = np.array([[1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
D = np.array([[0.4, 0.1], [0.0, 0.0], [0.0, 0.0]])


def plant(**kw):
    args = dict(nmeas=2, ncon=1)
    args.update(kw)
    return nss(A, B, C, D, **args)


def scalar_plant(**kw):
    """x⁺ = 2x + w + u, z = x + w, y = x."""
    args = dict(nmeas=1, ncon=1)
    args.update(kw)
    return nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
               **args)


def _lift_loops(A, B, C, D):
    """The block-by-block lifting (the former implementation), as reference."""
    N, m, p = A.shape[0], B.shape[2], C.shape[1]
    DL = np.zeros((N * p, N * m))
    for k in range(N):
        DL[k * p:(k + 1) * p, k * m:(k + 1) * m] = D[k]
        for j in range(k):
            T = C[k]
            for i in range(k - 1, j, -1):
                T = T @ A[i]
            DL[k * p:(k + 1) * p, j * m:(j + 1) * m] = T @ B[j]
    return DL


# -- 1. complex data is refused, never silently truncated --------------------
@pytest.mark.parametrize("name", ["A", "B", "C", "D"])
def test_complex_plant_matrix_is_refused_naming_it(name):
    mats = dict(A=A, B=B, C=C, D=D)
    mats[name] = mats[name] + 1e-3j
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way
        with pytest.raises(ValueError, match=f"^{name}:.*complex"):
            nss(*mats.values(), nmeas=2, ncon=1)


@pytest.mark.parametrize("name", ["A", "B", "C", "D"])
def test_complex_jump_matrix_is_refused_naming_it(name):
    mats = dict(A=[[[0.5]], [[0.1]]], B=[[1.0]], C=[[1.0]], D=[[0.0]])
    mats[name] = np.asarray(mats[name], complex)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=f"^{name}:.*complex"):
            jss(*mats.values(), [0.4, 0.6])


def test_complex_gain_is_refused_by_feedback():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="^K:.*complex"):
            feedback(plant(), np.array([[-1.0 + 0.5j, 0.0]]))


def test_complex_probabilities_are_refused():
    with pytest.raises(ValueError, match="^probabilities:.*complex"):
        jss([[[0.5]], [[0.1]]], [[1.0]], [[1.0]], [[0.0]],
            np.array([0.4, 0.6], complex))


# -- 2. raw errors become named ones -----------------------------------------
def test_gain_with_zero_phases_raises_control_dimension():
    with pytest.raises(ControlDimension, match="^K:"):
        feedback(plant(), np.zeros((0, 1, 2)))


def test_complex_schedule_is_refused_naming_it():
    with pytest.raises(ValueError, match="^sensor_schedule:"):
        plant(sensor_schedule=[1j, 1])


def test_array_dt_is_refused_naming_it():
    with pytest.raises(ValueError, match="^dt:"):
        nss(A, B, C, D, np.array([0.1, 0.2]), nmeas=2, ncon=1)


@pytest.mark.parametrize("name, mats", [
    ("B", ([[[0.5]]], np.zeros((1, 0)), [[1.0]], np.zeros((1, 0)))),
    ("C", ([[[0.5]]], [[1.0]], np.zeros((0, 1)), np.zeros((0, 1)))),
])
def test_jump_system_without_inputs_or_outputs_says_what_is_needed(name, mats):
    with pytest.raises(ControlDimension, match=f"^{name}:.*at least one"):
        jss(*mats, [1.0])


@pytest.mark.parametrize("scale", [1e151, -1e200])
def test_entries_whose_squares_overflow_are_refused_at_construction(scale):
    big = A.copy()
    big[0, 1] = scale
    with pytest.raises(ValueError, match="^A:.*1e\\+?150"):
        nss(big, B, C, D, nmeas=2, ncon=1)
    with pytest.raises(ValueError, match="^A:.*1e\\+?150"):
        jss(big, [[1.0], [0.0]], [[1.0, 0.0]], [[0.0]], [1.0])


def test_large_entries_below_the_bound_are_accepted():
    big = A.copy()
    big[0, 1] = 1e149
    P = nss(big, B, C, D, nmeas=2, ncon=1)
    assert P.A[0, 1] == 1e149


@pytest.mark.parametrize("name", ["A", "B", "C", "D"])
def test_plant_matrices_cannot_be_overwritten(name):
    P = plant()
    with pytest.raises(ValueError, match="read-only"):
        getattr(P, name)[0, 0] = np.nan
    assert np.all(np.isfinite(getattr(P, name)))


def test_jump_system_matrices_cannot_be_overwritten():
    CL = feedback(plant(sensor_loss=0.1), [[-0.5, 0.0]])
    for M in (CL.A, CL.B, CL.C, CL.D, CL.modes.A, CL.modes.B, CL.modes.C,
              CL.modes.D, CL.modes.probabilities):
        with pytest.raises(ValueError, match="read-only"):
            M[(0,) * M.ndim] = np.nan


def test_read_only_systems_still_copy_pickle_and_interconnect():
    import copy
    import pickle
    CL = feedback(plant(sensor_loss=0.1), [[-0.5, 0.0]])
    assert pickle.loads(pickle.dumps(CL)).equals(CL)
    assert copy.deepcopy(CL).equals(CL)
    G = ct.feedback(CL, ct.ss([], [], [], [[0.0]], True))
    assert np.allclose(G.A, CL.A)


@pytest.mark.parametrize("name", ["A", "B", "C", "D"])
def test_numeric_strings_for_matrices_are_refused(name):
    mats = dict(A=A, B=B, C=C, D=D)
    mats[name] = mats[name].astype(str)
    with pytest.raises(ValueError, match=f"^{name}:.*str"):
        nss(*mats.values(), nmeas=2, ncon=1)


@pytest.mark.parametrize("name", ["sensor_loss", "actuator_loss"])
@pytest.mark.parametrize("value", ["0.1", True, np.bool_(False), 0.1 + 0j])
def test_losses_that_are_not_real_numbers_are_refused(name, value):
    with pytest.raises(ValueError, match=f"^{name}:"):
        plant(**{name: value})


@pytest.mark.parametrize("value", ["no", "False", 0, 1.0, None])
def test_shared_channel_must_be_a_bool(value):
    with pytest.raises(ControlArgument, match="^shared_channel:"):
        plant(sensor_schedule=[1, 0], actuator_schedule=[0, 1],
              shared_channel=value)


@pytest.mark.parametrize("value", [True, False, np.bool_(True)])
def test_shared_channel_accepts_bools(value):
    P = plant(sensor_schedule=[1, 0], actuator_schedule=[0, 1],
              shared_channel=value)
    assert P.shared_channel is bool(value)


# -- 3. periods with a bound; the lifted face built once, vectorised ---------
@pytest.mark.parametrize("N", [1, 2, 5])
def test_lift_matches_the_block_by_block_definition(N):
    rng = np.random.default_rng(N)
    A_, B_ = rng.normal(size=(N, 3, 3)), rng.normal(size=(N, 3, 2))
    C_, D_ = rng.normal(size=(N, 2, 3)), rng.normal(size=(N, 2, 2))
    DL = lift(A_, B_, C_, D_)[3]
    assert np.allclose(DL, _lift_loops(A_, B_, C_, D_), rtol=1e-12, atol=1e-12)


def test_lift_of_a_periodic_system_reproduces_its_simulation():
    rng = np.random.default_rng(7)
    N, n, m, p = 4, 3, 2, 2
    A_, B_ = 0.5 * rng.normal(size=(N, n, n)), rng.normal(size=(N, n, m))
    C_, D_ = rng.normal(size=(N, p, n)), rng.normal(size=(N, p, m))
    AL, BL, CL, DL = lift(A_, B_, C_, D_)
    x0, w = rng.normal(size=n), rng.normal(size=(N, m))
    x, z = x0.copy(), []
    for k in range(N):
        z.append(C_[k] @ x + D_[k] @ w[k])
        x = A_[k] @ x + B_[k] @ w[k]
    assert np.allclose(AL @ x0 + BL @ w.ravel(), x)
    assert np.allclose(CL @ x0 + DL @ w.ravel(), np.concatenate(z))


def test_feedback_builds_the_lifted_face_once(monkeypatch):
    import control_ncs.jump as jump
    calls = []
    real_lift = jump.lift
    monkeypatch.setattr(jump, "lift",
                        lambda *a: calls.append(1) or real_lift(*a))
    feedback(plant(sensor_schedule=[1, 2, 0], sensor_loss=0.1),
             [[-0.5, 0.0]])
    assert len(calls) == 1


def test_period_whose_lifted_face_cannot_fit_is_refused_at_once(monkeypatch):
    import control_ncs.jump as jump
    import control_ncs.strategies as strategies
    # lcm(997, 991) = 988027 phases: a lifted D of ~1e12 entries
    P = plant(sensor_schedule=[1] + [0] * 996,
              actuator_schedule=[1] + [0] * 990)
    assert P.period == 988027
    # refused before the network's chain (one matrix per phase) is built
    monkeypatch.setattr(strategies, "network", _never_reached)
    monkeypatch.setattr(jump, "lift", _never_reached)
    with pytest.raises(ValueError, match=r"^P: period N = 988027.*entries"):
        feedback(P, [[-0.5, 0.0]])
    with pytest.raises(ValueError, match=r"^P: period N = 988027"):
        build(P)


def _never_reached(*args, **kwargs):
    raise AssertionError("the loop's matrices were being built")


def test_jss_refuses_a_period_beyond_the_bound_naming_the_size():
    N = int(np.sqrt(MAX_LIFTED_ENTRIES)) + 1
    with pytest.raises(ValueError, match=rf"^probabilities: period N = {N}"):
        jss(np.zeros((N, 1, 1, 1)), [[1.0]], [[1.0]], [[0.0]],
            np.ones((N, 1)))


def test_long_period_within_the_bound_is_built():
    N = 600
    CL = feedback(plant(sensor_schedule=[1] + [0] * (N - 1), sensor_loss=0.1),
                  [[-0.5, 0.0]])
    assert CL.period == N and CL.D.shape == (N, N)
    assert np.allclose(np.tril(CL.D), CL.D)  # block lower triangular
    assert lifted_names(["w"], 2) == ["w[0]", "w[1]"]


# -- 7. one detector of a deterministic system; per-phase plant means ---------
def test_period_two_single_mode_system_is_deterministic():
    A_ = np.array([[[[0.5]]], [[[1.5]]]])          # (N=2, M=1, 1, 1)
    sys = jss(A_, [[1.0]], [[1.0]], [[0.0]], np.ones((2, 1)))
    A_d, B_d, C_d, D_d = sys.deterministic()
    assert A_d.shape == (2, 1, 1) and A_d[:, 0, 0].tolist() == [0.5, 1.5]
    assert B_d.shape == (2, 1, 1) and C_d.shape == (2, 1, 1)
    assert D_d.shape == (2, 1, 1)


def test_identical_unmerged_modes_are_deterministic():
    sys = jss([[[0.5]], [[0.5]]], [[1.0]], [[2.0]], [[0.1]], [0.3, 0.7])
    assert sys.nmodes == 2
    A_d, B_d, C_d, D_d = sys.deterministic()
    assert (A_d[0, 0, 0], C_d[0, 0, 0], D_d[0, 0, 0]) == (0.5, 2.0, 0.1)


def test_modes_of_zero_probability_do_not_count():
    sys = jss([[[0.5]], [[9.0]]], [[1.0]], [[1.0]], [[0.0]], [1.0, 0.0])
    assert sys.deterministic()[0][0, 0, 0] == 0.5


@pytest.mark.parametrize("field", ["A", "B", "C", "D"])
def test_two_live_modes_that_differ_anywhere_are_not_deterministic(field):
    mats = dict(A=[[[0.5]], [[0.5]]], B=[[[1.0]], [[1.0]]],
                C=[[[1.0]], [[1.0]]], D=[[[0.0]], [[0.0]]])
    mats[field] = np.array(mats[field])
    mats[field][1] += 0.25
    assert jss(*mats.values(), [0.3, 0.7]).deterministic() is None


def test_one_random_phase_makes_a_periodic_system_random():
    A_ = np.array([[[[0.5]], [[0.5]]], [[[0.5]], [[0.2]]]])  # phase 1 differs
    sys = jss(A_, [[1.0]], [[1.0]], [[0.0]], [[0.5, 0.5], [0.5, 0.5]])
    assert sys.deterministic() is None


def test_loss_free_closed_loop_is_deterministic():
    CL = feedback(plant(sensor_schedule=[1, 2]), [[-0.5, 0.0]])
    assert CL.deterministic() is not None
    lossy = feedback(plant(sensor_schedule=[1, 2], sensor_loss=0.2),
                     [[-0.5, 0.0]])
    assert lossy.deterministic() is None


def test_jump_plant_mean_weights_each_field_by_the_mode_probabilities():
    J = build(plant(sensor_schedule=[1, 2], sensor_loss=0.2,
                    actuator_loss=0.1))
    means = J.mean()
    assert len(means) == 6
    for f, M in zip(("A", "Bu", "Bw", "Cz", "Du", "Dw"), means):
        X = getattr(J, f)
        want = sum(J.probabilities[:, i, None, None] * X[:, i]
                   for i in range(X.shape[1]))
        assert M.shape == (J.period,) + X.shape[2:]
        assert np.allclose(M, want)
    # the mean of the loop's Bu carries the success probability q
    q = 0.8 * 0.9
    assert np.allclose(means[1], q * J.Bu[:, 3])


# -- 5. the package never hides a broken import of itself ---------------------
def test_no_module_guards_an_import_of_its_own_package():
    import ast
    import pathlib
    import control_ncs
    guarded = []
    for path in pathlib.Path(control_ncs.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Try):
                continue
            catches = {ast.unparse(h.type) for h in node.handlers if h.type}
            if not catches & {"ImportError", "ModuleNotFoundError"}:
                continue
            own = [n for n in node.body if isinstance(n, ast.ImportFrom)
                   and (n.level > 0 or (n.module or "").startswith(
                       "control_ncs"))]
            if own:
                guarded.append(f"{path.name}:{node.lineno}")
    assert guarded == []


# -- 7. controller kinds live in one place --------------------------------------
def test_accepted_controllers_and_actuators_come_from_the_builder():
    from control_ncs import strategies
    from control_ncs.gain import actuators, controllers
    assert set(strategies.MODE_BUILDERS) == set(controllers())
    for controller in ("static", "predictor", "lti"):
        for actuator in actuators():
            J = build(plant(sensor_loss=0.1), controller, actuator)
            assert J.controller == controller and J.actuator == actuator
    with pytest.raises(ControlArgument, match="^actuator:.*'ramp'"):
        build(plant(), "static", "ramp")
    with pytest.raises(ControlArgument, match="^controller:.*'pid'"):
        build(plant(), "pid", "zero")


def test_build_over_a_multiple_of_the_period_repeats_the_phases():
    P = plant(sensor_schedule=[1, 2, 0], actuator_schedule=[1, 0],
              sensor_loss=0.1, actuator_loss=0.2)
    for controller, actuator in [("static", "zero"), ("static", "hold"),
                                 ("predictor", "zero"),
                                 ("predictor", "hold")]:
        one = build(P, controller, actuator)
        two = build(P, controller, actuator, period=2 * P.period)
        for f in ("A", "Bu", "Bw", "Cz", "Du", "Dw", "E", "probabilities"):
            X = getattr(one, f)
            assert np.array_equal(getattr(two, f),
                                  np.concatenate([X, X])), (controller, f)


def test_feedback_applies_the_gain_as_is_in_positive_feedback():
    P = scalar_plant(actuator_loss=0.2)
    K, _, _ = ct.dlqr(P.A, P.B2, np.eye(1), np.eye(1))   # for u = -K x
    CL = feedback(P, -K)
    arrived = CL.modes.A[0, CL.nominal_mode[0]]
    assert np.allclose(arrived, P.A - P.B2 @ K)
