"""Shared helpers of the benchmarks: seeded plants, timing, memory, versions.

Everything random takes an explicit seed (never the global NumPy state).
"""

from __future__ import annotations

import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from typing import Any, Callable

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# -- plants -------------------------------------------------------------------
def random_plant(n: int, N: int = 1, seed: int = 0, *, m1: int = 2, m2: int = 2,
                 radius: float = 1.02, sensor_loss: float = 0.05,
                 actuator_loss: float = 0.1):
    """A seeded networked plant for synthesis benchmarks.

    ``A`` random with spectral radius ``radius`` (slightly unstable);
    ``B2`` standard normal; ``B1``, ``C1`` of norm about 0.5 whatever ``n``
    (entries ``N(0, 0.25/n)``) so that a fixed ``η`` stays feasible as ``n``
    grows; ``D11 = 2I + 0.1·N(0,1)`` (``D11 + D11ᵀ ≈ 4I``), ``D12`` small;
    full-state measurement (``C2 = I``). For ``N > 1`` the actuator schedule
    addresses one actuator per step in turn (``s2 = [1, 2, 1, 2, …]``), so the
    LMI has ``N`` genuinely different phases.
    """
    from control_ncs import nss
    rng = np.random.default_rng([seed, n, N])
    A = rng.standard_normal((n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)))
    B1 = 0.5 * rng.standard_normal((n, m1)) / np.sqrt(n)
    B2 = rng.standard_normal((n, m2))
    C1 = 0.5 * rng.standard_normal((m1, n)) / np.sqrt(n)
    D11 = 2 * np.eye(m1) + 0.1 * rng.standard_normal((m1, m1))
    D12 = 0.1 * rng.standard_normal((m1, m2))
    B = np.hstack([B1, B2])
    C = np.vstack([C1, np.eye(n)])
    D = np.vstack([np.hstack([D11, D12]), np.zeros((n, m1 + m2))])
    s2 = None if N == 1 else [1 + (k % m2) for k in range(N)]
    return nss(A, B, C, D, True, nmeas=n, ncon=m2, actuator_schedule=s2,
               sensor_loss=sensor_loss, actuator_loss=actuator_loss)


def random_stable_ss(n: int, m: int = 2, seed: int = 0, radius: float = 0.9):
    """A seeded stable discrete-time StateSpace with ``D + Dᵀ ≻ 0``."""
    import control as ct
    rng = np.random.default_rng([seed, n, m, 7])
    A = rng.standard_normal((n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((n, m)) / np.sqrt(n)
    C = rng.standard_normal((m, n)) / np.sqrt(n)
    D = 2 * np.eye(m) + 0.1 * rng.standard_normal((m, m))
    return ct.ss(A, B, C, D, True)


# -- timing -------------------------------------------------------------------
def median_time(fn: Callable[[], Any], repeats: int = 3, budget: float = 30.0
                ) -> tuple[float, list[float], Any]:
    """Median wall time of ``fn()`` over up to ``repeats`` runs.

    Stops repeating once the runs so far exceed ``budget`` seconds (a slow
    case then reports fewer runs; the count is returned). Returns
    ``(median, times, last result)``.
    """
    times, out = [], None
    for _ in range(max(1, repeats)):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
        if sum(times) > budget:
            break
    return statistics.median(times), times, out


def fit_exponent(x, y) -> float:
    """Least-squares slope of ``log y`` against ``log x``."""
    x, y = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    if x.size < 2:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


# -- memory -------------------------------------------------------------------
def peak_rss_mb() -> float:
    """Peak resident set size of this process so far, MB (getrusage)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _status_kb(pid: int, key: str) -> float | None:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return float(line.split()[1])
    except OSError:
        return None
    return None


def run_inline(module_call: dict) -> dict:
    """Run a :mod:`benchmarks.worker` job in this process (no cap; used by
    ``--quick``, where sizes are tiny and subprocess start-up would dominate)."""
    from .worker import main
    answer = main(json.dumps(module_call))
    answer.update(outcome="ok" if answer.get("ok") else "error",
                  wall=answer.get("total"), returncode=0, stderr_tail=[])
    return answer


def run_capped(module_call: dict, mem_gb: float, timeout: float) -> dict:
    """Run ``benchmarks.worker`` in a subprocess with an address-space cap.

    ``module_call`` is a JSON-able dict for :mod:`benchmarks.worker`. The
    child gets ``RLIMIT_AS = mem_gb`` GiB (an allocation beyond it fails
    inside the child, not on the machine); the parent polls its
    ``VmHWM``/``VmRSS`` in ``/proc`` every 0.2 s and kills it after
    ``timeout`` s. Returns the child's JSON answer (if any) plus
    ``peak_rss_mb`` (from the parent's polling), ``wall``, ``outcome``
    (``'ok'``, ``'timeout'``, ``'memory'`` or ``'error'``).
    """
    cap = int(mem_gb * 2**30)

    def limit():  # runs in the child before exec
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    env = dict(os.environ)
    env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "benchmarks.worker", json.dumps(module_call)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=limit, cwd=ROOT, env=env)
    peak = 0.0
    outcome = None
    while proc.poll() is None:
        hwm = _status_kb(proc.pid, "VmHWM") or _status_kb(proc.pid, "VmRSS")
        if hwm:
            peak = max(peak, hwm / 1024.0)
        if time.perf_counter() - start > timeout:
            proc.kill()
            outcome = "timeout"
            break
        time.sleep(0.2)
    out, err = proc.communicate()
    wall = time.perf_counter() - start
    answer: dict = {}
    for line in out.splitlines()[::-1]:
        if line.startswith("{"):
            try:
                answer = json.loads(line)
                break
            except ValueError:
                pass
    peak = max(peak, float(answer.get("peak_rss_mb", 0.0)))
    if outcome is None:
        if answer.get("ok"):
            outcome = "ok"
        elif "MemoryError" in err or "memory" in (answer.get("error") or "").lower() \
                or "alloc" in err.lower() or proc.returncode in (-6, -9, 134, 137):
            outcome = "memory"
        else:
            outcome = "error"
    answer.update(peak_rss_mb=peak, wall=wall, outcome=outcome,
                  returncode=proc.returncode,
                  stderr_tail=err.strip().splitlines()[-1:] if err.strip() else [])
    return answer


# -- the machine ---------------------------------------------------------------
def machine_info() -> dict:
    import control
    import cvxpy
    import scipy
    info = dict(
        machine=platform.machine(), processor=_cpu_model(),
        cores=os.cpu_count(), memory_gb=_mem_total_gb(),
        system=f"{platform.system()} {platform.release()}",
        python=platform.python_version(), numpy=np.__version__,
        scipy=scipy.__version__, cvxpy=cvxpy.__version__,
        control=control.__version__, loadavg=os.getloadavg())
    for name in ("clarabel", "scs", "cvxopt"):
        try:
            mod = __import__(name)
            info[name] = getattr(mod, "__version__", "?")
        except ImportError:
            info[name] = "not installed"
    try:
        blas = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
        info["blas"] = f"{blas.get('name')} {blas.get('version', '')}".strip()
    except Exception:  # pragma: no cover - informative only
        info["blas"] = "?"
    return info


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def _mem_total_gb() -> float:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError):
        return float("nan")
