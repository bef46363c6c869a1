"""Compiled LMIs reused per shape (lmi.py): same answers, bounded, per thread.

Every number of the data is a cvxpy Parameter, so a problem of a given shape
is compiled once and then only re-loaded with data. A reused problem must
give exactly the answer of a freshly built one, for any data of that shape.
"""

import threading

import numpy as np
import pytest

from control_ncs import lmi
from control_ncs.strategies import build

from helpers import random_jump, random_plant

REL = 1e-6


@pytest.fixture(autouse=True)
def empty_cache():
    lmi.cache_clear()
    yield
    lmi.cache_clear()


def plants(seeds, **network):
    """Jump plants of one shape (n = 3, two actuators, lossy), one per seed."""
    network = network or dict(actuator_loss=0.2, sensor_loss=0.1)
    return [build(random_plant(np.random.default_rng(seed), n=3, m1=1, m2=2,
                               **network)) for seed in seeds]


def loops(seeds):
    """Mean-square stable two-periodic jump systems of one shape."""
    return [random_jump(np.random.default_rng(seed), n=3, N=2, M=2, m=1, p=1,
                        radius=0.5) for seed in seeds]


def max_eta(plant, structure="full", form="merged"):
    model = lmi.synthesis_model(plant, None, 1.0, lmi.DEFAULT_MARGIN,
                                structure, form)
    report = lmi.solve(model.problem)
    assert report.status in ("optimal", "optimal_inaccurate")
    gains, P = lmi.read_gains(model, plant)
    return report.value, gains


def fresh(fn, *args, **kwargs):
    """``fn`` on an empty cache: a problem built and compiled anew."""
    lmi.cache_clear()
    return fn(*args, **kwargs)


def close(a, b):
    return abs(a - b) <= REL * max(1.0, abs(b))


# -- DPP -----------------------------------------------------------------------
@pytest.mark.parametrize("eta", [None, 0.1])
@pytest.mark.parametrize("form", ["merged", "paper"])
@pytest.mark.parametrize("structure", ["full", "block", "extended"])
def test_synthesis_problem_is_dpp(structure, form, eta):
    network = (dict(sensor_schedule=[1, 2], actuator_loss=0.2)
               if structure != "full" else {})
    plant, = plants([0], **network)
    model = lmi.synthesis_model(plant, eta, 0.9, lmi.DEFAULT_MARGIN,
                                structure, form)
    assert model.problem.is_dpp()


@pytest.mark.parametrize("eta, margin", [(None, 1e-7), (0.1, 1e-7),
                                         (0.1, None)])
def test_analysis_problem_is_dpp(eta, margin):
    sys, = loops([0])
    assert lmi.analysis_model(sys, eta, margin, 0.95).problem.is_dpp()


# -- same answers --------------------------------------------------------------
@pytest.mark.parametrize("structure, network", [
    ("full", dict(actuator_loss=0.2, sensor_loss=0.1)),
    ("extended", dict(sensor_schedule=[[1, 1, 0], [0, 1, 1]],
                      actuator_loss=0.1)),
    ("block", dict(sensor_schedule=[[1, 1, 0], [0, 1, 1]],
                   actuator_loss=0.1))])
def test_reused_synthesis_problem_gives_the_fresh_optimum(structure, network):
    group = plants([1, 2, 3], **network)
    reused = [max_eta(plant, structure) for plant in group]
    assert lmi.cache_info()["misses"] == 1
    for plant, (value, gains) in zip(group, reused):
        value0, gains0 = fresh(max_eta, plant, structure)
        assert close(value, value0)
        np.testing.assert_allclose(gains, gains0, rtol=1e-4, atol=1e-6)
    # the plants differ, so their answers do
    assert len({round(v, 6) for v, _ in reused}) == len(group)


def test_reused_synthesis_problem_follows_an_eta_sweep():
    plant, = plants([4])
    top, _ = max_eta(plant)

    def statuses():
        out = []
        for eta in (top - 0.5, top - 0.05, top + 0.05, top - 0.2):
            model = lmi.synthesis_model(plant, eta, 1.0, lmi.DEFAULT_MARGIN,
                                        "full", "merged")
            out.append(lmi.solve(model.problem).status)
        return out

    swept = statuses()
    assert lmi.cache_info()["hits"] == 3
    assert swept == ["optimal", "optimal", "infeasible", "optimal"]
    assert fresh(statuses) == swept


@pytest.mark.parametrize("eta, margin", [(None, 1e-7), (0.0, None)])
def test_reused_analysis_problem_gives_the_fresh_optimum(eta, margin):
    def solve(sys, level):
        model = lmi.analysis_model(sys, level, margin, 1.0)
        report = lmi.solve(model.problem)
        assert report.status == "optimal"
        return report.value

    # two systems of one shape, and (margin maximised) an η sweep
    cases = [(sys, eta) for sys in loops([5, 6])]
    if eta is not None:
        cases += [(cases[0][0], level) for level in (-0.5, -1.0)]
    reused = [solve(sys, level) for sys, level in cases]
    assert lmi.cache_info() == dict(hits=len(cases) - 1, misses=1, size=1,
                                     maxsize=lmi.CACHE_SIZE)
    for (sys, level), value in zip(cases, reused):
        assert close(value, fresh(solve, sys, level))
    assert len({round(v, 6) for v in reused}) == len(cases)


def test_decay_and_margin_are_data_not_shape():
    plant, = plants([7])

    def solve(decay, margin):
        model = lmi.synthesis_model(plant, None, decay, margin, "full",
                                    "merged")
        return lmi.solve(model.problem).value

    settings = [(1.0, 1e-7), (0.95, 1e-7), (1.0, 1e-5)]
    reused = [solve(*setting) for setting in settings]
    assert lmi.cache_info()["misses"] == 1
    for setting, value in zip(settings, reused):
        assert close(value, fresh(solve, *setting))
    # a decay bound shrinks the feasible set: η never grows (to the
    # solver's accuracy; the bound need not be active on this plant)
    assert reused[1] <= reused[0] + REL * max(1.0, abs(reused[0]))


# -- the cache -----------------------------------------------------------------
def test_same_shape_reuses_the_compiled_problem():
    a, b = plants([8, 9])
    first = lmi.synthesis_model(a, None, 1.0, 1e-7, "full", "merged")
    second = lmi.synthesis_model(b, None, 1.0, 1e-7, "full", "merged")
    assert second.problem is first.problem
    assert lmi.cache_info() == dict(hits=1, misses=1, size=1,
                                     maxsize=lmi.CACHE_SIZE)


@pytest.mark.parametrize("change", ["size", "eta", "form", "network"])
def test_a_different_shape_builds_its_own_problem(change):
    plant, = plants([10])
    other = {"size": build(random_plant(np.random.default_rng(10), n=4, m1=1,
                                        m2=2, actuator_loss=0.2)),
             "network": plants([10], sensor_schedule=[1, 2, 3])[0]
             }.get(change, plant)
    first = lmi.synthesis_model(plant, None, 1.0, 1e-7, "full", "merged")
    second = lmi.synthesis_model(
        other, 0.1 if change == "eta" else None, 1.0, 1e-7,
        "extended" if change == "network" else "full",
        "paper" if change == "form" else "merged")
    assert second.problem is not first.problem
    assert (lmi.cache_info()["misses"], lmi.cache_info()["hits"]) == (2, 0)


def test_the_cache_stays_bounded_and_drops_the_least_recent():
    systems = [random_jump(np.random.default_rng(n), n=n, N=1, M=2,
                           radius=0.5) for n in range(1, lmi.CACHE_SIZE + 3)]
    for sys in systems:
        lmi.analysis_model(sys, None, 1e-7)
        assert lmi.cache_info()["size"] <= lmi.CACHE_SIZE
    assert lmi.cache_info()["size"] == lmi.CACHE_SIZE
    misses = lmi.cache_info()["misses"]
    lmi.analysis_model(systems[-1], None, 1e-7)  # recent: kept
    assert lmi.cache_info()["misses"] == misses
    lmi.analysis_model(systems[0], None, 1e-7)   # oldest: dropped
    assert lmi.cache_info()["misses"] == misses + 1


def test_each_model_solves_its_own_data():
    a, b = plants([11, 12])
    value_a, value_b = max_eta(a), max_eta(b)
    model_a = lmi.synthesis_model(a, None, 1.0, 1e-7, "full", "merged")
    model_b = lmi.synthesis_model(b, None, 1.0, 1e-7, "full", "merged")
    # model_b loaded last, but model_a.problem carries model_a's data
    assert close(lmi.solve(model_a.problem).value, value_a[0])
    lmi.read_gains(model_a, a)
    assert close(lmi.solve(model_b.problem).value, value_b[0])
    # model_a's variables now hold model_b's answer: reading them is refused
    with pytest.raises(RuntimeError, match="not solved with its data"):
        lmi.read_gains(model_a, a)


def test_an_unsolved_model_never_reads_another_models_solution():
    a, b = plants([11, 12])
    model_a = lmi.synthesis_model(a, None, 1.0, 1e-7, "full", "merged")
    lmi.solve(model_a.problem)
    model_b = lmi.synthesis_model(b, None, 1.0, 1e-7, "full", "merged")
    # model_b was built but never solved: the variables hold nothing of a's
    with pytest.raises(RuntimeError, match="not solved with its data"):
        lmi.read_gains(model_b, b)
    assert all(X.value is None for X in model_b.X)


def test_touching_a_solved_model_after_another_was_solved_is_refused():
    a, b = plants([11, 12])
    model_a = lmi.synthesis_model(a, None, 1.0, 1e-7, "full", "merged")
    lmi.solve(model_a.problem)
    model_b = lmi.synthesis_model(b, None, 1.0, 1e-7, "full", "merged")
    lmi.solve(model_b.problem)
    _ = model_a.problem    # reloads a's data; the variables held b's answer
    with pytest.raises(RuntimeError, match="not solved with its data"):
        lmi.read_gains(model_a, a)
    lmi.solve(model_a.problem)
    lmi.read_gains(model_a, a)      # solved again: readable


def test_compile_time_is_reported_for_reused_problems():
    a, b = plants([13, 14])
    for plant in (a, b):
        model = lmi.synthesis_model(plant, None, 1.0, 1e-7, "full", "merged")
        report = lmi.solve(model.problem)
        assert report.compile_time == model.problem.compilation_time
        assert 0 < report.compile_time <= report.total_time


# -- threads -------------------------------------------------------------------
def test_threads_never_share_a_problem():
    group = plants([15, 16])
    expected = [fresh(max_eta, plant)[0] for plant in group]
    barrier = threading.Barrier(len(group))
    results, problems, errors = {}, {}, []

    def work(index):
        try:
            out = []
            for _ in range(3):
                barrier.wait()
                model = lmi.synthesis_model(group[index], None, 1.0, 1e-7,
                                            "full", "merged")
                problems.setdefault(index, model.problem)
                report = lmi.solve(model.problem)
                lmi.read_gains(model, group[index])
                out.append(report.value)
            results[index] = (out, lmi.cache_info())
        except BaseException as err:  # reported in the main thread
            errors.append(err)
            barrier.abort()

    threads = [threading.Thread(target=work, args=(i,))
               for i in range(len(group))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    assert problems[0] is not problems[1]
    for index, value in enumerate(expected):
        values, info = results[index]
        assert all(close(v, value) for v in values)
        assert (info["misses"], info["hits"]) == (1, 2)


class ScriptedClarabel:
    """Stands in for ``problem.solve``: answers each call with the next
    status of a script, warns as cvxpy does on an inaccurate answer, and
    records the options it was given. Whether a real Clarabel stalls just
    above a tolerance depends on its version; what ``lmi.solve`` does with
    each answer does not, so the answers are scripted here."""

    def __init__(self, problem, statuses):
        self.problem = problem
        self.statuses = list(statuses)
        self.calls = []

    def __call__(self, solver=None, **opts):
        import warnings
        status = self.statuses[len(self.calls)]
        self.calls.append(dict(opts))
        if status == "optimal_inaccurate":
            warnings.warn("Solution may be inaccurate. Try another solver, "
                          "adjusting the solver settings, or solve with "
                          "verbose=True for more information.", UserWarning,
                          stacklevel=2)
        self.problem._status = status
        self.problem._value = 1.0 if status.startswith("optimal") else None
        return self.problem._value


def scripted(statuses):
    sys, = loops([6])
    problem = lmi.analysis_model(sys, None, 1e-7, 1.0).problem
    stub = ScriptedClarabel(problem, statuses)
    problem.solve = stub        # on this instance only
    return problem, stub


def test_analysis_lmi_at_the_default_accuracy_is_optimal():
    sys, = loops([6])
    model = lmi.analysis_model(sys, None, 1e-7, 1.0)
    assert lmi.solve(model.problem).status == "optimal"


def test_a_stall_just_above_the_default_accuracy_is_asked_again_at_clarabels_own():
    problem, stub = scripted(["optimal_inaccurate", "optimal"])
    report = lmi.solve(problem)
    assert report.status == "optimal"
    assert len(stub.calls) == 2
    assert stub.calls[0]["tol_gap_abs"] == lmi.CLARABEL_DEFAULTS["tol_gap_abs"]
    assert not any(key.startswith("tol_") for key in stub.calls[1])
    assert report.options == stub.calls[1]


def test_a_stall_that_stays_inaccurate_keeps_the_first_answer():
    problem, stub = scripted(["optimal_inaccurate", "optimal_inaccurate",
                              "optimal_inaccurate"])
    report = lmi.solve(problem)
    assert report.status == "optimal_inaccurate"
    # the first (strict) solve is repeated, so the problem holds its answer
    assert stub.calls[2] == stub.calls[0]


def test_the_callers_own_tolerances_are_taken_at_their_word():
    problem, stub = scripted(["optimal_inaccurate"])
    report = lmi.solve(problem, "CLARABEL", tol_gap_abs=1e-9,
                       tol_gap_rel=1e-9, tol_feas=1e-9)
    assert report.status == "optimal_inaccurate"
    assert len(stub.calls) == 1


def test_solver_accuracy_warning_never_reaches_the_caller():
    """cvxpy warns "Solution may be inaccurate" on such an answer; the
    status says it already."""
    import warnings
    problem, stub = scripted(["optimal_inaccurate"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = lmi.solve(problem, "CLARABEL", tol_gap_abs=1e-9,
                           tol_gap_rel=1e-9, tol_feas=1e-9)
    assert report.status == "optimal_inaccurate"
    assert len(stub.calls) == 1
    assert [str(w.message) for w in caught] == []


def test_index_analysis_through_an_inaccurate_first_solve_emits_no_warning():
    import warnings
    from control_ncs import get_input_ff_index
    sys, = loops([6])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        get_input_ff_index(sys)
    assert [str(w.message) for w in caught] == []
