"""Estimator synthesis (MATH §12) at n = 4, 8, 16 against the predictor's.

Not registered in the benchmark suite (run it alone)::

    python -m benchmarks.bench_estimator [--quick]

For each size: the plant of :func:`benchmarks.common.random_plant`, whose
state is measured through ``n // 2`` random outputs (``y = C2 x``) for the
estimator. Timed (median of ``repeats`` warm runs after a cold one):

* ``estimator_gain`` — the exact LMI for ``L`` and its exact verification;
* ``passivesyn(controller='predictor')`` at a fixed ``η`` on the same plant
  with ``y = x`` — the LMI that ``K`` of the estimator controller will solve
  once ``passivesyn(controller='estimator')`` is wired (MATH §12: §8b's LMI);
* their ratio: the extra price of output feedback is ``L``'s LMI.
"""

from __future__ import annotations

import sys
import time
import warnings
from functools import partial

import numpy as np

from .common import random_plant

ETA = 0.5


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


def _median(f, repeats: int) -> float:
    f()                                  # cold: compile, caches
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def run(sizes=(4, 8, 16), repeats: int = 3) -> list[dict]:
    """One row per size: times (s), ratio, and the verified rates."""
    from control_ncs import passivesyn
    from control_ncs.estimator import estimator_gain
    rows = []
    for n in sizes:
        P = random_plant(n)
        Po = output_version(P)
        L = estimator_gain(Po)
        t_est = _median(partial(estimator_gain, Po), repeats)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t_pred = _median(partial(passivesyn, P, ETA,
                                     controller="predictor"), repeats)
        rows.append(dict(n=n, nmeas=Po.C2.shape[0], estimator=t_est,
                         predictor=t_pred, ratio=t_est / t_pred,
                         error_rate=L.ms_radius))
    return rows


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    rows = run((4, 8) if quick else (4, 8, 16), repeats=1 if quick else 3)
    print(f"{'n':>3} {'nmeas':>5} {'estimator_gain':>15} {'predictor syn':>14}"
          f" {'ratio':>6} {'error ms_radius':>16}")
    for r in rows:
        print(f"{r['n']:>3} {r['nmeas']:>5} {r['estimator']:>14.3f}s "
              f"{r['predictor']:>13.3f}s {r['ratio']:>6.2f} "
              f"{r['error_rate']:>16.4f}")


if __name__ == "__main__":
    main(sys.argv[1:])
