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


def _profile_line(call, top: int = 5) -> str:
    """Where one call's time goes: the package's functions with the largest
    cumulative time under cProfile (the call itself excluded)."""
    import cProfile
    import pstats
    prof = cProfile.Profile()
    prof.enable()
    call()
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    total = max((v[3] for v in stats.values()), default=0.0)
    rows = sorted(((v[3], f"{k[2]} ({k[0].rsplit('/', 1)[-1]})")
                   for k, v in stats.items() if "control_ncs" in k[0]),
                  reverse=True)[1:top + 1]
    return ", ".join(f"{name} {fmt_t(t)} ({100 * t / total:.0f} %)"
                     for t, name in rows)


def _start_costs(P) -> list:
    """The full-information start of the local searches two ways: the
    periodic Riccati recursion (now) against the exact H2 program (one
    SDP, before), and how far apart their gains are."""
    from dataclasses import replace
    from control_ncs.lmi import DEFAULT_MARGIN, h2_model, solve
    from control_ncs.strategies import build
    from control_ncs.synthesis.norms import _riccati_h2_gain
    plant = build(P, "static", "zero")
    start = time.perf_counter()
    G = _riccati_h2_gain(plant)
    t_ric = time.perf_counter() - start
    nx = plant.shape["nx"]
    full = replace(plant, E=np.broadcast_to(np.eye(nx), (plant.period, nx,
                                                         nx)),
                   Ew=None, Gw=None)
    start = time.perf_counter()
    model = h2_model(full, DEFAULT_MARGIN)
    solve(model.problem)
    Gs = model.gains()
    t_sdp = time.perf_counter() - start
    gap = float(np.abs(G - Gs).max() / np.abs(Gs).max()) if G is not None \
        else math.nan
    return [P.nstates, fmt_t(t_ric), fmt_t(t_sdp), fmt_x(t_sdp / t_ric),
            f"{gap:.1e}"]


def structured_design_section(quick: bool) -> Section:
    import os
    from control_ncs import feedback, h2syn, hinfsyn, l2_gain
    sec = Section("H2 and H∞ design of structured gains")
    load0 = os.getloadavg()
    sizes = [4] if quick else [4, 8, 16]
    rows: list = []
    design_rows = []
    start_rows = []
    times: dict = {}
    for n in sizes:
        P = _scheduled_plant(n)
        start_rows.append(_start_costs(P))
        # --quick: the H2 design and gradient only (hinfsyn solves the
        # bounded real lemma at every step of its search)
        limits = [("h2syn", h2syn, None)]
        if not quick:
            limits += [("hinfsyn", hinfsyn, None), ("hinfsyn", hinfsyn, 20.0)]
        for name, design, limit in limits:
            options = None if limit is None else dict(time_limit=limit)
            start = time.perf_counter()
            K, CL, value = design(P, options=options)
            t = time.perf_counter() - start
            times[(n, name, limit)] = t
            cert = "–"
            if name == "hinfsyn":
                c0 = time.perf_counter()
                again = l2_gain(feedback(P, K))
                cert = f"{fmt_t(time.perf_counter() - c0)} (γ {again.gamma:.4f})"
            design_rows.append([n, name, "default (60 s)" if limit is None
                                else f"{limit:g} s", K.result.route,
                                fmt_t(t), f"{value:.4f}", cert])
            if name == "h2syn" and limit is None:
                _gradient_costs(P, K, rows, l2=not quick)
    P = _scheduled_plant(sizes[-1])
    profile = _profile_line(lambda: h2syn(P))
    load1 = os.getloadavg()
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
    sec.add("The searches' full-information start (the H2-optimal gain on "
            "the whole state, then projected on what the gain reads): the "
            "periodic Riccati recursion of LQ with multiplicative noise "
            "against the exact H2 program (one SDP, Clarabel), which gave "
            "the start before; the gap is the largest entry of their "
            "difference relative to the largest gain (the SDP's accuracy).",
            "")
    sec.table(["n", "Riccati recursion", "H2 program (SDP)", "ratio",
               "relative gap"], start_rows)
    sec.add("Whole designs of the same plants, one run each, default "
            "arguments (`time_limit` 60 s: it covers hinfsyn's certificates "
            "too) and hinfsyn with `options={'time_limit': 20}`: the figure is the exact "
            "H2 norm or the certified ℓ2 bound of the returned loop; the "
            "last column re-certifies hinfsyn's loop with `l2_gain` (the "
            "certificate the design includes, timed alone). Load average "
            f"(1, 5, 15 min) {' '.join(f'{v:.2f}' for v in load0)} at the "
            f"start, {' '.join(f'{v:.2f}' for v in load1)} at the end "
            "(2 cores shared with other work).", "")
    sec.table(["n", "design", "time_limit", "route", "time", "figure",
               "l2_gain of the loop"], design_rows)
    sec.add(f"Where h2syn's time goes at n = {sizes[-1]} (cProfile, "
            f"cumulative): {profile}.", "")
    gaps = [float(r[-1]) for r in rows if r[-1] not in ("", "–")]
    sec.targets.append(Target(
        "the adjoint gradient agrees with central differences to 1e-4 "
        "(relative)", bool(gaps) and max(gaps) <= 1e-4,
        f"largest gap {max(gaps, default=float('nan')):.1e}",
        "the same exact figure differentiated two ways"))
    if quick:
        sec.full_run_only("structured h2syn, n = 16, under 10 s",
                          "n = 16 only in the full run")
        sec.full_run_only("structured hinfsyn, n = 16, under 20 s with its "
                          "certificate", "n = 16 only in the full run")
    else:
        t = times[(16, "h2syn", None)]
        sec.targets.append(Target(
            "structured h2syn, n = 16, under 10 s", t < 10.0, fmt_t(t),
            "the full-information start by Riccati, one LU for both fixed "
            "points, one BLAS thread"))
        t = times[(16, "hinfsyn", None)]
        sec.targets.append(Target(
            "structured hinfsyn, n = 16, under 20 s with its certificate",
            t < 20.0, f"{fmt_t(t)} with the default time_limit (60 s); "
            f"{fmt_t(times[(16, 'hinfsyn', 20.0)])} with time_limit=20",
            "every step of the l2 stage solves the bounded real lemma's "
            "LMI"))
    sec.data.update(times={f"{k}": v for k, v in times.items()})
    return sec
