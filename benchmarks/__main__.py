"""Run the benchmarks: ``python -m benchmarks [--quick] [--out DIR]``.

Writes ``DIR/benchmarks.md`` (default ``docs/``; with ``--quick`` a new
temporary directory, so that a smoke run never replaces the report) and
``DIR/benchmarks_scaling.png``. The full run takes about 30 minutes on the
project's 2-core machine; ``--quick`` runs tiny sizes only (under 30 s) to
check that every section works. Every section states its targets; the run
ends with one line per target: met, missed, or (a target of the full sizes
in ``--quick``) not measured.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import traceback
import warnings

import numpy as np

from .common import ROOT, fit_exponent, machine_info
from .report import Section, fmt_t

SECTIONS = [
    ("bench_synthesis", "forms"),
    ("bench_synthesis", "forms_detail"),
    ("bench_synthesis", "routes"),
    ("bench_synthesis", "compile_reduction"),
    ("bench_synthesis", "dlqr_section"),
    ("bench_synthesis", "delayed_default_section"),
    ("bench_stability", "ms_radius_section"),
    ("bench_stability", "monte_carlo_section"),
    ("bench_stability", "certified_radius_section"),
    ("bench_simulate", "simulate_section"),
    ("bench_simulate", "simulate_scale_section"),
    ("bench_passivity", "passivity_section"),
    ("bench_sweeps", "sweeps_section"),
    ("bench_markov", "markov_section"),
    ("bench_estimator", "estimator_section"),
    ("bench_refine", "refine_section"),
    ("bench_performance", "performance_section"),
    ("bench_delays", "delays_section"),
    ("bench_delays", "delayed_design_section"),
    ("bench_structured", "structured_design_section"),
    ("bench_jsr", "jsr_section"),
    ("bench_worstcase", "worstcase_section"),
    ("bench_intersample", "intersample_section"),
    ("bench_estimation", "estimation_section"),
    ("bench_kernel", "kernel_floor_section"),
    ("bench_kernel", "threads_section"),
]


def _run_sections(quick: bool, only: list | None) -> list:
    import importlib
    out = []
    for mod, fn in SECTIONS:
        if only and not any(o in fn or o in mod for o in only):
            continue
        start = time.perf_counter()
        print(f"[benchmarks] {mod}.{fn} …", flush=True)
        try:
            func = getattr(importlib.import_module(f"benchmarks.{mod}"), fn)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sec = func(quick)
        except Exception:  # a broken section is reported, not fatal
            sec = Section(f"{fn} (failed)")
            sec.add("```", traceback.format_exc().strip(), "```", "")
        sec.data["elapsed"] = time.perf_counter() - start
        print(f"[benchmarks]   {fmt_t(sec.data['elapsed'])}", flush=True)
        out.append(sec)
    return out


def _scaling(sections: list, png: str) -> Section:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sec = Section("6. Scaling")
    series = {}
    for s in sections:
        series.update({k: v for k, v in s.series.items() if len(v) >= 2})
    n_series = {}
    for s in sections:
        n_series.update(s.data.get("N_series", {}))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    rows = []
    styles = [(c, m) for m in ("o", "s", "^") for c in
              plt.rcParams["axes.prop_cycle"].by_key()["color"]]
    for j, (label, pts) in enumerate(series.items()):
        pts = sorted(pts)
        x, y = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
        big = x >= 16 if (x >= 16).sum() >= 2 else np.ones_like(x, bool)
        k = fit_exponent(x[big], y[big])
        color, marker = styles[j % len(styles)]
        ax1.loglog(x, y, "-", marker=marker, color=color,
                   label=f"{label}: n^{k:.2f}")
        rows.append([label, "n", ", ".join(f"{v:g}" for v in x[big]),
                     f"{k:.2f}"])
    ax1.set_xlabel("n (states)")
    ax1.set_ylabel("time [s]")
    ax1.set_title("time against n (exponent fitted for n ≥ 16)")
    ax1.grid(True, which="both", alpha=0.3)
    if ax1.get_legend_handles_labels()[0]:
        ax1.legend(fontsize="x-small")
    for (n, form), pts in sorted(n_series.items()):
        if len(pts) < 2:
            continue
        pts = sorted(pts)
        x, y = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
        k = fit_exponent(x, y)
        ax2.loglog(x, y, "o-", label=f"passivesyn {form}, n={n}: N^{k:.2f}")
        rows.append([f"passivesyn {form}, n = {n}", "N",
                     ", ".join(f"{v:g}" for v in x), f"{k:.2f}"])
    ax2.set_xlabel("N (period)")
    ax2.set_ylabel("time [s]")
    ax2.set_title("passivesyn time against N (fixed η)")
    ax2.grid(True, which="both", alpha=0.3)
    if ax2.get_legend_handles_labels()[0]:
        ax2.legend(fontsize="x-small")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    sec.add(f"![scaling]({os.path.basename(png)})", "",
            "Least-squares slopes of log(time) against log(n) (points with "
            "n ≥ 16 where there are two or more) or log(N):", "")
    sec.table(["series", "against", "points", "exponent"], rows)
    sec.add("Small sizes are dominated by fixed overheads (cvxpy "
            "compilation, Python, ARPACK set-up), so exponents fitted over "
            "them understate the asymptotic growth. The steep curves are the "
            "interior-point routes (one Clarabel iteration, passivesyn) and "
            "the dense ms_radius; the flat ones are the matrix-free "
            "ms_radius and the Riccati routes (O(n³) per sweep or solve, sweeps "
            "roughly independent of n).", "")
    return sec


def _header(info: dict, quick: bool, elapsed: float, load_end) -> str:
    lines = ["# control_ncs benchmarks", "",
             "Generated by `python -m benchmarks" + (" --quick" if quick else "")
             + "` (benchmarks/). Every ratio compares two routes measured in "
             "the same run on the same machine.", "",
             "| | |", "|---|---|",
             f"| machine | {info['processor']}, {info['cores']} cores, "
             f"{info['memory_gb']:.1f} GiB, {info['system']} |",
             f"| python | {info['python']} |",
             f"| numpy / BLAS | {info['numpy']} / {info['blas']} |",
             f"| scipy | {info['scipy']} |",
             f"| cvxpy | {info['cvxpy']} |",
             f"| clarabel / scs / cvxopt | {info['clarabel']} / {info['scs']}"
             f" / {info['cvxopt']} |",
             f"| control | {info['control']} |",
             f"| load average at start / end | "
             f"{' '.join(f'{v:.2f}' for v in info['loadavg'])} / "
             f"{' '.join(f'{v:.2f}' for v in load_end)} |",
             f"| run time | {fmt_t(elapsed)} |", ""]
    if info["loadavg"][0] > 1.0 or load_end[0] > 1.5:
        lines += ["The machine was shared while this ran (load average above; "
                  "other sessions run tests on the same 2 cores), so absolute "
                  "times carry noise of tens of percent; ratios of routes "
                  "measured back to back are steadier.", ""]
    return "\n".join(lines) + "\n"


def _targets(sections: list) -> str:
    lines = ["## Targets", "",
             "| target | met | measured | why |", "|---|---|---|---|"]
    for s in sections:
        for t in s.targets:
            met = {True: "**met**", False: "**missed**", None: "–"}[t.met]
            lines.append(f"| {t.name} | {met} | {t.measured} | {t.why} |")
    lines.append("")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks",
                                     description=__doc__)
    parser.add_argument("--quick", action="store_true",
                        help="tiny sizes only (a smoke run, < 30 s, every "
                        "target checked at those sizes)")
    parser.add_argument("--out", default=None,
                        help="output directory (default: docs/, or a new "
                        "temporary directory with --quick)")
    parser.add_argument("--only", nargs="*", default=None,
                        help="run only sections whose name contains these")
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = (tempfile.mkdtemp(prefix="benchmarks-quick-")
                    if args.quick else os.path.join(ROOT, "docs"))
    os.makedirs(args.out, exist_ok=True)
    start = time.perf_counter()
    info = machine_info()
    sections = _run_sections(args.quick, args.only)
    png = os.path.join(args.out, "benchmarks_scaling.png")
    scaling = _scaling(sections, png)
    elapsed = time.perf_counter() - start
    notes = ""
    if not args.quick:
        import importlib
        try:  # read at the end, so the analysis may be edited during a run
            notes = importlib.import_module("benchmarks.notes").NOTES
        except ImportError:
            pass
    text = (_header(info, args.quick, elapsed, os.getloadavg())
            + _targets(sections)
            + "".join(s.markdown() + "\n" for s in sections)
            + scaling.markdown() + "\n" + notes)
    md = os.path.join(args.out, "benchmarks.md")
    with open(md, "w") as fh:
        fh.write(text)
    print(f"[benchmarks] wrote {md} and {png} in {fmt_t(elapsed)}")
    _print_targets(sections)
    return 0


def _print_targets(sections: list) -> None:
    """One line per target: met, missed or not measured in this run."""
    count = {True: 0, False: 0, None: 0}
    for s in sections:
        if not s.targets and "(failed)" not in s.title:
            print(f"[target] –      {s.title}: states no target")
        for t in s.targets:
            count[t.met] += 1
            word = {True: "met", False: "MISSED", None: "–"}[t.met]
            print(f"[target] {word:6s} {t.name}: {t.measured}")
    failed = [s.title for s in sections if "(failed)" in s.title]
    print(f"[benchmarks] targets: {count[True]} met, {count[False]} missed, "
          f"{count[None]} not measured in this run; "
          f"{len(failed)} section(s) failed")


if __name__ == "__main__":
    sys.exit(main())
