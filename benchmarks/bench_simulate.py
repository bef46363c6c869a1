"""Benchmark 4: ``simulate`` trial-steps per second against per-trial loops.

The obvious alternative, "a loop of ``control.forced_response`` over
trials with the losses drawn the same way", does not exist as such:
``forced_response`` simulates one LTI system, while every trial of a lossy
loop is a *time-varying* system (its mode is drawn at every step). Calling
``forced_response`` once per step would measure call overhead, not a
simulation. Two honest baselines are measured instead:

* **numpy loop** — the straightforward simulation a user would write: per
  trial, draw the mode sequence (one uniform per step, the same probabilities
  as ``simulate``), then a Python loop over time with the drawn mode's
  matrices (``x = A_i x + B_i w``, ``z = C_i x + D_i w``). Same work as
  ``simulate``, one trial at a time.
* **forced_response loop** — per trial, ``control.forced_response`` of the
  *mean* system (an LTI system of the same size) over the same horizon.
  It ignores the losses, so it is a lower bound on the per-trial cost of any
  loop of ``forced_response`` calls: the cheapest thing such a loop could do.
"""

from __future__ import annotations

import time

import numpy as np

from .common import random_plant
from .report import Section, Target, fmt_t, fmt_x


def closed_loop(n: int, seed: int = 0):
    """A verified closed loop (N = 1, two modes) of ``random_plant(n)``,
    with a gain from ``passivesyn(..., options={'solver': 'riccati'})`` at
    η = 0.5."""
    from control_ncs import passivesyn
    K, CL, eta = passivesyn(random_plant(n, 1, seed), 0.5,
                            options={"solver": "riccati"})
    return CL


def numpy_loop(sys, T: int, trials: int, w: np.ndarray, x0: np.ndarray,
               seed: int = 0) -> np.ndarray:
    """Per-trial Python loop over time (the straightforward baseline)."""
    rng = np.random.default_rng(seed)
    A, B, C, D = (sys.modes.A[0], sys.modes.B[0], sys.modes.C[0],
                  sys.modes.D[0])
    cdf = np.cumsum(sys.modes.probabilities[0])
    out = np.empty((trials, C.shape[1], T))
    for j in range(trials):
        modes = np.searchsorted(cdf, rng.random(T), side="right")
        x = x0.copy()
        for t in range(T):
            i = modes[t]
            out[j, :, t] = C[i] @ x + D[i] @ w[:, t]
            x = A[i] @ x + B[i] @ w[:, t]
    return out


def forced_loop(sys, T: int, trials: int, w: np.ndarray, x0: np.ndarray):
    import control as ct
    mean = sys.mean()
    tt = np.arange(T)
    for _ in range(trials):
        r = ct.forced_response(mean, tt, w, x0)
    return r


def simulate_section(quick: bool) -> Section:
    from control_ncs.responses import simulate
    sec = Section("4. simulate: trial-steps per second")
    T = 200
    sizes = [4] if quick else [4, 32]
    reps = 1 if quick else 5
    rows, ratios = [], {}
    for n in sizes:
        sys = closed_loop(n)
        m = sys.modes.B.shape[-1]
        w = np.ones((m, T))
        x0 = np.ones(sys.modes.A.shape[-1])
        sim_trials = 2000 if quick else (20000 if n <= 8 else 5000)
        base = 20 if quick else 200
        # defaults bind this iteration's system (ruff B023)
        routes = {
            "simulate": (sim_trials, lambda k, sys=sys, w=w, x0=x0: simulate(
                sys, T, w, x0, trials=k, seed=1)),
            "numpy loop": (base, lambda k, sys=sys, w=w, x0=x0: numpy_loop(
                sys, T, k, w, x0)),
            "forced_response loop": (base, lambda k, sys=sys, w=w, x0=x0:
                                     forced_loop(sys, T, k, w, x0)),
        }
        times = {name: [] for name in routes}
        for _ in range(reps):         # interleaved: load changes hit all alike
            for name, (k, fn) in routes.items():
                t = time.perf_counter()
                fn(k)
                times[name].append(time.perf_counter() - t)
        speeds = {name: (routes[name][0] * T / float(np.median(ts)),
                         float(np.median(ts))) for name, ts in times.items()}
        for name, (sps, dt) in speeds.items():
            rows.append([n, name, routes[name][0], T, fmt_t(dt),
                         f"{sps:,.0f}",
                         fmt_x(speeds["simulate"][0] / sps)
                         if name != "simulate" else ""])
        ratios[n] = {k: speeds["simulate"][0] / v[0] for k, v in
                     speeds.items() if k != "simulate"}
        sec.data[n] = speeds
    sec.add(__doc__.split("\n\n", 1)[1].strip(), "")
    sec.add(f"Closed loop: `random_plant(n, 1)` with a verified gain "
            "(N = 1, two modes: loop closed with probability 0.855), "
            f"w = 1, x0 = 1, T = {T} steps; the three routes run in turn, "
            f"{5 if not quick else 1} rounds, median per route. "
            "Ratio: simulate's trial-steps/s over the baseline's.", "")
    sec.table(["n", "route", "trials", "T", "time", "trial-steps/s",
               "simulate ×"], rows)
    if True:        # a ratio of two routes in the same run
        sec.targets.append(Target(
            "simulate ≥ 50× the trial-steps/s of the forced_response loop",
            all(r["forced_response loop"] >= 50 for r in ratios.values()),
            "; ".join(f"n={n}: {fmt_x(r['forced_response loop'])} vs the "
                      f"forced_response loop, {fmt_x(r['numpy loop'])} vs "
                      "the numpy loop" for n, r in ratios.items())))
    sec.data["ratios"] = ratios
    return sec


def vectorised_loop(sys, T: int, trials: int, w: np.ndarray, x0: np.ndarray,
                    seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The loop over time a user would write, vectorised over trials: per
    step one uniform per trial picks its mode, every mode's products for
    all trials, the drawn one kept (phase 0 of an N = 1 loop). Returns
    the states and outputs, (T, trials, signal)."""
    rng = np.random.default_rng(seed)
    A, B, C, D = (sys.modes.A[0], sys.modes.B[0], sys.modes.C[0],
                  sys.modes.D[0])
    cdf = np.cumsum(sys.modes.probabilities[0])
    n, p = A.shape[-1], C.shape[1]
    states, outputs = np.empty((T, trials, n)), np.empty((T, trials, p))
    x = np.tile(x0, (trials, 1))
    for t in range(T):
        mode = np.searchsorted(cdf, rng.random(trials), side="right")
        states[t] = x
        z = outputs[t]
        z[...] = 0.0
        nxt = np.zeros_like(x)
        for i in range(A.shape[0]):
            sel = (mode == i)[:, None]
            nxt += sel * (x @ A[i].T + w[:, t] @ B[i].T)
            z += sel * (x @ C[i].T + w[:, t] @ D[i].T)
        x = nxt
    return states, outputs


def _traced(fn):
    """``fn()``'s result, time and peak of numpy's traced allocations."""
    import tracemalloc
    tracemalloc.start()
    try:
        t = time.perf_counter()
        out = fn()
        elapsed = time.perf_counter() - t
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return out, elapsed, peak


def simulate_scale_section(quick: bool) -> Section:
    from threadpoolctl import threadpool_limits

    from control_ncs.responses import simulate
    sec = Section("4b. simulate at scale: against a numpy loop vectorised "
                  "over trials, and its memory")
    n = 10
    trials, T = (10000, 100) if quick else (10000, 1000)
    rounds = 3
    sys = closed_loop(n)
    m = sys.modes.B.shape[-1]
    w, x0 = np.ones((m, T)), np.ones(n)
    routes = {
        "simulate (all signals)": lambda: simulate(sys, T, w, x0,
                                                   trials=trials, seed=1),
        "simulate, signals='outputs'": lambda: simulate(
            sys, T, w, x0, trials=trials, seed=1, signals="outputs"),
        "numpy loop over time, vectorised over trials": lambda:
            vectorised_loop(sys, T, trials, w, x0),
    }
    times: dict = {k: [] for k in routes}
    peaks: dict = {}
    sizes: dict = {}
    for _ in range(rounds):           # interleaved; the first is cold
        for name, fn in routes.items():
            with threadpool_limits(1):
                out, t, peak = _traced(fn)
            times[name].append(t)
            peaks[name] = max(peaks.get(name, 0), peak)
            arrays = out if isinstance(out, tuple) else [
                a for a in (out.x, out.y, out.u) if a.size]
            sizes[name] = sum(a.nbytes for a in arrays)
            del out, arrays
    import os
    warm = {k: float(np.median(v[1:])) for k, v in times.items()}
    loop = warm["numpy loop over time, vectorised over trials"]
    rows = []
    for name in routes:
        rows.append([name, fmt_t(times[name][0]), fmt_t(warm[name]),
                     fmt_x(loop / warm[name]), f"{sizes[name] / 2**20:.0f} MB",
                     f"{peaks[name] / 2**20:.0f} MB",
                     f"{peaks[name] / sizes[name]:.3f}"])
    sec.add(f"The closed loop of section 4 at n = {n} (N = 1, two modes), "
            f"{trials} trials × {T} steps, w = 1, x0 = 1. The numpy loop is "
            "`bench_simulate.vectorised_loop`: per step one uniform per "
            "trial, every mode's products for all trials and the drawn one "
            "kept; it stores states and outputs only (not the inputs "
            "simulate also returns). All routes on one BLAS thread (the "
            "loop's products of 10 000 rows would otherwise run on both "
            "cores, slower on this shared machine); simulate with its "
            "defaults (one worker thread). Rounds "
            f"interleaved, {rounds} of them: the first call of each route "
            "pays for fresh memory pages (on this virtual machine, seconds "
            "per GB), the later ones reuse freed memory; 'warm' is their "
            "median. Peak: numpy's largest traced allocation total during "
            "the call (tracemalloc), against the bytes of the arrays "
            f"returned. Load average at the end: "
            f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}.", "")
    sec.table(["route", "first call", "warm", "loop / route (warm)",
               "returned", "peak", "peak / returned"], rows)
    ratio = loop / warm["simulate (all signals)"]
    LOOP = "numpy loop over time, vectorised over trials"
    cold = times[LOOP][0] / times["simulate (all signals)"][0]
    sec.targets.append(Target(
        f"simulate ≥ 5× the numpy loop vectorised over trials "
        f"({trials} × {T}, n = {n})", ratio >= 5,
        f"{fmt_x(ratio)} warm, {fmt_x(cold)} first calls",
        "same loop and steps, back to back"))
    for name in ("simulate (all signals)", "simulate, signals='outputs'"):
        r = peaks[name] / sizes[name]
        sec.targets.append(Target(
            f"{name}: peak memory ≤ 1.2× the returned arrays", r <= 1.2,
            f"{r:.3f}× ({peaks[name] / 2**20:.0f} MB for "
            f"{sizes[name] / 2**20:.0f} MB)",
            "one slab per step holds the scratch rows of the modes' "
            "differences; signals= keeps only the rows asked for"))
    sec.data.update(times=times, peaks=peaks, sizes=sizes)
    return sec
