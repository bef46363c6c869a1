"""Analysis and simulation at the public boundary: portability and bad input.

Every bad argument raises a named exception at the public function, never a
raw error from numpy, scipy or ARPACK, and nothing is silently truncated.
"""

import ast
import fractions
import importlib
import os
import pathlib
import pkgutil
import subprocess
import sys

import control as ct

import matplotlib.pyplot as plt
import numpy as np
import pytest
from control.exception import ControlArgument

import control_ncs as cn

# x⁺ = 2x + w, u = -2x applied with probability 0.8
SCALAR = dict(A=[[[2.0]], [[0.0]]], B=[[1.0]], C=[[1.0]], D=[[0.0]],
              probabilities=[0.2, 0.8])


def scalar():
    return cn.jss(**SCALAR)


def random_loop(n=7, seed=0):
    rng = np.random.default_rng(seed)
    return cn.jss(0.3 * rng.normal(size=(2, n, n)), np.ones((n, 1)),
                  np.ones((1, n)), [[0.0]], [0.2, 0.8])


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def simulate_(sys, timepts, inputs=None, initial_state=None, **kw):
    return cn.simulate(sys, timepts, inputs, initial_state, trials=3, seed=0,
                       **kw)


def forced_(sys, timepts, inputs=None, initial_state=None, **kw):
    return cn.forced_response(sys, timepts, inputs, initial_state, trials=3,
                              seed=0, **kw)


TIME_DOMAIN = {"moments": cn.moments, "simulate": simulate_,
               "forced_response": forced_}


# -- portability --------------------------------------------------------------
def test_simulate_runs_where_sched_getaffinity_is_missing(monkeypatch):
    # macOS and Windows have no os.sched_getaffinity
    expected = cn.simulate(scalar(), 6, initial_state=1.0, trials=40, seed=2,
                           chunk=5, workers=1)
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    if hasattr(os, "process_cpu_count"):
        # Python 3.13: there os.process_cpu_count is os.cpu_count (on Linux
        # it calls the sched_getaffinity just removed)
        monkeypatch.setattr(os, "process_cpu_count", os.cpu_count)
    paths = cn.simulate(scalar(), 6, initial_state=1.0, trials=40, seed=2,
                        chunk=5)
    assert np.array_equal(paths.outputs, expected.outputs)


@pytest.mark.slow  # a subprocess: seconds, still run in CI
def test_package_imports_and_runs_under_python_OO():
    # -OO strips docstrings: nothing may edit a docstring that is None
    root = pathlib.Path(cn.__file__).resolve().parents[1]
    code = ("import control_ncs as cn\n"
            "S = cn.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], "
            "[0.2, 0.8])\n"
            "print(cn.step_response(S, 4, trials=5, seed=0).trials)\n")
    env = dict(os.environ, PYTHONPATH=str(root))
    proc = subprocess.run([sys.executable, "-OO", "-c", code], cwd=root,
                          env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "5"


# -- covariances: one check for moments and simulate --------------------------
BAD_COVARIANCES = {
    "negative": ([[-1.0]], "positive semidefinite"),
    "indefinite": ([[1.0, 2.0], [2.0, 1.0]], "positive semidefinite"),
    "asymmetric": ([[1.0, 0.5], [0.0, 1.0]], "symmetric"),
    "complex": (np.array([[1.0 + 1j]]), "real"),
}


def two_state():
    return cn.jss(np.zeros((1, 2, 2)), np.eye(2), np.eye(2), np.zeros((2, 2)),
                  [1.0])


@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
@pytest.mark.parametrize("case", sorted(BAD_COVARIANCES))
@pytest.mark.parametrize("name", ["noise_covariance", "initial_covariance"])
def test_covariance_that_is_not_symmetric_psd_is_refused(func, case, name):
    W, reason = BAD_COVARIANCES[case]
    sys = two_state() if np.shape(W) == (2, 2) else scalar()
    with pytest.raises(ValueError, match=f"^{name}: .*{reason}"):
        TIME_DOMAIN[func](sys, 3, **{name: W})


def test_moments_and_simulate_agree_on_a_singular_covariance():
    W = [[1.0, 1.0], [1.0, 1.0]]
    exact = cn.moments(two_state(), 2, noise_covariance=W)
    paths = cn.simulate(two_state(), 2, trials=4, seed=0, noise_covariance=W)
    assert np.allclose(exact.states_cov[:, :, 1], W)
    x1 = paths.states[:, :, 1]
    assert np.allclose(x1[0], x1[1])          # rank one: x₁ = x₂ on every path


# -- time points ---------------------------------------------------------------
BAD_TIMEPTS = {
    "inf": float("inf"), "nan": float("nan"), "bool": True, "complex": 3 + 0j,
    "none": None, "string": "5", "fraction": 5.5, "zero": 0, "negative": -2,
    "complex-array": np.array([0.0, 1.0, 2.0], dtype=complex),
    "nan-array": [0.0, float("nan")], "empty": [],
    "not-from-zero": [1.0, 2.0, 3.0], "unequal": [0.0, 1.0, 3.0],
    "huge-time": [0.0, 1e30],
}


@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
@pytest.mark.parametrize("case", sorted(BAD_TIMEPTS))
def test_bad_timepts_are_refused_naming_the_argument(func, case):
    with pytest.raises(ValueError, match="^timepts: "):
        TIME_DOMAIN[func](scalar(), BAD_TIMEPTS[case])


@pytest.mark.parametrize("respond", [cn.step_response, cn.impulse_response,
                                     cn.initial_response])
@pytest.mark.parametrize("case", ["inf", "bool", "not-from-zero"])
def test_responses_refuse_bad_timepts(respond, case):
    with pytest.raises(ValueError, match="^timepts: "):
        respond(scalar(), BAD_TIMEPTS[case], trials=3)


@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
@pytest.mark.parametrize("steps", [10**12, 10**30, 1e30])
def test_a_number_of_steps_beyond_memory_is_refused_naming_timepts(func,
                                                                   steps):
    with pytest.raises(ValueError, match="^timepts: "):
        TIME_DOMAIN[func](scalar(), steps)


@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
def test_a_count_and_the_times_from_zero_give_the_same_grid(func):
    sys = cn.jss(**SCALAR, dt=0.5)
    by_count = TIME_DOMAIN[func](sys, 4.0, initial_state=1.0)
    by_times = TIME_DOMAIN[func](sys, [0.0, 0.5, 1.0, 1.5], initial_state=1.0)
    assert np.array_equal(by_count.time, [0.0, 0.5, 1.0, 1.5])
    assert np.array_equal(by_times.time, by_count.time)


@pytest.mark.parametrize("count", [4, np.int64(4), 4.0, np.float32(4.0),
                                   np.array(4), fractions.Fraction(4)])
def test_a_number_of_steps_may_be_any_integral_real_number(count):
    for func in TIME_DOMAIN.values():
        assert func(scalar(), count).time.size == 4


def test_paths_that_do_not_fit_in_memory_are_refused_naming_trials():
    with pytest.raises(ValueError, match="^trials, timepts: .*GiB"):
        cn.simulate(scalar(), 3, trials=10**15)


# -- complex signals are refused, not truncated ---------------------------------
@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
@pytest.mark.parametrize("value", [np.array([1.0 + 1e-3j, 1.0, 1.0]),
                                   [1j, 1.0, 1.0], 2 + 0j])
def test_complex_inputs_are_refused(func, value):
    with pytest.raises(ValueError, match="^inputs: .*complex"):
        TIME_DOMAIN[func](scalar(), 3, value)


@pytest.mark.parametrize("func", sorted(TIME_DOMAIN))
@pytest.mark.parametrize("value", [np.array([1.0 + 1e-3j]), 1j])
def test_complex_initial_state_is_refused(func, value):
    with pytest.raises(ValueError, match="^initial_state: .*complex"):
        TIME_DOMAIN[func](scalar(), 3, None, value)


def test_initial_state_scalar_broadcasts_in_moments_as_in_simulate():
    sys = two_state()
    exact = cn.moments(sys, 1, initial_state=2.0)
    paths = cn.simulate(sys, 1, initial_state=2.0, trials=1, seed=0)
    assert np.array_equal(exact.states_mean[:, 0], [2.0, 2.0])
    assert np.array_equal(paths.states[:, 0, 0], [2.0, 2.0])


# -- options of the Monte Carlo functions ---------------------------------------
def test_quantiles_none_is_refused_naming_the_argument():
    with pytest.raises(ValueError, match="^quantiles: "):
        cn.step_response(scalar(), 3, trials=3, quantiles=None)


@pytest.mark.parametrize("progress", ["yes", 1, 0.5])
def test_progress_must_be_true_false_or_none(progress):
    with pytest.raises(ControlArgument, match="^progress: "):
        cn.simulate(scalar(), 3, trials=3, progress=progress)


def test_progress_none_shows_a_bar_only_where_someone_watches(capsys):
    cn.simulate(scalar(), 3, trials=3, progress=None)
    assert "simulate" not in capsys.readouterr().err


@pytest.mark.parametrize("paths", [-1, 0, 1.5, "a"])
def test_sample_paths_plot_refuses_a_bad_number_of_paths(paths):
    data = cn.simulate(scalar(), 3, trials=4, seed=0)
    with pytest.raises(ValueError, match="^paths: "):
        data.plot(paths=paths)


@pytest.mark.parametrize("paths", [-1, 1.5, "a", True])
def test_plot_ensemble_refuses_a_bad_number_of_paths(paths):
    r = cn.step_response(scalar(), 3, trials=4, seed=0)
    with pytest.raises(ValueError, match="^paths: "):
        cn.plot_ensemble(r, paths=paths)


def test_plot_ensemble_refuses_what_is_not_an_axes():
    r = cn.step_response(scalar(), 3, trials=4, seed=0)
    with pytest.raises(ControlArgument, match="^ax: "):
        cn.plot_ensemble(r, ax="x")


def test_schedule_plot_refuses_what_is_not_an_axes():
    P = cn.nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
               np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    with pytest.raises(ControlArgument, match="^ax: "):
        cn.schedule_plot(P, ax=[1, 2])


@pytest.mark.parametrize("steps", [0, -3, 1.5, float("inf"), "a"])
def test_schedule_plot_refuses_a_bad_number_of_steps(steps):
    P = cn.nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
               np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    with pytest.raises(ValueError, match="^steps: "):
        cn.schedule_plot(P, steps)


# -- stability ------------------------------------------------------------------
@pytest.mark.parametrize("tol", ["x", float("nan"), float("inf"), -1.0, 0.0,
                                 True, None])
def test_ms_radius_refuses_a_bad_tolerance(tol):
    with pytest.raises(ValueError, match="^tol: "):
        cn.ms_radius(random_loop(), method="matrix-free", tol=tol)


def test_ms_radius_tolerance_is_checked_on_every_route():
    with pytest.raises(ValueError, match="^tol: "):
        cn.ms_radius(scalar(), tol="x")


@pytest.mark.parametrize("k", [1.5, "a", True])
def test_second_moment_operator_refuses_a_phase_that_is_not_an_int(k):
    with pytest.raises(ValueError, match="^k: "):
        cn.stability.second_moment_operator(scalar(), k=k)


# -- module layout ----------------------------------------------------------------
def test_no_submodule_bears_the_name_of_a_public_name():
    # `import control_ncs.simulate` must not hand back a function. Read the
    # package's own directory: an editable install's import hook may map
    # submodule names to another checkout.
    modules = {m.name for m in pkgutil.iter_modules(cn.__path__)}
    assert modules, "no submodules found"
    assert not modules & set(cn.__all__)


@pytest.mark.parametrize("module, names", [
    ("responses", ["simulate", "step_response", "impulse_response",
                   "initial_response", "forced_response", "SamplePaths",
                   "EnsembleResponse"]),
    ("plots", ["plot_ensemble", "schedule_plot"]),
    ("meancov", ["moments", "MomentsResponse"]),
    ("stability", ["ms_radius", "is_mss", "second_moment_operator"])])
def test_public_names_live_in_the_module_of_their_job(module, names):
    mod = importlib.import_module(f"control_ncs.{module}")
    for name in names:
        assert name in mod.__all__
        if name in cn._IN_SUBMODULE:       # public in its module only
            assert cn._IN_SUBMODULE[name] == mod.__name__
        else:
            assert getattr(mod, name) is getattr(cn, name)


ANALYSIS_MODULES = {"montecarlo", "responses", "plots", "meancov", "stability",
                    "stationary"}


def test_analysis_modules_share_no_private_names():
    package = pathlib.Path(cn.__file__).parent
    for path in sorted(package.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not (isinstance(node, ast.ImportFrom) and node.level == 1):
                continue
            if path.stem in ANALYSIS_MODULES or node.module in ANALYSIS_MODULES:
                private = [a.name for a in node.names
                           if a.name.startswith("_")]
                assert not private, f"{path.name} imports {private}"


def test_schedule_plot_returns_a_control_plot():
    P = cn.nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
               np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    cplt = cn.schedule_plot(P, 8)
    assert isinstance(cplt, ct.ControlPlot)
    assert cplt.axes.shape == (1, 1)
    assert len(cplt.lines[0, 0]) == 3          # two sensors, one actuator
    assert cplt.figure is cplt.axes[0, 0].figure


def test_schedule_plot_draws_in_given_axes():
    P = cn.nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
               np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    fig, ax = plt.subplots()
    cplt = cn.schedule_plot(P, ax=ax)
    assert cplt.axes[0, 0] is ax and cplt.figure is fig
