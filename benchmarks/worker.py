"""Subprocess worker for the memory-capped synthesis runs.

``python -m benchmarks.worker '<json>'`` runs one synthesis and prints one
JSON line: ``ok``, times, status, ``peak_rss_mb`` (getrusage) and, on
failure, ``error``. Launched by :func:`benchmarks.common.run_capped`, which
caps the address space, watches the resident memory and enforces a timeout.

Jobs (``"job"``):

* ``"passivesyn"``: ``passivesyn(random_plant(n, N), eta, options=...)`` with
  ``options={'solver': ..., 'solver_options': opts}``
  (``solver`` None: the package's automatic choice);
* ``"ff_index"``: ``passivity_certificate(random_stable_ss(n))``;
* ``"ms_dense"``: ``ms_radius(random_loop(n, N), method='dense')``;
* ``"clarabel_probe"``: the plain cvxpy + Clarabel build of the merged LMI
  with ``max_iter`` iterations only (memory and time per iteration).
"""

from __future__ import annotations

import json
import sys
import time
import warnings

#: A job's ``options`` that are passivesyn's keywords (the rest are the
#: solver's options).
DESIGN_KEYWORDS = ("controller", "actuator", "gain", "method")


def main(arg: str) -> dict:
    warnings.simplefilter("ignore")
    spec = json.loads(arg)
    from benchmarks.common import peak_rss_mb, random_plant
    n, N = int(spec["n"]), int(spec["N"])
    eta = spec.get("eta", 0.5)
    decay = spec.get("decay")
    opts = dict(spec.get("options", {}))
    P = random_plant(n, N) if spec["job"] not in ("ms_dense", "ff_index") \
        else None
    out: dict = dict(ok=False)
    start = time.perf_counter()
    try:
        if spec["job"] == "passivesyn":
            from control_ncs import passivesyn
            # the spec's options: the design's keywords, else solver options
            kw = {k: opts.pop(k) for k in DESIGN_KEYWORDS if k in opts}
            K, CL, e = passivesyn(P, eta, decay=decay, **kw, options=dict(
                solver=spec.get("solver"), solver_options=opts))
            res = K.result
            out.update(ok=True, eta=e, ms_radius=res.ms_radius,
                       solver=res.report.solver,
                       sweeps=res.report.iterations,
                       attempts=len(res.attempts),
                       compile=sum(a.compile_time for a in res.attempts),
                       solve=sum(a.solve_time for a in res.attempts),
                       status=[a.status for a in res.attempts])
        elif spec["job"] == "clarabel_probe":
            from control_ncs.lmi import solve, synthesis_model
            from control_ncs.strategies import build
            plant = build(P)
            t0 = time.perf_counter()
            model = synthesis_model(plant, eta, 1.0, 1e-7, "full", "merged")
            build_time = time.perf_counter() - t0
            rep = solve(model.problem, "CLARABEL", **opts)
            out.update(ok=True, status=rep.status, build=build_time,
                       compile=rep.compile_time, solve=rep.solve_time,
                       iterations=rep.iterations)
        elif spec["job"] == "ff_index":
            import control_ncs as cn
            from benchmarks.common import random_stable_ss
            res = cn.passivity_certificate(random_stable_ss(n),
                                           solver=spec.get("solver"), **opts)
            out.update(ok=bool(res.passive), eta=res.eta,
                       compile=res.report.compile_time,
                       solve=res.report.solve_time)
        elif spec["job"] == "ms_dense":
            from benchmarks.bench_stability import random_loop
            from control_ncs import ms_radius
            out.update(ok=True, rho=ms_radius(random_loop(n, N),
                                              method="dense"))
        else:
            raise ValueError(f"unknown job {spec['job']!r}")
    except MemoryError as err:
        out.update(error=f"MemoryError: {err}")
    except Exception as err:  # reported, not raised: the parent decides
        out.update(error=f"{type(err).__name__}: {str(err)[:300]}")
    out.update(total=time.perf_counter() - start, peak_rss_mb=peak_rss_mb())
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1]), default=float), flush=True)
