"""Benchmark 9: estimator synthesis (theory: output feedback) at n = 4, 8, 16 against the
predictor's.

A section of the runner (``python -m benchmarks --only estimator``); also
runs alone::

    python -m benchmarks.bench_estimator [--quick]

For each size: the plant of :func:`benchmarks.common.random_plant`, whose
state is measured through ``n // 2`` random outputs (``y = C2 x``) for the
estimator. Timed (median of ``repeats`` warm runs after a cold one):

* ``estimator_gain`` — the exact LMI for ``L`` and its exact verification;
* ``passivesyn(controller='predictor')`` at a fixed ``η`` on the same plant
  with ``y = x`` (theory: predictor's LMI);
* ``passivesyn(controller='estimator')`` at the same ``η`` on the plant with
  ``y = C2 x``: ``L`` by ``estimator_gain``, then §8b's LMI for ``K`` on the
  estimator's loop (theory: output feedback); one cold run, in this process, with
  ``options={'time_limit': ESTIMATOR_LIMIT}``;
* the ratios to the predictor: the price of output feedback.

From n = 16 on the predictor's synthesis takes minutes, so it runs once,
cold, in a subprocess killed after :data:`PREDICTOR_LIMIT` seconds
(:func:`benchmarks.common.run_capped`); its row says so.
"""

from __future__ import annotations

import sys
import warnings
from functools import partial

import numpy as np

from .common import median_time, random_plant, run_capped
from .report import Section, Target, fmt_t, fmt_x

ETA = 0.5
#: Wall-clock cap (s) of the one cold predictor synthesis from n = 16 on.
PREDICTOR_LIMIT = 300.0
#: Memory cap (GiB) of that subprocess.
PREDICTOR_MEM_GB = 8.0
#: passivesyn's own time budget (s) for the estimator synthesis.
ESTIMATOR_LIMIT = 300.0


def output_version(P, seed: int = 0):
    """The same plant measured through ``n // 2`` random outputs."""
    from control_ncs import nss
    n, m1, m2 = P.nstates, P.B1.shape[1], P.ncon
    p2 = max(1, n // 2)
    C2 = np.random.default_rng([seed, n]).standard_normal((p2, n))
    C = np.vstack([P.C1, C2])
    D = np.vstack([np.hstack([P.D11, P.D12]), np.zeros((p2, m1 + m2))])
    return nss(P.A, np.hstack([P.B1, P.B2]), C, D, True, nmeas=p2, ncon=m2,
               sensor_loss=P.sensor_loss, actuator_loss=P.actuator_loss)


def run(sizes=(4, 8, 16), repeats: int = 3, capped_from: int = 16
        ) -> list[dict]:
    """One row per size: times (s), ratio, and the verified rates.

    The predictor's synthesis at ``n >= capped_from`` runs once, cold, in a
    capped subprocess; its ``predictor`` time is then ``None`` when it was
    cut off (``predictor_outcome`` says why).
    """
    from control_ncs import passivesyn
    from control_ncs.estimator import estimator_gain
    rows = []
    for n in sizes:
        P = random_plant(n)
        Po = output_version(P)
        L = estimator_gain(Po)  # cold: compile, caches
        t_est = median_time(partial(estimator_gain, Po), repeats,
                            budget=float("inf"))[0]
        row = dict(n=n, nmeas=Po.C2.shape[0], estimator=t_est,
                   error_rate=L.ms_radius)
        if n >= capped_from:
            # the worker builds random_plant(n, 1): the same plant as P
            r = run_capped(dict(job="passivesyn", n=n, N=1, eta=ETA,
                                options=dict(controller="predictor")),
                           PREDICTOR_MEM_GB, PREDICTOR_LIMIT)
            ok = r["outcome"] == "ok"
            row.update(predictor=r.get("total") if ok else None,
                       predictor_how="1 cold run, subprocess",
                       predictor_outcome=r["outcome"],
                       predictor_error=r.get("error")
                       or "; ".join(r.get("stderr_tail", [])) or None,
                       predictor_rate=r.get("ms_radius"))
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                K, _, _ = passivesyn(P, ETA, controller="predictor")  # cold
                t_pred = median_time(partial(passivesyn, P, ETA,
                                             controller="predictor"),
                                     repeats, budget=float("inf"))[0]
            row.update(predictor=t_pred,
                       predictor_how=f"median of {repeats} warm",
                       predictor_outcome="ok",
                       predictor_rate=K.result.ms_radius)
        row["ratio"] = (None if row["predictor"] is None
                        else t_est / row["predictor"])
        row.update(_estimator_synthesis(Po))
        row["syn_ratio"] = (None if row["predictor"] is None
                            or row["synthesis"] is None
                            else row["synthesis"] / row["predictor"])
        rows.append(row)
    return rows


def _estimator_synthesis(Po) -> dict:
    """One cold ``passivesyn(controller='estimator')``: time and outcome."""
    import time
    from control_ncs import SynthesisError, passivesyn
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            K, _, _ = passivesyn(Po, ETA, controller="estimator",
                                 options={"time_limit": ESTIMATOR_LIMIT})
    except SynthesisError as err:
        return dict(synthesis=None, synthesis_outcome=err.reason,
                    synthesis_rate=None)
    return dict(synthesis=time.perf_counter() - start,
                synthesis_outcome="ok", synthesis_rate=K.result.ms_radius)


def estimator_section(quick: bool) -> Section:
    """Section 9: ``estimator_gain`` against the predictor's ``passivesyn``
    on the same plants, measured in this run."""
    sizes, repeats = ((4,), 1) if quick else ((4, 8, 16), 3)
    sec = Section("9. Estimator synthesis: estimator_gain vs the "
                  "predictor's passivesyn")
    rows = run(sizes, repeats, capped_from=8 if quick else 16)
    sec.add("`estimator_gain` (the LMI for L, theory: output feedback, and its exact "
            "verification) on `random_plant(n)` measured through n // 2 "
            "random outputs (`bench_estimator.output_version`), against "
            f"`passivesyn(controller='predictor')` at η = {ETA} on the same "
            "plant with full-state measurement (the LMI for K of the "
            "estimator controller). Estimator times are medians of "
            f"{repeats} warm run(s) after a cold one; the predictor's way of "
            "timing is in its column. From n = 16 the predictor runs once, "
            f"cold, in a subprocess capped at {PREDICTOR_LIMIT:.0f} s and "
            f"{PREDICTOR_MEM_GB:g} GiB; a capped row shows its outcome "
            "instead of a time. *ratio* = estimator / predictor.", "")
    table = []
    for r in rows:
        pred = (fmt_t(r["predictor"]) if r["predictor"] is not None else
                f"> {PREDICTOR_LIMIT:.0f} s (cut off)"
                if r["predictor_outcome"] == "timeout"
                else f"{r['predictor_outcome']}: "
                f"{(r.get('predictor_error') or 'no message')[:120]}")
        rate = r.get("predictor_rate")
        syn = (fmt_t(r["synthesis"]) if r["synthesis"] is not None
               else r["synthesis_outcome"])
        srate = r.get("synthesis_rate")
        table.append([r["n"], r["nmeas"], fmt_t(r["estimator"]),
                      f"{r['error_rate']:.4f}", pred, r["predictor_how"],
                      "–" if rate is None else f"{rate:.4f}",
                      fmt_x(r["ratio"]), syn,
                      "–" if srate is None else f"{srate:.4f}",
                      fmt_x(r["syn_ratio"])])
    sec.table(["n", "outputs", "estimator_gain", "error ms_radius (L)",
               "predictor passivesyn", "timed as", "closed-loop ms_radius (K)",
               "ratio", "estimator passivesyn (1 cold run)",
               "its closed-loop ms_radius", "ratio to predictor"], table)
    sec.data["estimator"] = rows
    sec.series["estimator_gain"] = [(r["n"], r["estimator"]) for r in rows]
    worst = max(r["error_rate"] for r in rows)
    sec.targets.append(Target(
        "every estimator gain makes the estimation error mean-square "
        "stable", worst < 1.0, f"largest error ms_radius {worst:.4f}",
        "each gain's error loop certified by ms_radius"))
    return sec


def main(argv: list[str]) -> None:
    print(estimator_section("--quick" in argv).markdown())


if __name__ == "__main__":
    main(sys.argv[1:])
