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
    rows, times = [], {}
    cases = [(4, 1), (8, 2)] if quick else [(4, 1), (4, 3), (8, 1), (8, 3),
                                            (8, 5)]
    for n, D in cases:
        P = delayed_plant(n, D)
        Kd = ct.dlqr(P.A, P.B2, np.eye(n), np.eye(2))[0]
        for controller in ("static", "predictor"):
            CL = feedback(P, -0.5 * Kd, controller=controller)
            t, _, rho = median_time(lambda CL=CL: ms_radius(CL), 3, 20.0)
            times[(n, D, controller)] = t
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
    if not quick:
        t = max(times[(8, 5, c)] for c in ("static", "predictor"))
        sec.targets.append(Target(
            "ms_radius over a delayed link, n = 8, buffer 5, under 1 s",
            t < 1.0, f"{fmt_t(t)} ({fmt_x(1.0 / t)} under the limit)",
            "synthesis over delayed links is not available, so the "
            "passivesyn target of the same size is not measured"))
    sec.data.update(times={f"{k}": v for k, v in times.items()})
    return sec
