"""Benchmark: the H2 norm of jump systems (dense vs matrix-free, and against
python-control on deterministic systems)."""

from __future__ import annotations

import numpy as np

from .bench_stability import random_loop
from .common import median_time
from .report import Section, Target, fmt_t, fmt_x


def _stable_lti(n: int, seed: int):
    import control as ct
    rng = np.random.default_rng([seed, n, 14])
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.abs(np.linalg.eigvals(A)).max()
    return ct.ss(A, rng.standard_normal((n, 2)), rng.standard_normal((2, n)),
                 rng.standard_normal((2, 2)), 1.0)


def _synthesis_plant(n: int, seed: int = 16):
    """A seeded n-state plant with 4 controls over an actuator link losing
    20 %: z = the first 4 states and the 4 applied inputs, y = x."""
    from control_ncs import nss
    rng = np.random.default_rng([seed, n])
    m = 4
    A = rng.standard_normal((n, n))
    A *= 1.05 / np.abs(np.linalg.eigvals(A)).max()
    B = np.hstack([np.eye(n)[:, :2], rng.standard_normal((n, m))])
    nz = min(4, n) + m
    C1 = np.vstack([np.eye(n)[:min(4, n)], np.zeros((m, n))])
    C = np.vstack([C1, np.eye(n)])
    D = np.zeros((nz + n, 2 + m))
    D[min(4, n):nz, 2:] = np.eye(m)
    return nss(A, B, C, D, True, nmeas=n, ncon=m, actuator_loss=0.2)


def performance_section(quick: bool) -> Section:
    import control as ct
    from control_ncs import ms_radius, norm
    sec = Section("H2 norm: dense vs matrix-free, and against python-control")
    rows, mf_t = [], {}
    sizes = [4, 8, 16] if quick else [4, 8, 16, 24, 50, 100, 200]
    for n in sizes:
        sys = random_loop(n, 10)
        row: list = [n, 10]
        if n <= 24:
            t_d, _, v_d = median_time(
                lambda sys=sys: norm(sys, method="dense"), 3, 5.0)
            row += [fmt_t(t_d), f"{v_d:.10g}"]
        else:
            t_d, v_d = None, None
            row += ["–", "–"]
        t_m, _, v_m = median_time(
            lambda sys=sys: norm(sys, method="matrix-free"), 3, 20.0)
        t_r, _, _ = median_time(
            lambda sys=sys: ms_radius(sys, method="matrix-free"), 3, 20.0)
        mf_t[n] = t_m
        row += [fmt_t(t_m), f"{v_m:.10g}", fmt_x(t_m / t_r),
                f"{abs(v_d - v_m) / v_d:.1e}" if v_d else "–"]
        rows.append(row)
    sec.add("`ncs.norm(sys, 2)` of the random 10-periodic two-mode loops of "
            "the ms_radius benchmark (`bench_stability.random_loop`). "
            "`dense`: the Kronecker monodromy solved directly; "
            "`matrix-free`: GMRES on the second-moment operator, after the "
            "mean-square stability check (ARPACK). Ratio column: the "
            "matrix-free norm's time over `ms_radius` alone. Median of up to "
            "3 runs.", "")
    sec.table(["n", "N", "dense", "‖G‖₂ dense", "matrix-free",
               "‖G‖₂ matrix-free", "norm / ms_radius", "rel. diff"], rows)
    lti_rows = []
    for n in ([4, 16] if quick else [4, 16, 64, 128]):
        G = _stable_lti(n, 1)
        t_o, _, v_o = median_time(lambda G=G: norm(G, 2), 5, 5.0)
        t_c, _, v_c = median_time(lambda G=G: ct.norm(G, 2), 5, 5.0)
        diff = (f"{abs(v_o - v_c) / v_c:.1e}" if np.isfinite(v_c)
                else f"ct.norm gave {v_c} (ours {v_o:.6g})")
        lti_rows.append([n, fmt_t(t_o), fmt_t(t_c), fmt_x(t_o / t_c), diff])
    sec.add("", "Deterministic discrete-time systems (2 inputs, 2 outputs, "
            "spectral radius 0.9): `ncs.norm(G, 2)` (one Stein equation) "
            "against `ct.norm(G, 2)`, same run. Where python-control returns "
            "inf, its own test for poles near the unit circle fired (it warns "
            "\"poles close to the complex unit circle\") although every pole "
            "has modulus ≤ 0.9.", "")
    sec.table(["n", "ncs.norm", "ct.norm", "ncs / ct", "rel. diff"], lti_rows)
    syn_rows, syn_t = [], {}
    for n in ([4] if quick else [4, 16]):
        P = _synthesis_plant(n)
        from control_ncs import h2syn, hinfsyn
        t_h2, _, out_h2 = median_time(lambda P=P: h2syn(P), 1, 60.0)
        t_hi, _, out_hi = median_time(lambda P=P: hinfsyn(P), 1, 60.0)
        syn_t[n] = max(t_h2, t_hi)
        syn_rows.append([n, fmt_t(t_h2), f"{out_h2[2]:.6g}", fmt_t(t_hi),
                         f"{out_hi[2]:.6g}",
                         f"{out_hi[0].result.lower:.6g}"])
    sec.add("", "Synthesis over a lossy actuator link (loss 0.2, 4 inputs, "
            "the state measured, z = 4 states and the 4 applied inputs): "
            "`h2syn` and `hinfsyn`, each followed by its exact analysis of "
            "the designed loop (the H2 norm; the certified ℓ2 bracket). One "
            "run each.", "")
    sec.table(["n", "h2syn", "‖G‖₂", "hinfsyn", "γ certified",
               "γ lower bound"], syn_rows)
    if quick:
        sec.full_run_only("h2syn and hinfsyn at n = 16 under a minute",
                          "n = 16 only in the full run")
        sec.full_run_only("ncs.norm(·, 2) at n = 200, N = 10 under 10 s "
                          "(matrix-free)", "n = 200 only in the full run")
    if not quick:
        t16 = syn_t.get(16)
        sec.targets.append(Target(
            "h2syn and hinfsyn at n = 16 under a minute",
            t16 is not None and t16 < 60,
            f"slower of the two {fmt_t(t16)} ({fmt_x(60 / t16)} under the "
            f"limit)" if t16 else "not measured"))
    if not quick:
        t200 = mf_t.get(200)
        sec.targets.append(Target(
            "ncs.norm(·, 2) at n = 200, N = 10 under 10 s (matrix-free)",
            t200 is not None and t200 < 10,
            f"{fmt_t(t200)} ({fmt_x(10 / t200)} under the limit)"
            if t200 else "not measured"))
    sec.series["H2 norm matrix-free, N=10"] = sorted(mf_t.items())
    sec.data.update(mf=mf_t)
    return sec
