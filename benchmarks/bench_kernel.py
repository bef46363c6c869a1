"""The second-moment kernel against the matrix-product floor, and on one
BLAS thread against the default threads.

The floor of a call is the matrix products its operator applications need,
timed as plain ``@`` on the same shapes in the same run (one BLAS thread,
as the kernel runs): ``ms_radius`` and the H2 norm apply the period's map
``Σ_i p_i A_i Q A_iᵀ`` by two ``n × n`` products per live mode and phase,
counted by wrapping the one function that forms them
(``stability._sandwich``); ``moments`` needs ``A_i Q A_iᵀ`` and
``C_i Q C_iᵀ`` per mode and step. Everything else a call does (the Stein
preconditioner, ARPACK's and GMRES's vector work, the extended-precision
residuals that certify the bracket, Python) is above the floor, and the
profile says where.
"""

from __future__ import annotations

import os
import statistics
import time
from collections import Counter, defaultdict
from contextlib import contextmanager
from typing import Any, Callable

import numpy as np

from .bench_stability import random_loop
from .report import Section, Target, fmt_t, fmt_x

#: The issue's goal: each call within this factor of its floor.
FLOOR_GOAL = 1.3


def _product_time(n: int, count: int, rounds: int = 5) -> float:
    """Least time of one ``n × n`` product, from ``count`` sandwiches
    ``A Q Aᵀ`` (2·count products) per round, one BLAS thread."""
    from control_ncs._blas import serial_blas
    rng = np.random.default_rng(n)
    A = rng.standard_normal((count, n, n))
    Q = np.eye(n)
    times = []
    with serial_blas(10**9):
        for _ in range(rounds):
            t = time.perf_counter()
            for a in A:
                a @ Q @ a.T
            times.append((time.perf_counter() - t) / (2 * count))
    return min(times)


@contextmanager
def _counting():
    """Count the ``n × n`` products of the map (``_sandwich`` calls)."""
    from control_ncs import stability
    original = stability._sandwich
    count = Counter()

    def counted(A, Q):
        count[A.dtype.name] += 2 * len(A)
        return original(A, Q)
    stability._sandwich = counted
    try:
        yield count
    finally:
        stability._sandwich = original


@contextmanager
def _profiled():
    """Time by part of a certified radius call (wrappers, restored)."""
    from control_ncs import _stein, stability
    spent: dict = defaultdict(float)
    calls: Counter = Counter()
    patches = []

    def wrap(owner, name, key):
        original = getattr(owner, name)

        def timed(*args, **kwargs):
            t = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                spent[key] += time.perf_counter() - t
                calls[key] += 1
        setattr(owner, name, timed)
        patches.append((owner, name, original))

    tm = stability._TupleMap
    original_residual = tm.residual

    def residual(self, X, mu, wide=False):
        key = "residual, extended" if wide and self.dtype != np.float64 \
            else "residual, double"
        t = time.perf_counter()
        try:
            return original_residual(self, X, mu, wide)
        finally:
            spent[key] += time.perf_counter() - t
            calls[key] += 1
    tm.residual = residual
    patches.append((tm, "residual", original_residual))
    wrap(tm, "__call__", "map applications (double)")
    wrap(tm, "__init__", "set-up (rounding tails)")
    wrap(_stein.Stein, "__call__", "Stein solves")
    wrap(stability, "eigs", "ARPACK (with its applications)")
    wrap(stability, "gmres", "GMRES (with its applications, Stein)")
    try:
        yield spent, calls
    finally:
        for owner, name, original in patches:
            setattr(owner, name, original)


def _least(fn: Callable[[], Any], rounds: int) -> float:
    """The least time of ``rounds`` calls: on a shared machine the run
    least disturbed by other work (the floor is timed the same way)."""
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def _calls(sys, T: int) -> dict:
    from control_ncs import moments, ms_radius, norm
    x0 = np.ones(sys.modes.A.shape[-1])
    return {
        "ms_radius (certified)": lambda: ms_radius(sys, method="matrix-free",
                                                   bracket=True),
        "H2 norm (GMRES)": lambda: norm(sys, 2, method="matrix-free"),
        f"moments, {T} steps": lambda: moments(sys, T, initial_state=x0),
    }


def _moments_floor(sys, T: int, rounds: int = 3) -> float:
    """``T`` steps of ``A_i Q A_iᵀ`` and ``C_i Q C_iᵀ`` per mode, plain
    ``@``, one BLAS thread."""
    from control_ncs._blas import serial_blas
    A, C = sys.modes.A, sys.modes.C
    n = A.shape[-1]
    Q = np.eye(n)
    times = []
    with serial_blas(10**9):
        for _ in range(rounds):
            t = time.perf_counter()
            for j in range(T):
                k = j % sys.period
                for i in range(A.shape[1]):
                    A[k, i] @ Q @ A[k, i].T
                    C[k, i] @ Q @ C[k, i].T
            times.append(time.perf_counter() - t)
    return min(times)


def kernel_floor_section(quick: bool) -> Section:
    sec = Section("11. The second-moment kernel against the matrix-product "
                  "floor")
    N = 4 if quick else 10
    sizes = [60] if quick else [60, 200]
    rounds = 2 if quick else 5
    T = 50 if quick else 200
    rows, profile_rows, ratios = [], [], {}
    for n in sizes:
        sys = random_loop(n, N)
        t_prod = _product_time(n, 2 * N)
        for name, fn in _calls(sys, T).items():
            fn()                                     # warm: imports, caches
            t = _least(fn, rounds)
            if name.startswith("moments"):
                floor = _moments_floor(sys, T)
                counted = "–"
            else:
                with _counting() as count:
                    fn()
                products = sum(count.values())
                floor = products * t_prod
                wide = count.get("longdouble", 0)
                counted = f"{products}" + (f" ({wide} extended)" if wide
                                           else "")
            ratios[(name, n)] = t / floor
            rows.append([name, n, N, fmt_t(t), counted, fmt_t(floor),
                         fmt_x(t / floor)])
        with _profiled() as (spent, calls):
            t0 = time.perf_counter()
            _calls(sys, T)["ms_radius (certified)"]()
            total = time.perf_counter() - t0
        for key in sorted(spent, key=spent.get, reverse=True):
            profile_rows.append([n, key, calls[key], fmt_t(spent[key]),
                                 f"{100 * spent[key] / total:.0f} %"])
        profile_rows.append([n, "whole call", 1, fmt_t(total), "100 %"])
    sec.add(__doc__.split("\n\n", 1)[1].strip(), "",
            f"Loops: `bench_stability.random_loop(n, {N})` (two modes per "
            f"phase). Least time of {rounds} run(s) after a warm-up call; "
            "the floor's product time is the least of 5 rounds of "
            f"{2 * N} sandwiches, the moments' floor the least of 3 (on a "
            "shared machine the least disturbed runs; medians moved by "
            "tens of percent between runs).", "")
    sec.table(["call", "n", "N", "time", "n×n products", "floor",
               "time / floor"], rows)
    sec.add("Where the certified radius spends its time (one call, "
            "instrumented; the GMRES row includes its map applications and "
            "Stein solves, the ARPACK row its map applications):", "")
    sec.table(["n", "part", "calls", "time", "share"], profile_rows)
    for n in sizes:
        worst = max(ratios[(name, n)] for name in _calls(random_loop(2, 1),
                                                          T))
        sec.targets.append(Target(
            f"second-moment kernel (ms_radius, H2, moments) within "
            f"{FLOOR_GOAL}× the matrix-product floor, n = {n}",
            worst <= FLOOR_GOAL,
            ", ".join(f"{name.split(' ')[0]} {fmt_x(ratios[(name, n)])}"
                      for name in _calls(random_loop(2, 1), T)),
            "a ratio of two times in the same run" if worst <= FLOOR_GOAL
            else "see the profile: what is above the floor"))
    sec.data.update(ratios={f"{k[0]}, n={k[1]}": v for k, v in
                            ratios.items()})
    return sec


@contextmanager
def _threads_allowed():
    """The kernels on the BLAS's default threads (the limit switched off)."""
    from control_ncs import _blas
    saved = _blas.SERIAL_MIN_STATES
    _blas.SERIAL_MIN_STATES = 10**9
    try:
        yield
    finally:
        _blas.SERIAL_MIN_STATES = saved


def threads_section(quick: bool) -> Section:
    from control_ncs import moments, ms_radius, norm
    from control_ncs._blas import SERIAL_MIN_STATES
    sec = Section("12. The kernels on one BLAS thread against the default "
                  "threads")
    N = 4 if quick else 10
    n = 64 if quick else 200
    rounds = 3 if quick else 2
    sys = random_loop(n, N)
    x0 = np.ones(n)
    calls = {
        "ms_radius": lambda: ms_radius(sys, method="matrix-free"),
        "H2 norm": lambda: norm(sys, 2, method="matrix-free"),
        "moments, 100 steps": lambda: moments(sys, 100, initial_state=x0),
    }
    load0 = os.getloadavg()
    times: dict = defaultdict(list)
    for _ in range(rounds):       # interleaved: the load hits both alike
        for name, fn in calls.items():
            t = time.perf_counter()
            fn()
            times[(name, "one")].append(time.perf_counter() - t)
            with _threads_allowed():
                t = time.perf_counter()
                fn()
                times[(name, "default")].append(time.perf_counter() - t)
    load1 = os.getloadavg()
    rows, worst = [], 0.0
    for name in calls:
        one = statistics.median(times[(name, "one")])
        many = statistics.median(times[(name, "default")])
        worst = max(worst, one / many)
        rows.append([name, n, N, fmt_t(one), fmt_t(many), fmt_x(many / one)])
    sec.add("The same calls back to back: as the package runs them (one "
            f"BLAS thread from n = {SERIAL_MIN_STATES}, `control_ncs._blas`)"
            " and with the limit switched off (OpenBLAS's default: one "
            f"thread per core, {os.cpu_count()} here). Load average (1, 5, "
            f"15 min) at start {' '.join(f'{v:.2f}' for v in load0)}, at end "
            f"{' '.join(f'{v:.2f}' for v in load1)}; median of {rounds} "
            "interleaved round(s).", "")
    sec.table(["call", "n", "N", "one thread", "default threads",
               "default / one"], rows)
    sec.targets.append(Target(
        f"kernels on one BLAS thread never slower than on the default "
        f"threads (n = {n}, N = {N})",
        worst <= 1.1,
        "; ".join(f"{r[0]}: default threads {r[5]} the one-thread time"
                  for r in rows),
        "one thread by construction; 10 % allowed for noise between two "
        "runs of the same call"))
    sec.data.update(times={f"{k[0]}, {k[1]}": v for k, v in times.items()},
                    load=(load0, load1))
    return sec
