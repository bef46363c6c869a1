"""Benchmark: worst-case analysis and design over a weakly-hard loss budget.

A seeded n-state plant whose commands may be lost at most twice in any five
steps (the weakly-hard (2, 5) automaton, 11 nodes, built here from its
definition). Measured: the design of gains per node of the memory-M lift
(M = 1, 2) for the worst-case ℓ2 gain, each re-certified on its fixed loop;
the analysis of one designed loop with storages per lifted node at memories
0, 1 and 2, beside the plain program with one common quadratic storage for
every edge (cvxpy, Clarabel, the same loop), in the same run.
"""

from __future__ import annotations

import time

import numpy as np

from .report import Section, Target, fmt_t, fmt_x


def weakly_hard(misses: int, window: int) -> list:
    """Edges ``(state, next, delivered)``: states are the last ``window - 1``
    outcomes with at most ``misses`` losses; a step is allowed when the
    ``window`` outcomes it completes have at most ``misses`` losses."""
    states = [w for w in np.ndindex(*(2,) * (window - 1))
              if (window - 1) - sum(w) <= misses]
    index = {w: k for k, w in enumerate(states)}
    edges = []
    for w in states:
        for d in (0, 1):
            if window - sum(w) - d <= misses:
                edges.append((index[w], index[w[1:] + (d,)], d))
    return edges


def _plant(n: int, seed: int = 0):
    from control_ncs import ConstrainedPlant
    rng = np.random.default_rng([seed, n])
    A = rng.standard_normal((n, n))
    A *= 1.05 / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((n, 1))
    Bw = 0.5 * rng.standard_normal((n, 1))
    Cz = np.vstack([rng.standard_normal((1, n)) / np.sqrt(n),
                    np.zeros((1, n))])
    Du = np.array([[0.0], [0.3]])
    return ConstrainedPlant.lossy(A, B, Bw, Cz, Du, np.zeros((2, 1)),
                                  weakly_hard(2, 5))


def _common_storage_gain(loop) -> tuple[float, str]:
    """The plain program: one ``P`` for every edge, ``γ²`` minimised
    (bounded real lemma per mode), Clarabel; the solver's γ (unchecked)."""
    import cvxpy as cp
    n, m = loop.nstates, loop.ninputs
    P = cp.Variable((n, n), symmetric=True)
    g2 = cp.Variable()
    cons = [P >> 1e-8 * np.eye(n)]
    for _, _, i in loop.graph.edges:
        F = np.hstack([loop.A[i], loop.B[i]])
        H = np.hstack([loop.C[i], loop.D[i]])
        M = F.T @ P @ F + H.T @ H - cp.bmat(
            [[P, np.zeros((n, m))], [np.zeros((m, n)), g2 * np.eye(m)]])
        cons.append(0.5 * (M + M.T) << 0)
    problem = cp.Problem(cp.Minimize(g2), cons)
    problem.solve(solver=cp.CLARABEL)
    if problem.status != "optimal" or g2.value is None:
        return float("nan"), problem.status
    return float(np.sqrt(max(g2.value, 0.0))), problem.status


def worstcase_section(quick: bool) -> Section:
    from control_ncs import SynthesisError, worst_case_design, worst_case_gain
    sec = Section("Worst-case gain over a weakly-hard (2, 5) loss budget")
    sizes = [2] if quick else [2, 4, 8]
    memories = (1,) if quick else (1, 2)
    cycle_length = 4 if quick else 8
    design_rows, analysis_rows, brackets = [], [], []
    for n in sizes:
        P = _plant(n)
        loop = None
        for M in memories:
            start = time.perf_counter()
            try:
                res = worst_case_design(P, spec="gain", memory=M,
                                        cycle_length=cycle_length)
            except SynthesisError as err:
                design_rows.append([n, M, fmt_t(time.perf_counter() - start),
                                    err.reason, "", "", ""])
                continue
            elapsed = time.perf_counter() - start
            design_rows.append([n, M, fmt_t(elapsed), len(res.walks),
                                f"{res.figure:.5f}", f"{res.bound:.5f}",
                                f"{res.figure_synthesis:.5f}"])
            brackets.append((res.bound, res.figure))
            loop = res.loop if loop is None else loop
        if loop is None:
            continue
        start = time.perf_counter()
        g_common, status = _common_storage_gain(loop)
        t_common = time.perf_counter() - start
        analysis_rows.append([n, "one common storage (plain cvxpy)", "",
                              fmt_t(t_common), "1×",
                              f"{g_common:.5f}" if status == "optimal"
                              else status, ""])
        for M in (0,) if quick else (0, 1, 2):
            start = time.perf_counter()
            res = worst_case_gain(loop, memory=M, cycle_length=cycle_length)
            t = time.perf_counter() - start
            analysis_rows.append([n, "worst_case_gain, storages per node",
                                  M, fmt_t(t), fmt_x(t / t_common),
                                  f"{res.figure:.5f}", f"{res.bound:.5f}"])
    sec.add("A seeded n-state plant (spectral radius 1.05, one input, "
            "`z = [c x; 0.3 u]`), its commands lost at most twice in any five "
            "steps (weakly-hard (2, 5): 11 nodes, 16 edges). "
            "`worst_case_design(spec='gain', memory=M)`: gains per node of "
            "the memory-M lift; the figure is the fixed loop's certified "
            "worst-case ℓ2 gain (analysis at memory 0 on the lifted graph), "
            "the other side the largest gain of a periodic pattern of at "
            f"most {cycle_length} steps; one run each (time includes the "
            "analysis and the pattern search).", "")
    sec.table(["n", "memory", "time", "lifted nodes", "certified γ",
               "periodic patterns' γ", "design LMI's γ"], design_rows)
    sec.add("The loop designed at memory 1 (on its lifted graph), analysed "
            "again: storages per node of the memory-M lift of that graph "
            "(exact check and pattern search included), beside one common "
            "quadratic storage for every edge (the plain cvxpy program, "
            "solver figure unchecked; NaN/status when it has no solution).",
            "")
    sec.table(["n", "route", "memory", "time", "× common", "γ",
               "patterns' γ"], analysis_rows)
    sec.targets.append(Target(
        "every certified worst-case γ at least its periodic patterns' γ",
        bool(brackets) and all(lo <= hi * (1 + 1e-9) for lo, hi in brackets),
        f"{len(brackets)} designs", "a pattern's gain is a lower bound of "
        "the worst case"))
    return sec
