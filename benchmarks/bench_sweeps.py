"""Benchmark 7: design maps and schedule search on 1, 2 workers and Dask."""

from __future__ import annotations

import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np

from .common import random_plant
from .report import Section, Target, fmt_t, fmt_x


def _same(a, b) -> bool:
    return (np.array_equal(a.eta, b.eta, equal_nan=True)
            and np.array_equal(a.ms_radius, b.ms_radius, equal_nan=True)
            and bool((a.reason == b.reason).all()))


def schedule_plant():
    """Two states measured by two sensors, one actuator: ``x⁺ = A x + ...``
    with one unstable mode coupled to the stable one (seeded data would do
    as well; a fixed plant keeps the counts readable)."""
    from control_ncs import nss
    A = [[1.1, 0.2], [0.1, 0.8]]
    B = [[0.3, 0.0, 1.0], [0.0, 0.3, 0.4]]
    C = [[0.5, 0.0], [0.0, 0.5], [1.0, 0.0], [0.0, 1.0]]
    D = np.block([[2 * np.eye(2), np.zeros((2, 1))], [np.zeros((2, 3))]])
    return nss(A, B, C, D, nmeas=2, ncon=1, sensor_loss=0.05,
               actuator_loss=0.1)


def _design_maps(sec: Section, quick: bool) -> None:
    import control_ncs as cn
    n, side = (2, 2) if quick else (8, 20)
    P = random_plant(n, 1, seed=0)
    grid = np.linspace(0.0, 0.4, side)
    kw = dict(decay=0.99, progress=False)
    runs, results = {}, {}

    def timed(label, executor):
        t = time.perf_counter()
        results[label] = cn.design_map(P, grid, grid, executor=executor, **kw)
        runs[label] = time.perf_counter() - t

    timed("sequential (this process)", None)
    if quick:  # a smoke run: no interpreters to spawn
        with ThreadPoolExecutor(2) as ex:
            timed("thread pool, 2 threads", ex)
    ctx = multiprocessing.get_context("spawn")
    for workers in (() if quick else (1, 2)):
        # pool start-up (spawned interpreters importing control_ncs) is
        # part of what a user pays, so it is inside the timing
        t = time.perf_counter()
        with ProcessPoolExecutor(workers, mp_context=ctx) as ex:
            results[f"process pool, {workers} worker(s)"] = cn.design_map(
                P, grid, grid, executor=ex, **kw)
        runs[f"process pool, {workers} worker(s)"] = time.perf_counter() - t
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        LocalCluster = None
    if LocalCluster is not None and not quick:
        t = time.perf_counter()
        with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                          dashboard_address=None) as cluster, \
                Client(cluster) as client:
            results["Dask LocalCluster, 2 workers"] = cn.design_map(
                P, grid, grid, executor=client.get_executor(), **kw)
        runs["Dask LocalCluster, 2 workers"] = time.perf_counter() - t
    ref = results["sequential (this process)"]
    one = runs.get("process pool, 1 worker(s)",
                   runs["sequential (this process)"])
    rows = [[label, fmt_t(t), fmt_x(one / t),
             "yes" if _same(results[label], ref) else "**no**"]
            for label, t in runs.items()]
    sec.add(f"`design_map` of a random n = {n} plant (`random_plant({n}, 1, "
            f"seed=0)`), {side} × {side} grid of α1, α2 in [0, 0.4], η "
            f"maximised with decay 0.99, one passivesyn per cell; "
            f"{int(ref.feasible.sum())} of {ref.eta.size} cells certified. "
            f"Times include starting the pool or cluster. The machine has "
            f"{os.cpu_count()} cores.", "")
    sec.table(["executor", "time", "speed-up vs 1 worker process",
               "identical to sequential"], rows)
    sec.targets.append(Target(
        "design map: every executor gives the sequential map",
        all(_same(results[label], ref) for label in runs),
        ", ".join(label for label in runs), "cells are independent and "
        "seeded by their position"))
    if not quick:
        two = runs["process pool, 2 worker(s)"]
        sec.targets.append(Target(
            "design map: 2 worker processes faster than 1", two < one,
            fmt_x(one / two), "cells are independent; the ideal is 2× on 2 "
            "free cores"))
    sec.data["design_map"] = runs


def _searches(sec: Section, quick: bool) -> None:
    import control_ncs as cn
    P = schedule_plant()
    # period 6 without a shared channel has 7826 canonical schedules
    # (about half an hour of LMIs here): the shared channel keeps it at 700
    cases = ([(2, True, "predictor")] if quick else
             [(4, False, "static"), (4, True, "predictor"),
              (6, True, "predictor")])
    rows = []
    ctx = multiprocessing.get_context("spawn")
    with (ThreadPoolExecutor(1) if quick else
          ProcessPoolExecutor(2, mp_context=ctx)) as ex:
        for N, shared, controller in cases:
            t = time.perf_counter()
            res = cn.schedule_search(P, N, shared_channel=shared,
                                     controller=controller, decay=0.99,
                                     executor=ex, limit=None, progress=False)
            elapsed = time.perf_counter() - t
            best = res.ranking[0] if res.ranking else None
            rows.append([N, "yes" if shared else "no", controller, res.total,
                         res.explored, int(res.pruned.sum()),
                         ", ".join(f"{k} {v}" for k, v in
                                   res.pruned_counts.items()) or "–",
                         res.evaluated, int(res.feasible.sum()),
                         fmt_t(elapsed),
                         "–" if best is None else
                         f"{list(best.sensor_schedule)} / "
                         f"{list(best.actuator_schedule)}: η = {best.eta:.4g}"])
    sec.add("`schedule_search` of a two-state plant with two sensors and one "
            "actuator (α1 = 0.05, α2 = 0.1, decay 0.99, η maximised), on "
            + ("one thread" if quick else "a process pool of 2 workers")
            + ". *Total* counts index schedules "
            "before symmetry, *explored* the canonical ones (cyclic shifts; "
            "this plant has no relabelling symmetry), *pruned* those removed "
            "by the exact tests before any LMI.", "")
    sec.table(["N", "shared channel", "controller", "total", "explored",
               "pruned", "pruned by", "LMIs", "certified", "time",
               "best (sensors / actuators)"], rows)


def servo_plant(sensor_loss: float = 0.0, actuator_loss: float = 0.0):
    """A sampled DC-motor servo (dt = 0.05) whose three sensors send in two
    groups: the static gain is structured, so its LMI is only sufficient."""
    import control as ct
    from control_ncs import nss
    A = [[1.0, 0.039347, 0.001029], [0.0, 0.606513, 0.037288],
         [0.0, -0.000746, 0.904818]]
    B = [[0.10653, 0.000036], [3.934662, 0.002059], [-0.002059, 0.095162]]
    C = [[0, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    D = [[3.0, 0], [0, 0], [0, 0], [0, 0]]
    return nss(ct.ss(A, B, C, D, 0.05), nmeas=3, ncon=1,
               sensor_schedule=[[1, 0, 0], [0, 1, 1]],
               actuator_schedule=[1, 1], sensor_loss=sensor_loss,
               actuator_loss=actuator_loss)


def _map_methods(sec: Section, quick: bool) -> None:
    """The map's methods where the LMI is only sufficient."""
    import control_ncs as cn
    side = 1 if quick else 4
    a1 = np.linspace(0.0, 0.3, side)
    a2 = np.linspace(0.0, 0.15, side)
    rows, runs, maps = [], {}, {}
    for method in ("lmi", "auto") if quick else ("lmi", "auto", "refine"):
        t = time.perf_counter()
        dm = cn.design_map(servo_plant(), a1, a2, decay=0.995,
                           progress=False, method=method)
        runs[method] = time.perf_counter() - t
        maps[method] = dm
        reasons = sorted(set(map(str, dm.reason.ravel())))
        rows.append([method, fmt_t(runs[method]),
                     fmt_x(runs[method] / runs["lmi"]),
                     f"{int(dm.feasible.sum())} / {dm.eta.size}",
                     f"{np.nanmean(dm.eta):.4g}" if dm.feasible.any()
                     else "–", ", ".join(reasons)])
    sec.add(f"`design_map` of the servo of `tests/test_verdicts.py` (three "
            f"sensors in two groups: a structured static gain), {side} × "
            f"{side} grid of α1 in [0, 0.3], α2 in [0, 0.15], η maximised "
            f"with decay 0.995, sequential. `'lmi'`: the sufficient LMI only; "
            f"`'auto'` (default): the LMI, then every cell where it is only "
            f"sufficient refined from its own LMI gain or its nearest "
            f"certified neighbour's; `'refine'`: passivesyn's refinement "
            f"in every cell from scratch.", "")
    sec.table(["method", "time", "× the LMI's", "certified cells",
               "mean certified η", "reasons"], rows)
    sec.data["map_methods"] = runs
    sec.targets.append(Target(
        "the map's default ('auto') certifies every cell the LMI certifies",
        bool(np.all(maps["auto"].feasible >= maps["lmi"].feasible)),
        f"{int(maps['auto'].feasible.sum())} against "
        f"{int(maps['lmi'].feasible.sum())} of {maps['lmi'].eta.size}",
        "it refines where the LMI is only sufficient"))


def sweeps_section(quick: bool) -> Section:
    sec = Section("7. Sweeps: design maps and schedule search")
    _design_maps(sec, quick)
    _map_methods(sec, quick)
    _searches(sec, quick)
    return sec
