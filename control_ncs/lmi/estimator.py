"""The estimator LMIs of :ref:`theory-output-feedback`.

Mean-square detectability of the lossy, scheduled sensor link, Bernoulli or
bursty, with the estimator gain as a change of variables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import cvxpy as cp


# -- estimator gain (theory: output feedback) ---------------------------------
@dataclass
class EstimatorModel:
    """The estimator LMI of :ref:`theory-output-feedback` over one period,
    before its solve.

    Attributes
    ----------
    problem : cvxpy.Problem
    P, Z : list of cvxpy.Variable
        ``P_k`` (n × n, symmetric) and ``Z_k = P_k L_k`` (n × p2), per phase.
    """

    problem: cp.Problem
    P: list
    Z: list


def estimator_model(A: np.ndarray, C2: np.ndarray, S1: np.ndarray,
                    loss: float, decay: float = 1.0,
                    margin: float = 1e-6) -> EstimatorModel:
    """Mean-square detectability LMI of the lossy, scheduled sensor link.

    For every phase ``k`` (``j = k + 1 mod N``), with ``Mθ = (I - θ L_j Σ1,j
    C2) A`` and ``Z_j = P_j L_j``, ``Σ_θ p_θ Mθᵀ P_j Mθ ≺ r² P_k`` is, by a
    Schur complement, ``[[r² P_k, *, *], [√α1 P_j A, P_j, 0],
    [√(1-α1) (P_j - Z_j Σ1,j C2) A, 0, P_j]] ≻ 0``
    (:ref:`theory-output-feedback`). The LMI is homogeneous in ``(P, Z)``: it
    is normalised by ``P_k ⪰ I`` and imposed with the margin ``margin · s``
    (``s`` the scale of ``A``); the objective ``t ⪰ P_k`` keeps the certificate
    well conditioned.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C2 : ndarray, shape (p2, n)
    S1 : ndarray, shape (N, p2, p2)
        Sensor selections ``Σ1,k`` per phase.
    loss : float
        ``α1``, the sensor link's loss probability (Bernoulli).
    decay : float
        ``r`` in ``(0, 1]``.
    margin : float
        Relative strictness margin.

    Returns
    -------
    EstimatorModel
    """
    n, N = A.shape[0], S1.shape[0]
    p2 = C2.shape[0]
    P = [cp.Variable((n, n), symmetric=True) for _ in range(N)]
    Z = [cp.Variable((n, p2)) for _ in range(N)]
    t = cp.Variable()
    eps = margin * max(1.0, float(np.linalg.norm(A, 2)) ** 2)
    cons = []
    for k in range(N):
        j = (k + 1) % N
        rows = []
        if loss > 0:
            rows.append(np.sqrt(loss) * (P[j] @ A))
        if loss < 1:
            rows.append(np.sqrt(1 - loss) * ((P[j] - Z[j] @ S1[j] @ C2) @ A))
        size = len(rows)
        blocks = [[decay ** 2 * P[k]] + [r.T for r in rows]]
        for i, r in enumerate(rows):
            blocks.append([r] + [P[j] if i == c else np.zeros((n, n))
                                 for c in range(size)])
        M = cp.bmat(blocks)
        # cvxpy needs the symmetry said out loud
        cons.append(0.5 * (M + M.T) >> eps * np.eye(n * (size + 1)))
        cons += [P[k] >> np.eye(n), P[k] << t * np.eye(n)]
    return EstimatorModel(cp.Problem(cp.Minimize(t), cons), P, Z)


def markov_estimator_model(A: np.ndarray, C2: np.ndarray, S1: np.ndarray,
                           transition: np.ndarray, decay: float = 1.0,
                           margin: float = 1e-6) -> EstimatorModel:
    """The estimator LMI over a bursty (Markov) sensor link; exact.

    The error loop ``e_{k+1} = (I - θ_{k+1} L_{k+1} Σ1,k+1 C2) A e_k`` is a
    Markov jump system whose mode at step ``k`` is ``i = θ_{k+1}`` (the link
    moves at every step, scheduled or not: :ref:`theory-markov`). It is
    mean-square stable (within ``r²``) iff storages ``P_{k,i} ≻ 0`` exist
    with ``M_iᵀ E_{k,i} M_i ≺ r² P_{k,i}``, ``E_{k,i} = Σ_j T[i, j]
    P_{k+1,j}``, ``M_0 = A`` and ``M_1 = (I - L_{k+1} Σ C2) A``. The gain
    enters the arrived mode only, so ``Z_k = E_{k,1} L_{k+1}`` makes the
    condition an LMI without loss (:ref:`theory-output-feedback`): one gain
    per phase is optimal. Normalised by ``P ⪰ I`` with the margin
    ``margin · s``, as :func:`estimator_model`.

    Parameters
    ----------
    A, C2, S1, decay, margin
        As for :func:`estimator_model`.
    transition : ndarray, shape (2, 2)
        The sensor link's ``T[a, b] = P(θ⁺ = b | θ = a)``, order (lost,
        arrived).

    Returns
    -------
    EstimatorModel
        ``P[k]`` is the pair ``[P_{k,0}, P_{k,1}]``; ``Z[k]`` gives
        ``L_{k+1} = E_{k,1}⁻¹ Z_k``.
    """
    n, N = A.shape[0], S1.shape[0]
    p2 = C2.shape[0]
    T = np.asarray(transition, float)
    P = [[cp.Variable((n, n), symmetric=True) for _ in range(2)]
         for _ in range(N)]
    Z = [cp.Variable((n, p2)) for _ in range(N)]
    t = cp.Variable()
    eps = margin * max(1.0, float(np.linalg.norm(A, 2)) ** 2)
    cons = []
    for k in range(N):
        j = (k + 1) % N
        E = [T[i, 0] * P[j][0] + T[i, 1] * P[j][1] for i in range(2)]
        lost = decay ** 2 * P[k][0] - A.T @ E[0] @ A
        cons.append(0.5 * (lost + lost.T) >> eps * np.eye(n))
        M = (E[1] - Z[k] @ S1[j] @ C2) @ A
        block = cp.bmat([[decay ** 2 * P[k][1], M.T], [M, E[1]]])
        cons.append(0.5 * (block + block.T) >> eps * np.eye(2 * n))
        for i in range(2):
            cons += [P[k][i] >> np.eye(n), P[k][i] << t * np.eye(n)]
    return EstimatorModel(cp.Problem(cp.Minimize(t), cons), P, Z)
