"""The same user calls timed on two source trees, alternately, in one run.

``python -m benchmarks.before_after OLD_TREE NEW_TREE [--rounds R]`` runs
each call of :data:`CALLS` in a fresh interpreter per tree (``PYTHONPATH``
set to the tree), alternating the trees, and prints the least time of each
call per tree and their ratio, as a markdown table. The trees are checkouts
of the package (``git worktree add /tmp/old <commit>``); only calls whose
spelling both trees accept belong here.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

SETUP = """
import time, json, numpy as np, control_ncs as ncs
rng = np.random.default_rng(0)
n = 4
A = rng.standard_normal((n, n)); A *= 0.95 / max(abs(np.linalg.eigvals(A)))
B = np.hstack([np.eye(n)[:, :1], rng.standard_normal((n, 1))])
C = np.vstack([np.eye(n)[:1], np.eye(n)[:2]])
D = np.zeros((3, 2))
def plant(**kw):
    return ncs.nss(A, B, C, D, nmeas=2, ncon=1, **kw)
K = -np.array([[0.5, 0.2]])
"""

#: name -> (prepare, timed statement)
CALLS = {
    "feedback, Bernoulli links": (
        "P = plant(sensor_loss=0.1, actuator_loss=0.2)",
        "ncs.feedback(P, K)"),
    "ms_radius, Bernoulli links": (
        "CL = ncs.feedback(plant(sensor_loss=0.1, actuator_loss=0.2), K)",
        "ncs.ms_radius(CL)"),
    "feedback, a delayed sensor link": (
        "P = plant(sensor_delay=ncs.random_delay([0.5, 0.3, 0.2]))",
        "ncs.feedback(P, K)"),
    "norm(., 2), a delayed sensor link": (
        "CL = ncs.feedback(plant(sensor_delay=ncs.random_delay("
        "[0.5, 0.3, 0.2])), K)",
        "ncs.norm(CL, 2)"),
    "h2syn, a sensor schedule": (
        "P = plant(sensor_schedule=[[1, 0], [0, 1]], actuator_loss=0.1)",
        "ncs.h2syn(P)"),
    "passivesyn, Bernoulli links": (
        "P = ncs.nss(A, np.hstack([B[:, :1], B[:, 1:]]), np.vstack(["
        "B[:, 1:].T, np.eye(n)]), np.zeros((n + 1, 2)), nmeas=n, ncon=1,"
        " actuator_loss=0.1)",
        "ncs.passivesyn(P, controller='static')"),
}

TIMER = """
{setup}
{prepare}
best = float('inf')
for _ in range(3):
    t = time.perf_counter()
    {statement}
    best = min(best, time.perf_counter() - t)
print(json.dumps(best))
"""


def _time(tree: str, name: str) -> float:
    prepare, statement = CALLS[name]
    code = TIMER.format(setup=SETUP, prepare=prepare, statement=statement)
    env = dict(os.environ, PYTHONPATH=tree)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tree,
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        return float("nan")
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.before_after")
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args(argv)
    rows = []
    for name in CALLS:
        best = {"old": float("inf"), "new": float("inf")}
        for _ in range(args.rounds):
            for key in ("old", "new"):
                best[key] = min(best[key], _time(getattr(args, key), name))
        rows.append((name, best["old"], best["new"]))
    print(f"load average at the end: {os.getloadavg()}")
    print("| call | before | after | after / before |")
    print("|---|---|---|---|")
    for name, old, new in rows:
        print(f"| {name} | {old * 1e3:.3g} ms | {new * 1e3:.3g} ms | "
              f"{new / old:.2f} |")


if __name__ == "__main__":
    main()
