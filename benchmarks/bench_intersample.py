"""Benchmark: Jitterbug's continuous-time cost, exact against Monte Carlo.

``cost`` of a sampled loop with random sub-sample input delays, against the
Monte Carlo of the continuous plant it replaces (a sub-grid that holds every
delay, the exact noise per sub-step, the trapezoid rule).
"""

from __future__ import annotations

import math
import time
from functools import partial

import numpy as np
import scipy.linalg

from .report import Section, Target, fmt_t, fmt_x


def jittery_loop(n: int, grains: int, seed: int = 0, h: float = 0.1):
    """A seeded n-state continuous plant (one control, the state measured,
    noise where the input enters, ``z = [x; u]``), sampled at ``h`` with the
    input applied ``τ`` late, ``τ`` uniform on ``grains`` points of
    ``[0, h)``, closed with a cautious LQ gain. Returns ``(G, K, CL)``."""
    import control as ct
    from control_ncs import feedback, nss
    rng = np.random.default_rng([seed, n, grains, 36])
    A = rng.standard_normal((n, n)) / math.sqrt(n)
    A -= (np.abs(np.linalg.eigvals(A)).max() - 0.5) * np.eye(n)
    B = rng.standard_normal((n, 1))
    C1 = np.vstack([np.eye(n), np.zeros((1, n))])
    D12 = np.vstack([np.zeros((n, 1)), np.ones((1, 1))])
    G = ct.ss(A, np.hstack([B, B]), np.vstack([C1, np.eye(n)]),
              np.block([[np.zeros((n + 1, 1)), D12],
                        [np.zeros((n, 2))]]))
    Phi = scipy.linalg.expm(A * h)
    Gam = np.linalg.solve(A, (Phi - np.eye(n)) @ B)
    K = -ct.dlqr(Phi, Gam, np.eye(n), 10 * np.eye(1))[0]
    P = nss(G, nmeas=n, ncon=1, dt=h,
            input_delay=(np.arange(grains) * h / grains,
                         np.full(grains, 1.0 / grains)))
    return G, K, feedback(P, K)


def monte_carlo(G, K, h: float, grains: int, paths: int, periods: int,
                seed: int = 0) -> tuple[float, float]:
    """``J`` and its standard error from independent paths of the
    continuous plant: ``grains`` sub-steps per period, the switch at a
    random one, the noise of each sub-step drawn exactly."""
    A, B = np.asarray(G.A), np.asarray(G.B)
    n = A.shape[0]
    B1, B2 = B[:, :1], B[:, 1:]
    C1, D12 = np.asarray(G.C)[:n + 1], np.asarray(G.D)[:n + 1, 1:]
    delta = h / grains
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A, B2
    E = scipy.linalg.expm(M * delta)
    Ed, Gd = E[:n, :n], E[:n, n:]
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n], H[:n, n:], H[n:, n:] = -A, B1 @ B1.T, A.T
    F = scipy.linalg.expm(H * delta)
    vals, vecs = np.linalg.eigh(F[n:, n:].T @ F[:n, n:])
    R = vecs * np.sqrt(np.clip(vals, 0.0, None))      # R Rᵀ = Σ(δ)
    rng = np.random.default_rng(seed)
    x, u_prev = np.zeros((paths, n)), np.zeros((paths, 1))
    total = np.zeros(paths)
    burn = periods // 10
    for k in range(burn + periods):
        switch = rng.integers(0, grains, paths)
        u_now = x @ K.T
        acc = np.zeros(paths)
        for j in range(grains):
            u = np.where((j < switch)[:, None], u_prev, u_now)
            z0 = x @ C1.T + u @ D12.T
            x = x @ Ed.T + u @ Gd.T + rng.standard_normal((paths, n)) @ R.T
            z1 = x @ C1.T + u @ D12.T
            acc += 0.5 * delta * ((z0 ** 2).sum(1) + (z1 ** 2).sum(1))
        u_prev = u_now
        if k >= burn:
            total += acc
    J = total / (periods * h)
    return float(J.mean()), float(J.std(ddof=1) / math.sqrt(paths))


def _cpu_median(fn, repeats: int):
    """Median CPU time of ``fn()`` (the machine is shared: its wall time
    also counts the other sessions) and the last result."""
    times, out = [], None
    for _ in range(repeats):
        start = time.process_time()
        out = fn()
        times.append(time.process_time() - start)
    return float(np.median(times)), out


def intersample_section(quick: bool) -> Section:
    from control_ncs import cost
    sec = Section("The cost between the samples: exact against Monte Carlo")
    h = 0.1
    cases = [(4, 10, 100, 100)] if quick else [(4, 10, 400, 400),
                                               (10, 50, 400, 400)]
    rows = []
    for n, grains, paths, periods in cases:
        G, K, CL = jittery_loop(n, grains, h=h)
        t_exact, res = _cpu_median(lambda CL=CL: cost(CL), 3)
        t_mc, (mc, se) = _cpu_median(partial(
            monte_carlo, G, K, h, grains, paths, periods), 1)
        # the standard error the Monte Carlo would have in cost's time
        se_then = se * math.sqrt(t_mc / t_exact)
        rows.append([n, grains, CL.modes.A.shape[-1], f"{res.cost:.5g}",
                     fmt_t(t_exact), f"{mc:.5g} ± {se:.2g}",
                     f"{(mc - res.cost) / se:+.2f}", fmt_t(t_mc),
                     fmt_x(t_mc / t_exact),
                     f"{100 * se_then / res.cost:.3g} %"])
        sec.data[f"n={n}, grains={grains}"] = dict(
            exact=res.cost, t_exact=t_exact, mc=mc, se=se, t_mc=t_mc)
    sec.add("`cost` of a sampled loop (n states, one control, the state "
            "measured, noise where the input enters, z = [x; u], h = 0.1) "
            "whose input is applied τ late, τ uniform on `grains` points of "
            "[0, h): exact, median CPU time of 3 runs. Against it, the Monte "
            "Carlo it replaces: `paths` independent paths of `periods` "
            "periods (plus a tenth for burn-in) on a sub-grid of `grains` "
            "steps per period, exact noise per sub-step, trapezoid rule "
            "(CPU time of one run). "
            "The last column is the Monte Carlo's relative standard error "
            "had it run only as long as `cost` (it falls as the square root "
            "of the time).", "")
    sec.table(["n", "grains", "loop state", "J (exact)", "time",
               "J (Monte Carlo)", "(MC − J)/se", "MC time",
               "MC time / exact", "MC error in exact's time"], rows)
    dev = [abs(d["mc"] - d["exact"]) / d["se"] for d in sec.data.values()]
    sec.targets.append(Target(
        "the Monte Carlo cost within 4 standard errors of the exact cost",
        max(dev) <= 4, f"largest deviation {max(dev):.2f} standard errors",
        "an independent simulation of the same loop"))
    name = ("`cost` at n = 10 with 50 delay grains at least 10x faster than "
            "the Monte Carlo of 400 paths x 400 periods")
    why = ("the exact figure should be the cheap one: the Monte Carlo's "
           "1 % standard error is what a user would otherwise pay for")
    big = sec.data.get("n=10, grains=50")
    if big is None:
        sec.full_run_only(name, why)
    else:
        ratio = big["t_mc"] / big["t_exact"]
        sec.targets.append(Target(name, ratio >= 10, f"{ratio:.0f}x", why))
    return sec
