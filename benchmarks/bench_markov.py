"""Benchmark: bursty (Markov) losses.

Not registered in the runner yet; run it alone::

    python -m benchmarks.bench_markov [--quick]

Two figures, each against its target:

* ``simulate`` with a Markov chain against the i.i.d. engine on the same
  modes (same system, same trials and steps): trial-steps per second, and
  their ratio (target >= 0.5).
* matrix-free ``ms_radius`` of a Markov system with n = 100 states, M = 4
  modes, period N = 10 (target under 10 s): operator on 4-tuples of
  100 × 100 matrices, 40 000 unknowns, inside ARPACK.
* ``passivesyn`` over two bursty links at n = 8, 16, 32 (gains ``K_{k,ℓ}``
  on the previous mode, theory: Markov losses), the default call, against the same
  plant over Bernoulli links of the same stationary losses.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from .report import Section, Target, fmt_t, fmt_x


def markov_system(n: int, N: int, M: int, seed: int = 0, radius: float = 0.9):
    """Random ``N``-periodic jump system with ``M`` modes, mode matrices of
    spectral radius ``radius`` and a random (Dirichlet) transition; and its
    i.i.d. twin (the same modes, the chain's stationary marginals)."""
    from control_ncs import jss
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((N, M, n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)), axis=-1)[..., None, None]
    B = rng.standard_normal((N, M, n, 1))
    C = rng.standard_normal((N, M, 1, n))
    D = np.zeros((N, M, 1, 1))
    T = rng.dirichlet(np.ones(M), size=(N, M))
    markov = jss(A, B, C, D, transition=T)
    iid = jss(A, B, C, D, markov.modes.probabilities)
    return markov, iid


def networked_loop(n: int, seed: int = 0):
    """A static-gain loop over two bursty links (4 Markov modes, N = 1) and
    the same loop with Bernoulli links of the same stationary losses."""
    import control as ct
    from control_ncs import feedback, gilbert_elliott, nss
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 1.02 / np.max(np.abs(np.linalg.eigvals(A)))
    B = np.hstack([rng.standard_normal((n, 1)), rng.standard_normal((n, 1))])
    C = np.vstack([rng.standard_normal((1, n)), np.eye(n)])
    D = np.zeros((n + 1, 2))
    s1 = gilbert_elliott(fail=0.05, recover=0.5)
    s2 = gilbert_elliott(fail=0.1, recover=0.6)
    P = nss(A, B, C, D, True, nmeas=n, ncon=1, sensor_loss=s1, actuator_loss=s2)
    K = -ct.dlqr(A, B[:, 1:], np.eye(n), np.eye(1))[0]
    Q = P.with_network(sensor_loss=s1.loss, actuator_loss=s2.loss)
    return feedback(P, K), feedback(Q, K)


def synthesis_plant(n: int, markov: bool = True, seed: int = 0):
    """A full-information plant (``y = x``, one actuator, ``z`` and ``w``
    scalar with ``D11 = 1``) over two Gilbert–Elliott links, or over
    Bernoulli links of the same stationary losses."""
    from control_ncs import gilbert_elliott, nss
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 1.02 / np.max(np.abs(np.linalg.eigvals(A)))
    B = np.hstack([rng.standard_normal((n, 1)), rng.standard_normal((n, 1))])
    C = np.vstack([rng.standard_normal((1, n)), np.eye(n)])
    D = np.zeros((n + 1, 2))
    D[0, 0] = 1.0
    s1 = gilbert_elliott(fail=0.05, recover=0.5)
    s2 = gilbert_elliott(fail=0.1, recover=0.6)
    if not markov:
        s1, s2 = s1.loss, s2.loss
    return nss(A, B, C, D, True, nmeas=n, ncon=1, sensor_loss=s1,
               actuator_loss=s2)


def bench_passivesyn(n: int, decay: float = 0.99) -> dict:
    """The default ``passivesyn`` call (maximised η, decay bound) on the
    Markov plant and on its Bernoulli twin: time, route, η, ms_radius."""
    from control_ncs import ms_radius, passivesyn
    out = {}
    for name, markov in (("markov", True), ("iid", False)):
        P = synthesis_plant(n, markov)
        t0 = time.perf_counter()
        K, CL, eta = passivesyn(P, decay=decay)
        seconds = time.perf_counter() - t0
        out[name] = dict(seconds=seconds, eta=eta, ms_radius=ms_radius(CL),
                         solver=K.result.report.solver,
                         gain=K.result.gain_kind, modes=CL.nmodes)
    out["ratio"] = out["markov"]["seconds"] / out["iid"]["seconds"]
    return out


def best_of(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_simulate(n: int, steps: int, trials: int) -> dict:
    from control_ncs import simulate
    markov, iid = networked_loop(n)
    out = {}
    for name, loop in (("markov", markov), ("iid", iid)):
        t = best_of(lambda loop=loop: simulate(
            loop, steps, initial_state=1.0, trials=trials, seed=1, workers=1))
        out[name] = trials * steps / t
    out["ratio"] = out["markov"] / out["iid"]
    return out


def bench_ms_radius(n: int, M: int, N: int) -> dict:
    from control_ncs import ms_radius
    markov, _ = markov_system(n, N, M)
    t0 = time.perf_counter()
    rho = ms_radius(markov, method="matrix-free")
    return dict(seconds=time.perf_counter() - t0, ms_radius=rho)


def markov_section(quick: bool) -> Section:
    """Section 8: Markov ``simulate`` against i.i.d., matrix-free
    ``ms_radius`` at n = 100, M = 4, N = 10, and ``passivesyn`` with
    Markov losses at n = 8, 16, 32 (all measured in this run)."""
    sec = Section("8. Bursty (Markov) losses: simulate, ms_radius, "
                  "passivesyn")
    n_sim, steps, trials = (4, 50, 200) if quick else (8, 200, 20000)
    s = bench_simulate(n_sim, steps, trials)
    sec.add(f"`simulate` of a static-gain loop (n = {n_sim}, LQR gain) over "
            "two Gilbert–Elliott links (4 Markov modes, N = 1; "
            "`bench_markov.networked_loop`) against the same loop with "
            "Bernoulli links of the same stationary losses: "
            f"{trials} trials × {steps} steps, one worker, best of 3.", "")
    sec.table(["losses", "time", "trial-steps/s", "ratio to i.i.d."],
              [["Markov chain (Gilbert–Elliott)",
                fmt_t(trials * steps / s["markov"]), f"{s['markov']:.3g}",
                fmt_x(s["ratio"])],
               ["i.i.d. (Bernoulli)", fmt_t(trials * steps / s["iid"]),
                f"{s['iid']:.3g}", fmt_x(1.0)]])
    n, M, N = (10, 4, 3) if quick else (100, 4, 10)
    r = bench_ms_radius(n, M, N)
    sec.add(f"Matrix-free `ms_radius` of a random {N}-periodic Markov jump "
            f"system, n = {n}, M = {M} modes, Dirichlet transitions "
            "(`bench_markov.markov_system`): ARPACK on the second-moment "
            f"operator on M-tuples of n × n matrices, {M * n * n} unknowns; "
            "one cold run.", "")
    sec.table(["n", "M", "N", "unknowns (M·n²)", "time", "ms_radius"],
              [[n, M, N, M * n * n, fmt_t(r["seconds"]),
                f"{r['ms_radius']:.6g}"]])
    sizes = (4,) if quick else (8, 16, 32)
    syn = {n: bench_passivesyn(n) for n in sizes}
    sec.add("The default `passivesyn(P, decay=0.99)` (η maximised) of a "
            "full-information plant over the two links above "
            "(`bench_markov.synthesis_plant`: random A of spectral radius "
            "1.02, one actuator, scalar w and z with D11 = 1): gains "
            "K_{k,ℓ} on the previous mode (theory: Markov losses), the LMI up to n = 8, "
            "the coupled Riccati equations above (`RICCATI_THRESHOLD`), each "
            "verified on the lumped pair-mode loop; against the same plant "
            "over Bernoulli links of the same stationary losses. One cold "
            "run each.", "")
    sec.table(["n", "links", "route", "time", "η", "ms_radius",
               "loop modes", "time ratio"],
              [[n, name, d[name]["solver"], fmt_t(d[name]["seconds"]),
                f"{d[name]['eta']:.4g}", f"{d[name]['ms_radius']:.4g}",
                d[name]["modes"],
                fmt_x(d["ratio"]) if name == "markov" else ""]
               for n, d in syn.items() for name in ("markov", "iid")])
    sec.data["markov"] = dict(simulate=s, ms_radius=r, passivesyn=syn)
    sec.targets.append(Target(
        "simulate: Markov chain ≥ 0.5× the i.i.d. engine",
        s["ratio"] >= 0.5, fmt_x(s["ratio"]),
        "same loop, trials and steps; measured back to back"))
    if quick:
        sec.full_run_only("matrix-free ms_radius, n = 100, M = 4, N = 10: "
                          "under 10 s", "n = 100 only in the full run")
    if not quick:
        sec.targets.append(Target(
            "matrix-free ms_radius, n = 100, M = 4, N = 10: under 10 s",
            r["seconds"] < 10.0, fmt_t(r["seconds"]),
            "40 000 unknowns inside ARPACK, one cold run"))
    return sec


def main(argv: list[str]) -> None:
    print(markov_section("--quick" in argv).markdown())


if __name__ == "__main__":
    main(sys.argv[1:])
