"""Benchmark 5: loss-free passivity index, ours vs python-control's."""

from __future__ import annotations

import time
import warnings

from .common import median_time, random_stable_ss, run_capped
from .report import Section, fmt_t, fmt_x


def _rel(a, b):
    return f"{abs(a - b) / max(abs(b), 1e-12):.1e}"


def passivity_section(quick: bool) -> Section:
    import control as ct
    import control_ncs as cn
    from .riccati import riccati_ff_index
    sec = Section("5. Loss-free passivity index: control_ncs vs "
                  "control.get_input_ff_index (cvxopt)")
    sizes = [4] if quick else [4, 16, 32, 64]
    clarabel_max = 32          # above: one capped run (it takes minutes)
    rows, data = [], {}
    for n in sizes:
        G = random_stable_ss(n)
        d = {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d["kyp"] = cn.frequency_ff_index(G)
            d["t_ct"], _, d["ct"] = median_time(
                lambda: ct.get_input_ff_index(G), 1 if quick else 3, 20.0)
            sec.series.setdefault("control.get_input_ff_index (cvxopt)",
                                  []).append((n, d["t_ct"]))
            if n <= clarabel_max:
                d["t_ours"], _, d["ours"] = median_time(
                    lambda: cn.get_input_ff_index(G), 1 if quick else 3, 20.0)
                rep = cn.passivity_certificate(G).report
                d["split"] = (rep.compile_time, rep.solve_time)
            else:
                r = run_capped(dict(job="ff_index", n=n, N=1), 16.0, 60.0)
                d["capped"] = r
                if r.get("ok"):
                    d["t_ours"], d["ours"] = r["total"], r["eta"]
                    d["split"] = (r["compile"], r["solve"])
            t = time.perf_counter()
            try:
                d["t_cvx"], _, d["cvx"] = median_time(
                    lambda: cn.get_input_ff_index(G, solver="CVXOPT"),
                    1 if quick else 3, 20.0)
            except Exception as err:
                d["t_cvx"], d["cvx_error"] = (time.perf_counter() - t,
                                              f"{type(err).__name__}: {err}")
            t = time.perf_counter()
            try:
                d["ric"], _ = riccati_ff_index(G, rtol=1e-3 if quick else 1e-6)
            except Exception as err:
                d["ric_error"] = f"{type(err).__name__}: {err}"
            d["t_ric"] = time.perf_counter() - t
        data[n] = d
        if "t_ours" in d:
            sec.series.setdefault("control_ncs.get_input_ff_index (Clarabel)",
                                  []).append((n, d["t_ours"]))
        if "ric" in d:
            sec.series.setdefault("Riccati prototype ff index",
                                  []).append((n, d["t_ric"]))
        ref = d["ct"]
        if "ours" in d:
            rows.append([n, "control_ncs (Clarabel, default)", fmt_t(d["t_ours"]),
                         f"{fmt_t(d['split'][0])} / {fmt_t(d['split'][1])}",
                         fmt_x(d["t_ours"] / d["t_ct"]), f"{d['ours']:.8f}",
                         _rel(d["ours"], ref), _rel(d["ours"], d["kyp"])])
        else:
            r = d["capped"]
            rows.append([n, "control_ncs (Clarabel, default)",
                         f"{r['outcome']} after {fmt_t(r['wall'])}", "",
                         f"> {fmt_x(r['wall'] / d['t_ct'])}", "–", "", ""])
        if "cvx" in d:
            rows.append([n, "control_ncs, solver='CVXOPT'", fmt_t(d["t_cvx"]),
                         "", fmt_x(d["t_cvx"] / d["t_ct"]), f"{d['cvx']:.8f}",
                         _rel(d["cvx"], ref), _rel(d["cvx"], d["kyp"])])
        else:
            rows.append([n, "control_ncs, solver='CVXOPT'",
                         f"failed after {fmt_t(d['t_cvx'])}", "", "",
                         d["cvx_error"][:140], "", ""])
        if "ric" in d:
            rows.append([n, "Riccati prototype (benchmarks/riccati.py)",
                         fmt_t(d["t_ric"]), "", fmt_x(d["t_ric"] / d["t_ct"]),
                         f"{d['ric']:.8f}", _rel(d["ric"], ref),
                         _rel(d["ric"], d["kyp"])])
        else:
            rows.append([n, "Riccati prototype (benchmarks/riccati.py)",
                         f"failed after {fmt_t(d['t_ric'])}", "", "",
                         d["ric_error"][:140], "", ""])
        rows.append([n, "control.get_input_ff_index (cvxopt)", fmt_t(d["t_ct"]),
                     "", "1×", f"{ref:.8f}", "", _rel(ref, d["kyp"])])
        rows.append([n, "KYP frequency sweep (frequency_ff_index)", "", "", "",
                     f"{d['kyp']:.8f}", _rel(d["kyp"], ref), ""])
    sec.add("Random stable discrete-time systems (`random_stable_ss`: "
            "spectral radius 0.9, 2 inputs/outputs, D ≈ 2I so D + Dᵀ ≻ 0). "
            "control_ncs: `get_input_ff_index` (cvxpy; the certificate is "
            "checked exactly; compile / solve of one call shown); with the "
            "default Clarabel above n = 32 one run in a subprocess capped "
            "at 16 GiB and 60 s. control: `control.get_input_ff_index` "
            "(cvxopt, no verification). Median of up to 3 runs. 'time / "
            "control': our time over control's (below 1 = faster).", "")
    sec.table(["n", "route", "time", "compile / solve", "time / control",
               "ν", "rel. diff to control", "rel. diff to KYP"], rows)
    sec.data.update(data)
    return sec
