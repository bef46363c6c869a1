"""Lifting a periodic system over one period, and the size it may reach.

The StateSpace face of a jump system of period ``N`` is its mean system
lifted over one period (:ref:`theory-jump-system`): inputs and outputs are
stacked time-major and the sampling time is ``N·dt``. This module computes
that lift and refuses a period whose lifted face could not be stored.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

#: Largest lifted face (entries of ``A, B, C, D`` over one period) that a
#: JumpStateSpace builds: 5e7 float64 entries are 400 MB. The block lower
#: triangular ``D`` of size ``N·p × N·m`` is inherent to the lifted face, so a
#: longer period is refused at once rather than after minutes of work.
MAX_LIFTED_ENTRIES = 50_000_000


def lift(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Lift an N-periodic linear system over one period.

    Parameters
    ----------
    A, B, C, D : ndarray, shapes (N, n, n), (N, n, m), (N, p, n), (N, p, m)
        ``x[t+1] = A[k] x[t] + B[k] w[t]``, ``z[t] = C[k] x[t] + D[k] w[t]``,
        ``k = t mod N``.

    Returns
    -------
    AL, BL, CL, DL : ndarray
        The time-invariant system from ``x[jN]`` and the stacked inputs
        ``[w[jN]; w[jN+1]; …; w[jN+N-1]]`` (time-major: all channels of
        phase 0 first) to ``x[(j+1)N]`` and the stacked outputs
        ``[z[jN]; …; z[jN+N-1]]``. Shapes (n, n), (n, N m), (N p, n),
        (N p, N m); ``DL`` is block lower triangular.

    Examples
    --------
    A scalar system with ``A = 2`` at phase 0 and ``A = 0.5`` at phase 1:
    over one period ``x[2] = 0.5 · 2 · x[0] + 0.5 w[0] + w[1]``, and
    ``z[1] = 2 x[0] + w[0]``:

    >>> A = np.array([[[2.0]], [[0.5]]])
    >>> B, C, D = np.ones((2, 1, 1)), np.ones((2, 1, 1)), np.zeros((2, 1, 1))
    >>> AL, BL, CL, DL = ncs.lift(A, B, C, D)
    >>> AL.tolist(), BL.tolist(), CL.tolist(), DL.tolist()
    ([[1.0]], [[0.5, 1.0]], [[1.0], [2.0]], [[0.0, 0.0], [1.0, 0.0]])
    """
    N, n = A.shape[0], A.shape[1]
    m, p = B.shape[2], C.shape[1]
    # phi = A[N-1] ... A[j]: the transition from phase j to the period end
    BL = np.zeros((n, N * m))
    phi = np.eye(n)
    for j in range(N - 1, -1, -1):
        BL[:, j * m:(j + 1) * m] = phi @ B[j]
        phi = phi @ A[j]
    AL = phi
    # CL[k] = C[k] A[k-1] ... A[0]
    CL = np.zeros((N * p, n))
    forward = np.eye(n)
    for k in range(N):
        CL[k * p:(k + 1) * p] = C[k] @ forward
        forward = A[k] @ forward
    # DL[k, j] = C[k] A[k-1] ... A[j+1] B[j] for j < k, D[k] on the diagonal.
    # One sub-diagonal d = k - j at a time, all its blocks at once:
    # G[j] = A[j+d-1] ... A[j+1] B[j], so the Python loop runs N times, not N²/2.
    DL = np.zeros((N, p, N, m))
    phases = np.arange(N)
    DL[phases, :, phases, :] = D
    G = np.asarray(B, float)
    for d in range(1, N):
        first = phases[:N - d]  # the phases j of the blocks (j + d, j)
        if d > 1:
            G = A[first + d - 1] @ G[:N - d]
        else:
            G = G[:N - 1]
        DL[first + d, :, first, :] = C[first + d] @ G
    return AL, BL, CL, DL.reshape(N * p, N * m)


def lifted_size(n: int, m: int, p: int, N: int) -> int:
    """Number of entries of the lifted face ``(AL, BL, CL, DL)``."""
    return n * n + N * n * (m + p) + N * N * p * m


def check_lifted_size(n: int, m: int, p: int, N: int, name: str) -> None:
    """Refuse a period whose lifted face exceeds :data:`MAX_LIFTED_ENTRIES`."""
    size = lifted_size(n, m, p, N)
    if N > 1 and size > MAX_LIFTED_ENTRIES:
        raise ValueError(
            f"{name}: period N = {N} is too long: the lifted mean system "
            f"(n = {n}, {m} inputs, {p} outputs per step) would have "
            f"{size:.3g} entries, more than MAX_LIFTED_ENTRIES = "
            f"{MAX_LIFTED_ENTRIES:.3g} (its D alone is {N * p} x {N * m}); "
            f"use shorter schedules, whose least common multiple sets N")


def lifted_names(names: Sequence[str], N: int) -> list[str]:
    """Signal names of the lifted face: ``'<name>[k]'`` for phase ``k``."""
    if N == 1:
        return list(names)
    return [f"{s}[{k}]" for k in range(N) for s in names]
