"""Benchmark 5: loss-free passivity index, ours vs python-control's."""

from __future__ import annotations

import time
import warnings

from .common import random_stable_ss, run_capped
from .report import Section, Target, fmt_t, fmt_x


def _rel(a, b):
    return f"{abs(a - b) / max(abs(b), 1e-12):.1e}"


def passivity_section(quick: bool) -> Section:
    import control as ct
    import control_ncs as cn
    sec = Section("5. Loss-free passivity index: control_ncs vs "
                  "control.get_input_ff_index (cvxopt)")
    sizes = [4] if quick else [4, 16, 32, 64]
    lmi_max = 32          # above: one capped run (it takes minutes)
    reps = 1 if quick else 3
    rows, data = [], {}
    for n in sizes:
        G = random_stable_ss(n)
        d = {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d["kyp"] = cn.frequency_ff_index(G)
            # interleaved rounds: load changes hit every route alike
            times = {"ct": [], "ours": [], "lmi": []}
            for _ in range(reps):
                t = time.perf_counter()
                d["ct"] = ct.get_input_ff_index(G)
                times["ct"].append(time.perf_counter() - t)
                t = time.perf_counter()
                res = cn.passivity_certificate(G)
                times["ours"].append(time.perf_counter() - t)
                d["ours"], d["method"] = res.eta, res.method
                d["split"] = (res.report.compile_time, res.report.solve_time)
                if n <= lmi_max:
                    t = time.perf_counter()
                    d["lmi"] = cn.get_input_ff_index(G, method="lmi")
                    times["lmi"].append(time.perf_counter() - t)
            for key, ts in times.items():
                if ts:
                    d["t_" + key] = sorted(ts)[len(ts) // 2]
            if n > lmi_max:
                r = run_capped(dict(job="ff_index", n=n, N=1,
                                    options=dict(method="lmi")), 16.0, 60.0)
                d["capped"] = r
                if r.get("ok"):
                    d["t_lmi"], d["lmi"] = r["total"], r["eta"]
        data[n] = d
        sec.series.setdefault("control.get_input_ff_index (cvxopt)",
                              []).append((n, d["t_ct"]))
        sec.series.setdefault("control_ncs.get_input_ff_index (default)",
                              []).append((n, d["t_ours"]))
        if "t_lmi" in d:
            sec.series.setdefault("control_ncs.get_input_ff_index "
                                  "(method='lmi', Clarabel)",
                                  []).append((n, d["t_lmi"]))
        ref = d["ct"]
        rows.append([n, f"control_ncs default (method='auto' → "
                        f"{d['method']})", fmt_t(d["t_ours"]),
                     f"{fmt_t(d['split'][0])} / {fmt_t(d['split'][1])}",
                     fmt_x(d["t_ours"] / d["t_ct"]), f"{d['ours']:.8f}",
                     _rel(d["ours"], ref), _rel(d["ours"], d["kyp"])])
        if "lmi" in d:
            rows.append([n, "control_ncs method='lmi' (Clarabel)",
                         fmt_t(d["t_lmi"]), "", fmt_x(d["t_lmi"] / d["t_ct"]),
                         f"{d['lmi']:.8f}", _rel(d["lmi"], ref),
                         _rel(d["lmi"], d["kyp"])])
        else:
            r = d["capped"]
            rows.append([n, "control_ncs method='lmi' (Clarabel)",
                         f"{r['outcome']} after {fmt_t(r['wall'])}", "",
                         f"> {fmt_x(r['wall'] / d['t_ct'])}", "–", "", ""])
        rows.append([n, "control.get_input_ff_index (cvxopt)", fmt_t(d["t_ct"]),
                     "", "1×", f"{ref:.8f}", "", _rel(ref, d["kyp"])])
        rows.append([n, "KYP frequency sweep (frequency_ff_index)", "", "", "",
                     f"{d['kyp']:.8f}", _rel(d["kyp"], ref), ""])
    sec.add("Random stable discrete-time systems (`random_stable_ss`: "
            "spectral radius 0.9, 2 inputs/outputs, D ≈ 2I so D + Dᵀ ≻ 0). "
            "control_ncs default: `passivity_certificate(G)` — for a "
            "deterministic system the KYP frequency search gives an upper "
            "bound, one Riccati equation (`scipy.linalg.solve_discrete_are`) "
            "just below it gives P, and the exact check certifies the index "
            "(compile / solve columns: frequency search / Riccati + checks). "
            "`method='lmi'`: the LMI with Clarabel and the same exact check; "
            f"above n = {lmi_max} one run in a subprocess capped at 16 GiB "
            "and 60 s. control: `control.get_input_ff_index` (cvxopt, no "
            f"verification). Median of {reps} interleaved rounds. "
            "'time / control': our time over control's (below 1 = faster).",
            "")
    sec.table(["n", "route", "time", "compile / solve", "time / control",
               "ν", "rel. diff to control", "rel. diff to KYP"], rows)
    sec.data.update(data)
    gap = max(abs(d["ours"] - d["kyp"]) / max(abs(d["kyp"]), 1e-12)
              for d in data.values())
    sec.targets.append(Target(
        "the certified index agrees with the KYP frequency sweep to 1e-4",
        gap <= 1e-4, f"largest relative difference {gap:.1e}",
        "an independent route (a frequency sweep of the same system)"))
    return sec
