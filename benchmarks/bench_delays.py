"""Benchmark: analysis over delayed links as the buffer grows."""

from __future__ import annotations

import numpy as np

from .common import median_time
from .report import Section, Target, fmt_t, fmt_x


def delayed_plant(n: int, buffer: int, seed: int = 0):
    """A seeded n-state plant (2 controls, the state measured) whose sensor
    link delays packets uniformly over 0..buffer (loss 0.05)."""
    from control_ncs import nss, random_delay
    rng = np.random.default_rng([seed, n, buffer, 26])
    A = rng.standard_normal((n, n))
    A *= 1.05 / np.abs(np.linalg.eigvals(A)).max()
    B2 = rng.standard_normal((n, 2))
    B = np.hstack([np.eye(n)[:, :1], B2])
    C = np.vstack([np.eye(n)[:1], np.eye(n)])
    D = np.zeros((n + 1, 3))
    pmf = np.full(buffer + 1, 0.95 / (buffer + 1))
    return nss(A, B, C, D, True, nmeas=n, ncon=2,
               sensor_delay=random_delay(pmf, buffer=buffer))


def delays_section(quick: bool) -> Section:
    import control as ct
    from control_ncs import feedback, ms_radius
    sec = Section("Delayed links: analysis cost as the buffer grows")
    rows, times, widths = [], {}, {}
    cases = [(4, 1)] if quick else [(4, 1), (4, 3), (8, 1), (8, 3), (8, 5)]
    for n, D in cases:
        P = delayed_plant(n, D)
        Kd = ct.dlqr(P.A, P.B2, np.eye(n), np.eye(2))[0]
        for controller in ("static", "predictor"):
            CL = feedback(P, -0.5 * Kd, controller=controller)
            t, _, rho = median_time(lambda CL=CL: ms_radius(CL),
                                    1 if quick else 3, 20.0)
            times[(n, D, controller)] = t
            widths[(n, D, controller)] = ms_radius(CL, bracket=True).width
            size = CL.modes.A.shape[-1]
            rows.append([n, D, controller, size, CL.nmodes,
                         CL.nmodes * size ** 2, fmt_t(t), f"{rho:.6f}"])
    sec.add("`ms_radius` of the loop closed over a sensor link with delays "
            "uniform on 0..D (loss 0.05), gain -0.5·dlqr. The loop state is "
            "(D+1)n (+ D·m for the predictor's input history), the modes "
            "are the D + 2 ages; the second-moment operator acts on "
            "modes × state² unknowns (dense up to 576, matrix-free above). "
            "Median of up to 3 runs.", "")
    sec.table(["n", "D", "controller", "loop state", "modes", "unknowns",
               "ms_radius time", "ms_radius"], rows)
    widest = max(widths.values())
    sec.targets.append(Target(
        "ms_radius over delayed links certified to 1e-10 (relative width)",
        widest <= 1e-10, f"widest bracket {widest:.1e}",
        "Markov modes: the ages of the buffer"))
    if quick:
        sec.full_run_only("ms_radius over a delayed link, n = 8, buffer 5, "
                          "under 1 s", "n = 8 only in the full run")
    if not quick:
        t = max(times[(8, 5, c)] for c in ("static", "predictor"))
        sec.targets.append(Target(
            "ms_radius over a delayed link, n = 8, buffer 5, under 1 s",
            t < 1.0, f"{fmt_t(t)} ({fmt_x(1.0 / t)} under the limit)",
            "passive design over delayed links: the next section"))
    sec.data.update(times={f"{k}": v for k, v in times.items()})
    return sec


def passive_delayed_plant(n: int, buffer: int, seed: int = 0):
    """:func:`delayed_plant` with ``z = x1 + w`` (``D11 = 1``), so that
    the loop can be passive."""
    from control_ncs import nss
    P = delayed_plant(n, buffer, seed)
    D = np.array(P.D)
    D[0, 0] = 1.0
    return nss(P.A, P.B, P.C, D, True, nmeas=n, ncon=2,
               sensor_delay=P.sensor_delay)


def delayed_design_section(quick: bool) -> Section:
    import control as ct
    import time
    from control_ncs import (SynthesisError, feedback, ms_radius,
                             passivesyn, passivity_certificate)
    sec = Section("Passive design over delayed links")
    rows, rates = [], []
    cases = [(2, 1)] if quick else [(2, 1), (4, 1), (4, 2)]
    # --quick: the static gain with a one-second search (a smoke test)
    limit = dict(time_limit=1.0) if quick else {}
    for n, D in cases:
        P = passive_delayed_plant(n, D)
        for controller in ("static",) if quick else ("static", "predictor"):
            start = time.perf_counter()
            try:
                K, CL, eta = passivesyn(P, controller=controller, decay=0.99,
                                        options=limit)
                got = f"{eta:.4f}"
                rates.append(ms_radius(CL))
                rate = f"{rates[-1]:.4f}"
                size = CL.modes.A.shape[-1]
            except SynthesisError as err:
                got, rate, size = err.reason, "–", "–"
            rows.append([n, D, controller, size,
                         fmt_t(time.perf_counter() - start), got, rate])
    sec.add("`passivesyn(P, controller=..., decay=0.99)` over a sensor link "
            "with delays uniform on 0..D (loss 0.05), `z = x1 + w`: the "
            "local search of the gain (one per age, or the predictor's) on "
            "exact figures: quasi-Newton on the exact rate's Perron "
            "gradient until the loop is mean-square stable, then "
            "Nelder–Mead on the certified level, each step one passivity "
            "certificate of the delayed loop (default `time_limit`, 120 s). "
            "One run each.", "")
    sec.table(["n", "D", "controller", "loop state", "passivesyn time",
               "certified η", "ms_radius"], rows)
    sec.targets.append(Target(
        "every delayed design returned is mean-square stable with decay "
        "0.99 (ms_radius < 0.99²)", bool(rates) and max(rates) < 0.99 ** 2,
        f"{len(rates)} designs, largest ms_radius "
        f"{max(rates, default=float('nan')):.4f}",
        "the certified decay, re-checked by ms_radius"))
    if quick:
        sec.full_run_only("passivesyn over a delayed link, n = 8, buffer 5, "
                          "under a minute", "n = 8 only in the full run")
    if not quick:
        n, D = 8, 5
        P = passive_delayed_plant(n, D)
        Kd = ct.dlqr(P.A, P.B2, np.eye(n), np.eye(2))[0]
        CL = feedback(P, -0.5 * Kd, controller="predictor")
        routes = {}
        for method in ("riccati", "lmi"):
            start = time.perf_counter()
            res = passivity_certificate(CL, None, method=method)
            routes[method] = (time.perf_counter() - start, res.eta)
        sec.add(f"One passivity certificate (η maximised) of the n = 8, "
                f"buffer 5 predictor loop (state {CL.modes.A.shape[-1]}, "
                f"{CL.nmodes} Markov modes, gain -0.5·dlqr): the coupled "
                f"Riccati iteration (the default above 8 states) against the "
                f"LMI solved by Clarabel, one run each.", "")
        sec.table(["route", "time", "certified η"],
                  [[m, fmt_t(t), f"{e:.6f}"] for m, (t, e) in routes.items()])
        sec.add(f"Ratio LMI / Riccati: "
                f"{fmt_x(routes['lmi'][0] / routes['riccati'][0])}.", "")
        start = time.perf_counter()
        try:
            K, CL, eta = passivesyn(P, controller="predictor", decay=0.99,
                                    options={"time_limit": 45})
            got = f"certified η = {eta:.4f}"
        except SynthesisError as err:
            got = f"no design ({err.reason})"
        t = time.perf_counter() - start
        sec.targets.append(Target(
            "passivesyn over a delayed link, n = 8, buffer 5, under a minute",
            t < 60.0, f"{fmt_t(t)} with time_limit=45 s: {got}",
            "each step of the local search costs one certificate of the "
            "58-state loop; within the limit the search stops early"))
    return sec
