"""Design maps and schedule search: each cell is passivesyn,
schedules are enumerated up to symmetry, pruning is exact, executors give
the sequential result."""

from __future__ import annotations

import itertools
import math
import pickle
import sys
from concurrent.futures import Executor, Future, ThreadPoolExecutor, \
    ProcessPoolExecutor

import numpy as np
import pytest
import control as ct
from control.exception import ControlArgument

import control_ncs as ncs
from control_ncs import _schedules
from control_ncs.exceptions import REASONS


def scalar_plant(a=1.2, **network):
    """``x⁺ = a x + w + u``, ``z = x + w``, ``y = x``."""
    return ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, **network)


def two_state_plant(**network):
    """An asymmetric plant with two sensors and one actuator."""
    A = [[1.2, 0.3], [0.0, 0.9]]
    B = [[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]]
    C = [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]]
    D = np.block([[np.eye(2), np.zeros((2, 1))], [np.zeros((2, 3))]])
    return ncs.nss(A, B, C, D, nmeas=2, ncon=1, **network)


def symmetric_plant(**network):
    """Two identical coupled masses, each with its own actuator, disturbance
    and output: swapping states, actuators and (w, z) pairs 1 and 2 together
    leaves it unchanged."""
    A = [[1.1, 0.2], [0.2, 1.1]]
    B = [[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]]
    C = [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]]
    D = np.block([[np.eye(2), np.zeros((2, 2))], [np.zeros((2, 4))]])
    return ncs.nss(A, B, C, D, nmeas=2, ncon=2, **network)


def in_fresh_thread(func, *args, **kwargs):
    """``func(*args, **kwargs)`` in a new thread, whose cvxpy compile cache
    (per thread, lmi.py) is empty, as each sweep task's is."""
    with ThreadPoolExecutor(1) as ex:
        return ex.submit(func, *args, **kwargs).result()


def same(a, b):
    return np.array_equal(a, b, equal_nan=True)


# -- design_map -----------------------------------------------------------------

def test_design_map_cell_is_exactly_passivesyn_of_that_plant():
    P = scalar_plant()
    dm = ncs.design_map(P, [0.0, 0.4], [0.0, 0.3], decay=0.95, progress=False)
    for i, a1 in enumerate(dm.values[0]):
        for j, a2 in enumerate(dm.values[1]):
            Q = P.with_network(sensor_loss=a1, actuator_loss=a2)
            try:
                K, CL, eta = in_fresh_thread(ncs.passivesyn, Q, decay=0.95)
            except ncs.SynthesisError as err:
                assert not dm.feasible[i, j] and dm.reason[i, j] == err.reason
                continue
            assert dm.feasible[i, j] and dm.reason[i, j] == "certified"
            assert dm.eta[i, j] == eta
            assert dm.ms_radius[i, j] == pytest.approx(ncs.ms_radius(CL),
                                                       rel=1e-9)


def test_design_map_has_one_row_per_sensor_loss_and_one_column_per_actuator_loss():
    dm = ncs.design_map(scalar_plant(), [0.0, 0.1, 0.2], [0.0, 0.2],
                        eta=0.1, progress=False)
    assert dm.axes == ("sensor_loss", "actuator_loss")
    for arr in (dm.eta, dm.ms_radius, dm.feasible, dm.reason):
        assert arr.shape == (3, 2)


def test_design_map_marks_uncertified_cells_nan_with_their_reason():
    # with 80 % sensor loss the gain acts with probability 0.2, so E x² is
    # multiplied by at least 0.8·1.2² = 1.152 per step: no loop is MSS
    dm = ncs.design_map(scalar_plant(), [0.0, 0.8], [0.0], decay=0.95,
                        progress=False)
    assert dm.feasible.tolist() == [[True], [False]]
    assert math.isnan(dm.eta[1, 0]) and math.isnan(dm.ms_radius[1, 0])
    assert dm.reason[1, 0] in REASONS
    assert dm.reason.dtype == object


@pytest.mark.parametrize("bad", [[], [1.0], [-0.1], [float("nan")], ["a"],
                                 [[0.1, 0.2]]])
def test_design_map_refuses_bad_loss_grids_naming_the_argument(bad):
    with pytest.raises(ValueError, match="actuator_loss"):
        ncs.design_map(scalar_plant(), [0.0], bad, progress=False)


def test_design_map_refuses_a_static_gain_that_never_closes_the_loop():
    P = scalar_plant(sensor_schedule=[1, 0], actuator_schedule=[0, 1])
    with pytest.raises(ValueError, match="predictor"):
        ncs.design_map(P, [0.0], [0.0], progress=False)


def test_sweeps_refuse_unknown_keywords_and_bad_options():
    P = scalar_plant()
    with pytest.raises(TypeError):
        ncs.design_map(P, [0.0], [0.0], solver_speed=3)
    with pytest.raises(ControlArgument, match="executor"):
        ncs.design_map(P, [0.0], [0.0], executor=4, progress=False)
    with pytest.raises(ControlArgument, match="controller"):
        ncs.design_map(P, [0.0], [0.0], controller="pid", progress=False)
    with pytest.raises(ControlArgument, match="P"):
        ncs.design_map(ct.ss([[0.5]], [[1]], [[1]], [[0]], True), [0.0], [0.0])
    with pytest.raises(ValueError, match="decay"):
        ncs.design_map(P, [0.0], [0.0], decay=1.5, progress=False)
    with pytest.raises(ControlArgument, match="objective"):
        ncs.schedule_search(P, 2, objective="speed", progress=False)


def test_design_map_to_pandas_has_one_row_per_cell():
    dm = ncs.design_map(scalar_plant(), [0.0, 0.3], [0.0, 0.1, 0.2],
                        decay=0.95, progress=False)
    df = dm.to_pandas()
    assert len(df) == 6
    assert list(df.columns) == ["sensor_loss", "actuator_loss", "eta",
                                "ms_radius", "feasible", "reason"]
    row = df[(df.sensor_loss == 0.3) & (df.actuator_loss == 0.2)].iloc[0]
    assert same(row.eta, dm.eta[1, 2])


def test_to_pandas_without_pandas_raises_a_clear_import_error(monkeypatch):
    dm = ncs.design_map(scalar_plant(), [0.0], [0.0], eta=0.1, progress=False)
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        dm.to_pandas()


def test_design_map_plot_draws_heat_map_and_feasibility_boundary():
    dm = ncs.design_map(scalar_plant(), [0.0, 0.4, 0.8], [0.0, 0.3],
                        decay=0.95, progress=False)
    assert dm.feasible.any() and not dm.feasible.all()
    cplt = dm.plot()
    assert isinstance(cplt, ct.ControlPlot)
    assert cplt.axes.shape == (1, 1) and len(cplt.lines[0, 0]) == 2
    assert cplt.axes[0, 0].get_xlabel() == "actuator_loss"


def test_results_survive_pickling():
    dm = ncs.design_map(scalar_plant(), [0.0, 0.8], [0.0], decay=0.95,
                        progress=False)
    again = pickle.loads(pickle.dumps(dm))
    assert same(again.eta, dm.eta) and (again.reason == dm.reason).all()
    res = ncs.schedule_search(scalar_plant(), 2, decay=0.98, progress=False)
    back = pickle.loads(pickle.dumps(res))
    assert back.ranking == res.ranking and back.pruned_counts == \
        res.pruned_counts


def test_progress_bar_is_shown_when_asked(capsys):
    pytest.importorskip("tqdm")
    ncs.design_map(scalar_plant(), [0.0, 0.1], [0.0], eta=0.1, progress=True)
    assert "design_map" in capsys.readouterr().err


# -- executors ------------------------------------------------------------------

def test_thread_pool_gives_the_sequential_results():
    P = two_state_plant()
    kw = dict(decay=0.98, progress=False)
    dm = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], **kw)
    res = ncs.schedule_search(P, 2, **kw)
    with ThreadPoolExecutor(2) as ex:
        dm2 = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], executor=ex, **kw)
        res2 = ncs.schedule_search(P, 2, executor=ex, **kw)
    assert same(dm.eta, dm2.eta) and same(dm.ms_radius, dm2.ms_radius)
    assert (dm.reason == dm2.reason).all()
    assert same(res.eta, res2.eta) and (res.reason == res2.reason).all()
    assert res.ranking == res2.ranking


def test_process_pool_gives_the_sequential_results():
    P = two_state_plant()
    kw = dict(decay=0.98, progress=False)
    dm = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], **kw)
    res = ncs.schedule_search(P, 2, **kw)
    with ProcessPoolExecutor(2) as ex:
        dm2 = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], executor=ex, **kw)
        res2 = ncs.schedule_search(P, 2, executor=ex, **kw)
    assert same(dm.eta, dm2.eta) and same(dm.ms_radius, dm2.ms_radius)
    assert (dm.reason == dm2.reason).all()
    assert same(res.eta, res2.eta) and res.ranking == res2.ranking


@pytest.mark.slow
def test_dask_cluster_of_two_processes_gives_the_sequential_results():
    distributed = pytest.importorskip("distributed")
    P = scalar_plant()
    kw = dict(decay=0.98, progress=False)
    dm = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], **kw)
    res = ncs.schedule_search(P, 2, shared_channel=True,
                              controller="predictor", **kw)
    with distributed.LocalCluster(n_workers=2, processes=True,
                                  threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        ex = client.get_executor()
        dm2 = ncs.design_map(P, [0.0, 0.5], [0.0, 0.3], executor=ex, **kw)
        res2 = ncs.schedule_search(P, 2, shared_channel=True,
                                   controller="predictor", executor=ex, **kw)
    assert same(dm.eta, dm2.eta) and (dm.reason == dm2.reason).all()
    assert same(res.eta, res2.eta) and res.ranking == res2.ranking


class _InterruptedExecutor(Executor):
    """The first task is interrupted (Ctrl-C); the others never start."""

    def __init__(self):
        self.futures = []

    def submit(self, fn, /, *args, **kwargs):
        fut = Future()
        if not self.futures:
            fut.set_exception(KeyboardInterrupt())
        self.futures.append(fut)
        return fut


class _RefusingExecutor(Executor):
    """Fails the test if any task reaches it."""

    def submit(self, fn, /, *args, **kwargs):
        raise AssertionError("a task was submitted")


def test_ctrl_c_cancels_pending_work_and_propagates():
    ex = _InterruptedExecutor()
    with pytest.raises(KeyboardInterrupt):
        ncs.design_map(scalar_plant(), [0.0, 0.1, 0.2], [0.0], eta=0.1,
                       executor=ex, progress=False)
    assert len(ex.futures) == 3
    assert all(f.cancelled() for f in ex.futures[1:])


# -- schedule_search: enumeration and symmetry ------------------------------------

def _orbits_by_brute_force(p2, m2, N, shared, relabel=()):
    """Count schedules up to rotation (and the given letter maps) by
    listing every word, independently of the necklace generator."""
    letters = [(i, j) for i in range(p2 + 1) for j in range(m2 + 1)
               if not (shared and i and j)]
    seen, orbits = set(), 0
    for word in itertools.product(letters, repeat=N):
        if word in seen:
            continue
        orbits += 1
        images = [word] + [tuple(h(x) for x in word) for h in relabel]
        for w in images:
            for r in range(N):
                seen.add(w[r:] + w[:r])
    return orbits, len(letters) ** N


def uncontrollable_plant():
    """The actuator only reaches state 2; state 1 is unstable and decoupled:
    every schedule is pruned, so enumeration is tested without LMIs."""
    A = [[1.5, 0.0], [0.0, 0.5]]
    B = [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]
    C = [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]]
    D = np.block([[np.eye(2), np.zeros((2, 1))], [np.zeros((2, 3))]])
    return ncs.nss(A, B, C, D, nmeas=2, ncon=1)


@pytest.mark.parametrize("N,shared", [(2, False), (3, False), (4, True),
                                      (5, False)])
def test_every_schedule_is_explored_once_up_to_cyclic_shift(N, shared):
    P = uncontrollable_plant()
    res = ncs.schedule_search(P, N, shared_channel=shared,
                              controller="predictor", progress=False)
    orbits, total = _orbits_by_brute_force(2, 1, N, shared)
    assert res.relabellings == 1
    assert (res.explored, res.total) == (orbits, total)
    words = {tuple(zip(a, b)) for a, b in zip(res.sensor_schedules.tolist(),
                                               res.actuator_schedules.tolist())}
    assert len(words) == res.explored
    assert all(min(w[r:] + w[:r] for r in range(N)) == w for w in words)


def test_cyclic_shift_of_a_schedule_gives_the_same_certified_eta():
    P = two_state_plant(sensor_loss=0.1, actuator_loss=0.1)
    s1, s2 = [1, 2, 0], [1, 1, 0]
    K, _, eta = ncs.passivesyn(P.with_network(sensor_schedule=s1,
                                              actuator_schedule=s2),
                               decay=0.98)
    K2, _, eta2 = ncs.passivesyn(P.with_network(sensor_schedule=s1[1:] + s1[:1],
                                                actuator_schedule=s2[1:] + s2[:1]),
                                 decay=0.98)
    assert eta2 == pytest.approx(eta, abs=1e-5)


def test_relabelling_is_used_only_when_the_plant_is_invariant():
    assert len(_schedules._relabellings(two_state_plant())) == 1
    group = _schedules._relabellings(symmetric_plant())
    assert sorted(group) == [((0, 1), (0, 1)), ((1, 0), (1, 0))]


def test_relabelling_reduces_the_search_to_orbits_of_the_symmetric_plant():
    res = ncs.schedule_search(symmetric_plant(), 2, controller="predictor",
                              decay=0.99, progress=False)
    swap = lambda x: ((3 - x[0]) % 3, (3 - x[1]) % 3)  # noqa: E731  1<->2
    orbits, _ = _orbits_by_brute_force(2, 2, 2, False, relabel=(swap,))
    assert res.relabellings == 2 and res.explored == orbits


def test_relabelled_schedule_gives_the_same_certified_eta():
    P = symmetric_plant(sensor_loss=0.1)
    _, _, eta = ncs.passivesyn(P.with_network(sensor_schedule=[1, 2, 0],
                                              actuator_schedule=[1, 2, 2]),
                               decay=0.99)
    _, _, eta2 = ncs.passivesyn(P.with_network(sensor_schedule=[2, 1, 0],
                                               actuator_schedule=[2, 1, 1]),
                                decay=0.99)
    assert eta2 == pytest.approx(eta, abs=1e-6)


def test_too_many_schedules_are_refused_with_their_number():
    P = two_state_plant()
    count = _schedules._orbit_count(8, [tuple(range(6))])
    with pytest.raises(ValueError, match=f"gives {count} schedules"):
        ncs.schedule_search(P, 8, limit=100, progress=False)


@pytest.mark.parametrize("bad", [0, -1, 2.0, True])
def test_schedule_search_refuses_a_bad_period(bad):
    with pytest.raises(ValueError, match="period"):
        ncs.schedule_search(scalar_plant(), bad, progress=False)


def test_schedule_search_refuses_a_loss_of_one():
    with pytest.raises(ValueError, match="sensor_loss"):
        ncs.schedule_search(scalar_plant(), 2, sensor_loss=1.0,
                            progress=False)


def test_sweeps_refuse_a_plant_without_full_state_measurement_up_front():
    # y = x1 only: every schedule would be pruned or fail in a worker
    P = ncs.nss([[1.2, 0.1], [0.0, 0.5]], [[1.0, 1.0], [0.0, 1.0]],
                [[1.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]],
                nmeas=1, ncon=1)
    with pytest.raises(ControlArgument, match="y = x"):
        ncs.schedule_search(P, 2, executor=_RefusingExecutor(),
                            progress=False)
    with pytest.raises(ControlArgument, match="y = x"):
        ncs.design_map(P, [0.0], [0.0], executor=_RefusingExecutor(),
                       progress=False)


# -- schedule_search: pruning ---------------------------------------------------

def test_static_gain_over_a_shared_channel_is_pruned_entirely():
    res = ncs.schedule_search(scalar_plant(), 3, shared_channel=True,
                              progress=False)
    assert res.pruned.all() and res.evaluated == 0
    assert res.pruned_counts == {"loop_open": res.explored}
    assert res.ranking == []


def test_every_pruned_schedule_really_has_no_certified_gain():
    P = two_state_plant(sensor_loss=0.2)
    for controller in ("static", "predictor"):
        res = ncs.schedule_search(P, 2, controller=controller, decay=0.99,
                                  progress=False)
        assert res.pruned.any()
        for i in np.flatnonzero(res.pruned):
            Q = P.with_network(sensor_schedule=res.sensor_schedules[i].tolist(),
                               actuator_schedule=res.actuator_schedules[i].tolist())
            if res.reason[i] == "loop_open":
                with pytest.raises(ValueError, match="never closes"):
                    ncs.passivesyn(Q, decay=0.99, controller=controller)
                continue
            with pytest.raises(ncs.SynthesisError):
                ncs.passivesyn(Q, decay=0.99, controller=controller)


def test_uncontrollable_unstable_mode_is_pruned_as_not_stabilisable():
    P = uncontrollable_plant()
    res = ncs.schedule_search(P, 2, progress=False)
    assert res.evaluated == 0
    assert set(res.pruned_counts) <= {"loop_open", "not_stabilisable"}
    assert res.pruned_counts["not_stabilisable"] > 0


def test_predictor_whose_estimation_error_is_not_mss_is_pruned():
    # a = 2, sensor reports every phase but is lost 30 %: the error loop
    # e⁺ = (1 − θ1) 2 e has E e² multiplied by 0.3·4 = 1.2 per step
    P = scalar_plant(a=2.0)
    res = ncs.schedule_search(P, 1, controller="predictor", sensor_loss=0.3,
                              progress=False)
    i = [k for k in range(res.explored)
         if res.sensor_schedules[k].tolist() == [1]
         and res.actuator_schedules[k].tolist() == [1]][0]
    assert res.reason[i] == "estimation_not_mss"
    with pytest.raises(ncs.SynthesisError):
        ncs.passivesyn(P.with_network(sensor_loss=0.3),
                       controller="predictor")


def test_predictor_error_loop_below_one_is_not_pruned():
    # 20 % loss: 0.2·4 = 0.8 < 1, so the schedule goes to passivesyn
    res = ncs.schedule_search(scalar_plant(a=2.0), 1, controller="predictor",
                              sensor_loss=0.2, progress=False)
    i = [k for k in range(res.explored)
         if res.sensor_schedules[k].tolist() == [1]
         and res.actuator_schedules[k].tolist() == [1]][0]
    assert not res.pruned[i]


# -- schedule_search: ranking ---------------------------------------------------

def test_ranking_is_best_eta_first_and_reports_counts():
    res = ncs.schedule_search(two_state_plant(), 3, decay=0.98, top=4,
                              progress=False, method="lmi")
    etas = [r.eta for r in res.ranking]
    assert len(etas) == 4 and etas == sorted(etas, reverse=True)
    assert etas[0] == np.nanmax(res.eta)
    assert res.explored == res.evaluated + int(res.pruned.sum())
    assert sum(res.pruned_counts.values()) == int(res.pruned.sum())
    best = res.ranking[0]
    _, _, eta = in_fresh_thread(ncs.passivesyn, two_state_plant().with_network(
        sensor_schedule=list(best.sensor_schedule),
        actuator_schedule=list(best.actuator_schedule)), decay=0.98,
        method="lmi")                   # the sweep's method
    assert eta == best.eta
    # the default search refines where the LMI is only sufficient: never a
    # lower level for any schedule
    auto = ncs.schedule_search(two_state_plant(), 3, decay=0.98, top=4,
                               progress=False)
    assert auto.ranking[0].eta >= best.eta
    both = res.feasible & auto.feasible
    assert np.all(auto.eta[both] >= res.eta[both] - 1e-12)
    assert np.all(auto.feasible >= res.feasible)


def test_rate_objective_ranks_fastest_certified_loop_first():
    res = ncs.schedule_search(two_state_plant(), 2, objective="rate",
                              eta=-0.5, top=3, progress=False)
    rates = [r.ms_radius for r in res.ranking]
    assert rates == sorted(rates) and rates[0] == np.nanmin(res.ms_radius)


def test_schedule_search_plot_draws_one_timeline_per_ranked_schedule():
    res = ncs.schedule_search(two_state_plant(), 2, decay=0.98, top=3,
                              progress=False)
    cplt = res.plot()
    assert isinstance(cplt, ct.ControlPlot)
    assert cplt.axes.shape == (3, 1)
    assert len(cplt.lines[0, 0]) == 3  # two sensors and one actuator


def test_schedule_search_to_pandas_lists_ranked_schedules_first():
    res = ncs.schedule_search(two_state_plant(), 2, decay=0.98, top=2,
                              progress=False)
    df = res.to_pandas()
    assert len(df) == res.explored
    assert df["rank"].tolist()[:2] == [1, 2]
    assert df["sensor_schedule"].iloc[0] == res.ranking[0].sensor_schedule


def test_sweeps_pass_the_synthesis_method_and_check_it():
    # default 'lmi' (fast); 'auto' refines structured cells: never below
    # the LMI's certified η on the same cell
    P = ncs.nss([[1.2, 0.3], [0.0, 0.7]], [[1.0, 1.0], [0.5, 0.0]],
            [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]], nmeas=2, ncon=1,
            sensor_schedule=[[1, 1], [1, 0]])
    with pytest.raises(ControlArgument, match="method"):
        ncs.design_map(P, 0.1, 0.1, method="fast", progress=False)
    lmi = ncs.design_map(P, 0.1, [0.1, 0.2], eta=-10.0, progress=False)
    refined = ncs.design_map(P, 0.1, [0.1, 0.2], eta=-10.0, method="auto",
                         progress=False)
    assert np.all(refined.feasible >= lmi.feasible)


@pytest.mark.parametrize("maps", [
    [(0, 1, 2)],                                  # no relabelling
    [(0, 1, 2), (1, 0, 2)],                       # a swap of two letters
    [(0, 1, 2), (1, 2, 0), (2, 0, 1)],            # a 3-cycle group
])
@pytest.mark.parametrize("N", [1, 2, 3, 4, 6])
def test_schedule_count_equals_a_brute_force_count_of_orbits(maps, N):
    import itertools
    orbits = set()
    for word in itertools.product(range(3), repeat=N):
        orbits.add(min(tuple(h[x] for x in word[r:] + word[:r])
                       for h in maps for r in range(N)))
    assert _schedules._orbit_count(N, maps) == len(orbits)


def test_a_map_over_a_bursty_link_keeps_the_bursts():
    """Once the map replaced the link by Bernoulli losses (η 0.49192 where
    the bursty loop certifies 0.48694)."""
    link = ncs.gilbert_elliott(loss=0.2, burst=2.0)
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                actuator_loss=link)
    dm = ncs.design_map(P, [0.0], [0.1, 0.2], decay=0.95, progress=False)
    for j, loss in enumerate((0.1, 0.2)):
        _, _, eta = in_fresh_thread(ncs.passivesyn, P.with_network(
            actuator_loss=ncs.gilbert_elliott(loss=loss, burst=2.0)),
            decay=0.95)
        assert dm.eta[0, j] == pytest.approx(eta, rel=1e-9)
    bernoulli = ncs.design_map(P.with_network(actuator_loss=0.2), [0.0],
                               [0.2], decay=0.95, progress=False)
    assert dm.eta[0, 1] < bernoulli.eta[0, 0] - 1e-3


def test_a_passivity_map_over_the_burst_length_is_passivesyn_per_cell():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
    dm = ncs.design_map(P, actuator_loss=[0.2], actuator_burst=[1.25, 1.5],
                        decay=0.95, progress=False)
    assert dm.axes == ("actuator_loss", "actuator_burst")
    for j, burst in enumerate((1.25, 1.5)):
        _, _, eta = in_fresh_thread(ncs.passivesyn, P.with_network(
            actuator_loss=ncs.gilbert_elliott(loss=0.2, burst=burst)),
            decay=0.95)
        assert dm.eta[0, j] == pytest.approx(eta, rel=1e-9)
    assert dm.eta[0, 1] < dm.eta[0, 0]          # longer bursts cost


def test_a_loss_a_bursty_link_cannot_reach_is_refused_naming_it():
    link = ncs.gilbert_elliott(loss=0.2, burst=1.1)
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                actuator_loss=link)
    with pytest.raises(ValueError, match="^loss: 0.95 cannot be reached"):
        ncs.design_map(P, [0.0], [0.95], progress=False)


def test_pruning_and_the_estimator_use_one_lifted_pbh_test():
    """A mode at 1.2 seen only by sensor 2: a schedule that never lets
    sensor 2 send is pruned as not detectable by the search, and the
    estimator refuses the same schedule, with one test and one tolerance."""
    from control_ncs._lifting import unseen_modes
    A = np.diag([0.5, 1.2])
    C2 = np.eye(2)
    sensor_1_only = [np.array([[1.0, 0.0], [0.0, 0.0]])]
    assert unseen_modes(A, sensor_1_only) == [1.2 + 0j]
    assert unseen_modes(A, [C2]) == []
    P = ncs.nss(A, np.hstack([np.eye(2), np.eye(2)]),
                np.vstack([np.eye(2), C2]), np.zeros((4, 4)),
                nmeas=2, ncon=2, sensor_schedule=[1])
    with pytest.raises(ValueError, match="not detectable"):
        ncs.estimator_gain(P)
    pruned = _schedules._prune(P, np.array([[1, 0]]), np.array([[1, 1]]),
                               "predictor", "zero", 0.0, None)
    assert pruned == "not_detectable"


def test_progress_is_quiet_by_default_where_nobody_watches(capsys):
    """Under pytest stderr is captured (not a terminal) and no kernel runs:
    the default shows no bar."""
    pytest.importorskip("tqdm")
    ncs.design_map(scalar_plant(), [0.0, 0.1], [0.0], eta=0.1)
    assert "design_map" not in capsys.readouterr().err


def test_progress_is_shown_by_default_in_a_terminal(capsys, monkeypatch):
    pytest.importorskip("tqdm")
    from control_ncs import _tasks
    monkeypatch.setattr(_tasks, "_watched", lambda: True)
    ncs.design_map(scalar_plant(), [0.0, 0.1], [0.0], eta=0.1)
    assert "design_map" in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["yes", 1, 0.5])
def test_progress_must_be_true_false_or_none(bad):
    from control.exception import ControlArgument
    with pytest.raises(ControlArgument, match="^progress: expected True"):
        ncs.design_map(scalar_plant(), [0.0], [0.0], progress=bad)


def test_design_map_plot_reads_title_inside_and_probability_axes_from_zero():
    import matplotlib.pyplot as plt
    dm = ncs.design_map(scalar_plant(), [0.0, 0.1], [0.0, 0.1], eta=0.1,
                        progress=False)
    cp = ncs.design_map_plot(dm)
    try:
        fig, ax = cp.figure, cp.axes[0, 0]
        fig.canvas.draw()
        box = ax.title.get_window_extent(fig.canvas.get_renderer())
        assert box.x0 >= 0 and box.x1 <= fig.bbox.width
        assert ax.get_xlabel() == "actuator_loss"
        assert ax.get_ylabel() == "sensor_loss"
        assert min(ax.get_xlim()) >= 0 and min(ax.get_ylim()) >= 0
    finally:
        plt.close(cp.figure)


def _two_state_h2_plant():
    A = np.array([[1.1, 0.3], [0.0, 0.8]])
    return ncs.nss(A, np.array([[1.0, 1.0], [0.0, 0.5]]),
                   np.array([[1.0, 0.0], [0.0, 0.0], [1.0, 0.0],
                             [0.0, 1.0]]),
                   np.array([[0.2, 0.0], [0.0, 0.5], [0.0, 0.0],
                             [0.0, 0.0]]), True, nmeas=2, ncon=1,
                   actuator_loss=0.1)


def test_schedule_search_ranks_by_the_designed_h2_norm():
    """objective='h2': every schedule (one sensor per phase, so the gain
    is structured) designed by h2syn's local search and ranked by the exact
    norm; each figure is h2syn's on that schedule, and none beats the
    design that hears both sensors at every step."""
    P = _two_state_h2_plant()
    res = ncs.schedule_search(P, 2, objective="h2", progress=False)
    ranked = res.ranking
    assert len(ranked) == int(res.feasible.sum()) > 2
    values = [s.value for s in ranked]
    assert values == sorted(values)
    full = ncs.h2syn(P)[2]
    for s in ranked[:3]:
        Ps = P.with_network(sensor_schedule=list(s.sensor_schedule),
                            actuator_schedule=list(s.actuator_schedule))
        K, CL, h2 = in_fresh_thread(ncs.h2syn, Ps)
        assert K.result.route == "local"
        assert s.value == pytest.approx(h2, rel=1e-9)
        assert h2 >= full * (1 - 1e-9)          # less information
    assert "h2 = " in res.summary() and "h2" in res.to_pandas()


def test_schedule_search_ranks_by_the_certified_l2_gain():
    P = _two_state_h2_plant()
    res = ncs.schedule_search(P, 1, objective="hinf", progress=False)
    assert len(res.ranking) == 1 and res.pruned_counts      # sensor 1 only
    best = res.ranking[0]
    Ps = P.with_network(sensor_schedule=list(best.sensor_schedule),
                        actuator_schedule=list(best.actuator_schedule))
    K, CL, gamma = in_fresh_thread(ncs.hinfsyn, Ps)
    assert best.value == pytest.approx(gamma, rel=1e-6)
    assert gamma >= ncs.hinfsyn(P)[2] * (1 - 1e-6)     # less information


@pytest.mark.parametrize("objective", ["h2", "hinf"])
@pytest.mark.parametrize("kwargs", [dict(eta=0.1), dict(decay=0.9),
                                    dict(method="lmi")])
def test_schedule_search_by_performance_refuses_passivity_options(
        kwargs, objective):
    name = next(iter(kwargs))
    with pytest.raises(ControlArgument,
                       match=f"^{name}: objective='{objective}'"):
        ncs.schedule_search(_two_state_h2_plant(), 2, objective=objective,
                            progress=False, **kwargs)
