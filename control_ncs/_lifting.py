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


#: The PBH tests' rank tolerance: ``[Φ − λI; O]`` is called rank-deficient
#: only when its smallest singular value is below this times its largest,
#: so that rounding never declares a mode unseen (or unreached) that a
#: scheduled sensor (or actuator) sees (or reaches).
PBH_RTOL = 1e-9


def unseen_modes(A: np.ndarray, outputs: Sequence[np.ndarray]) -> list:
    """Eigenvalues ``|λ| ≥ 1`` of ``A^N`` that periodic outputs never see.

    The PBH test of the lifted pair: ``x_{k+1} = A x_k`` observed through
    ``outputs[k] x_k`` for ``k = 0..N-1`` is, over one period, the pair
    ``(Φ, O) = (A^N, [C_0; C_1 A; …; C_{N-1} A^{N-1}])``; a mode ``λ`` of
    ``Φ`` is unseen when ``[Φ − λI; O]`` loses rank. Applied to
    ``(Aᵀ, (B_{N-1-j})ᵀ)`` it finds the modes that periodic inputs
    ``B_k u_k`` never reach (stabilisability through a schedule).

    Parameters
    ----------
    A : ndarray, shape (n, n)
    outputs : sequence of ndarray, each of shape (p_k, n)
        The output matrix at each phase of the period ``N = len(outputs)``.

    Returns
    -------
    list of complex
        The unseen eigenvalues on or outside the unit circle (empty:
        detectable).
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    rows, Ak = [], np.eye(n)
    for C in outputs:
        rows.append(np.asarray(C, float) @ Ak)
        Ak = A @ Ak
    Phi, O = Ak, np.vstack(rows)
    bad = []
    for lam in np.linalg.eigvals(Phi):
        if abs(lam) < 1 - 1e-12:
            continue
        s = np.linalg.svd(np.vstack([Phi - lam * np.eye(n), O]),
                          compute_uv=False)
        if s[n - 1] <= PBH_RTOL * max(1.0, s[0]):
            bad.append(complex(lam))
    return bad
