"""Benchmark: H2 and H∞ design of structured gains (the local searches).

Where no convex program is exact (a sensor schedule, a delayed link, a held
command) ``h2syn`` and ``hinfsyn`` search the gain locally. Measured here:
what one exact gradient costs against central differences of the same
exact figure (the alternative a search without the adjoint would use), and
what a whole design costs as the loop grows.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .common import median_time
from .report import Section, Target, fmt_t, fmt_x


def _scheduled_plant(n: int, seed: int = 0):
    """A seeded n-state plant, two inputs, the state measured by n sensors
    taking turns in pairs (period n/2), actuator loss 0.2, ``z = [x; u]``."""
    from control_ncs import nss
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 1.05 / max(abs(np.linalg.eigvals(A)))
    B2 = rng.standard_normal((n, 2))
    B = np.hstack([np.eye(n), B2])
    C = np.vstack([np.eye(n), np.zeros((2, n)), np.eye(n)])
    D = np.zeros((2 * n + 2, n + 2))
    D[n:n + 2, n:] = np.eye(2)
    period = max(1, n // 2)
    schedule = np.zeros((period, n), int)
    for k in range(period):
        schedule[k, 2 * k:2 * k + 2] = 1
    return nss(A, B, C, D, True, nmeas=n, ncon=2, actuator_loss=0.2,
               sensor_schedule=schedule)


def _gradient_costs(P, K, rows: list, l2: bool = True) -> None:
    """One exact gradient (adjoint) against central differences of the
    exact figure, near the gain ``K`` (h2syn's design, each entry moved by
    5 % of the largest, seeded: at the optimum itself the gradient
    vanishes and a relative gap means nothing)."""
    from control_ncs.synthesis._h2 import H2Objective
    from control_ncs.synthesis._hinf import GainObjective
    from control_ncs.synthesis.norms import _plant_problem
    mats, loop, _, _, _, _ = _plant_problem(P, "static", "zero", None)
    x = np.asarray(K.gains).reshape(loop.mask.shape).flat[loop.free].copy()
    x = x + 0.05 * np.abs(x).max() * np.random.default_rng(1).standard_normal(
        x.size)
    objectives = [("H2", H2Objective(loop, *mats))]
    if l2 and x.size <= 16:  # the l2 gain's differences: 2 LMIs per entry
        objectives.append(("l2 gain", GainObjective(loop, *mats)))
    for name, objective in objectives:
        t_adj, _, (f, g) = median_time(
            lambda objective=objective: objective.value(x), repeats=3,
            budget=20.0)
        if not math.isfinite(f):
            continue
        h = 1e-6 if name == "H2" else 1e-4
        start = time.perf_counter()
        central = np.array([(objective.value(x + h * e)[0]
                             - objective.value(x - h * e)[0]) / (2 * h)
                            for e in np.eye(x.size)])
        t_fd = time.perf_counter() - start
        gap = float(np.max(np.abs(central - g)) / np.max(np.abs(g)))
        rows.append([P.nstates, loop.free.size, name, fmt_t(t_adj),
                     fmt_t(t_fd), fmt_x(t_fd / t_adj), f"{gap:.1e}"])


def structured_design_section(quick: bool) -> Section:
    from control_ncs import h2syn, hinfsyn
    sec = Section("H2 and H∞ design of structured gains")
    sizes = [4] if quick else [4, 8, 16]
    rows: list = []
    design_rows = []
    for n in sizes:
        P = _scheduled_plant(n)
        # --quick: the H2 design and gradient only (hinfsyn solves the
        # bounded real lemma at every step of its search)
        for name, design in (("h2syn", h2syn),) + (
                () if quick else (("hinfsyn", hinfsyn),)):
            start = time.perf_counter()
            K, CL, value = design(P, time_limit=120.0)
            design_rows.append([n, name, K.result.route,
                                fmt_t(time.perf_counter() - start),
                                f"{value:.4f}"])
            if name == "h2syn":
                _gradient_costs(P, K, rows, l2=not quick)
    sec.add("A seeded n-state plant whose n sensors take turns in pairs "
            "(period n/2), two inputs, actuator loss 0.2, `z = [x; u]`: the "
            "static gain sees two coordinates per step, so the H2 and H∞ "
            "programs are not exact and the gain is searched locally. One "
            "gradient of the search's objective by its adjoint (H2: one "
            "adjoint fixed point; ℓ2 gain: the bounded real lemma's duals) "
            "against central differences of the same exact figure, near "
            "h2syn's design (each entry moved by 5 % of the largest; median "
            "of up to 3 runs; differences once; the ℓ2 gain's differences "
            "only up to 16 entries, two LMIs each).", "")
    sec.table(["n", "free entries", "objective", "adjoint gradient",
               "central differences", "ratio", "relative gap"], rows)
    sec.add("Whole designs of the same plants, one run each (`time_limit` "
            "120 s): the figure is the exact H2 norm or the certified ℓ2 "
            "bound of the returned loop.", "")
    sec.table(["n", "design", "route", "time", "figure"], design_rows)
    gaps = [float(r[-1]) for r in rows if r[-1] not in ("", "–")]
    sec.targets.append(Target(
        "the adjoint gradient agrees with central differences to 1e-4 "
        "(relative)", bool(gaps) and max(gaps) <= 1e-4,
        f"largest gap {max(gaps, default=float('nan')):.1e}",
        "the same exact figure differentiated two ways"))
    return sec
