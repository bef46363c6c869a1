"""Exact, solver-independent checks of passivity and stability certificates.

A solver's status is not a proof (:ref:`theory-synthesis`). Every verdict the
library returns is re-checked here with plain linear algebra on the
*closed-loop* jump system: the eigenvalues of the dissipation matrices ``Θ_k``
of :ref:`theory-passivity` for the certificate ``P_k``, the eigenvalues of
``P_k`` themselves, and the spectral radius of the second-moment operator
(:ref:`theory-mss`). The figures are kept on a :class:`Certificate`.

One algebra kernel serves every route: :func:`dissipation_blocks` (``Θ_k``
of one phase from raw per-mode arrays), :func:`ifp_supremum` (the Schur
complement that gives the largest certified ``η``) and
:func:`feedthrough_bound` (the necessary condition ``D̄ + D̄ᵀ ≻ 2ηI``). The
public functions check their arguments once and call them.
:class:`CertificationError` and :class:`SynthesisError` live in
:mod:`control_ncs.exceptions` and are re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from control.exception import ControlDimension

from ._checks import decay_bound, finite_real, real_array
from .exceptions import CERTIFIED, NOT_VERIFIED
from ._results import Result
from .jump import JumpStateSpace, as_jump
from .modes import Modes
from .stability import ms_radius

__all__ = ["Certificate", "dissipation_matrices", "certified_index",
           "check_certificate", "certify_index", "certify_ofp_index",
           "dissipation_blocks", "ifp_supremum", "feedthrough_bound",
           "supply_rows", "supply_feedthrough_bound"]

#: Relative back-offs below a certificate's supremum, tried in turn: the Schur
#: complement loses accuracy near the ms boundary, and a re-check needs room.
INDEX_BACKOFFS = (1e-6, 1e-5, 1e-4)


def _float_margin(M: np.ndarray) -> float:
    """Rounding error bound of a symmetric eigenvalue computation.

    LAPACK's symmetric eigensolvers are backward stable: computed eigenvalues
    are exact for a matrix within ``c·n·eps·‖M‖₂`` of ``M``. A sign is only
    claimed when the eigenvalue clears this bound.
    """
    return 16 * M.shape[0] * np.finfo(float).eps * max(np.linalg.norm(M, 2), 1e-300)


# -- the one algebra kernel (raw arrays, no checks) ---------------------------
def supply_blocks(probabilities: np.ndarray, A: np.ndarray, B: np.ndarray,
                  C: np.ndarray, D: np.ndarray, P: np.ndarray,
                  P_next: np.ndarray, Q: Any, S: Any, R: Any, *,
                  decay: float = 1.0) -> np.ndarray:
    """``Θ_k`` of one phase for any quadratic supply: the one kernel.

    (:ref:`theory-performance`.) The supply
    ``s(w, z) = zᵀQz + 2 zᵀSw + wᵀRw`` and the storage ``V = ξᵀPξ``:
    ``E V(ξ⁺) - r² V(ξ) < E s(w, z)`` reads ``[ξ; w]ᵀ Θ [ξ; w] < 0`` with::

        Θ = Σ_i p_i ([A_i B_i]ᵀ P⁺ [A_i B_i] - [C_i D_i]ᵀ Q [C_i D_i])
            - [[r² P, C̄ᵀ S], [Sᵀ C̄, D̄ᵀ S + Sᵀ D̄ + R]]

    ``C̄ = Σ p_i C_i``, ``D̄ = Σ p_i D_i``: the cross term is linear in
    ``z``, so its expectation takes the mean output matrices; the
    quadratic one takes every mode's own. Passivity with dissipation
    ``η`` and output-feedback level ``ρ`` is ``Q = -2ρI, S = I,
    R = -2ηI`` (:func:`dissipation_blocks`); the ℓ2 gain ``γ`` is
    ``Q = -I, S = 0, R = γ²I``. Internal callers
    only (no argument checked).

    Parameters
    ----------
    probabilities : ndarray, shape (M,)
        The mode law of the phase (or of the supply row).
    A, B, C, D : ndarray
        Per-mode matrices, shapes (M, n, n), (M, n, m), (M, p, n), (M, p, m).
    P, P_next : ndarray
        ``P_k`` (n, n) and ``P_{k+1}`` ((n, n), or (M, n, n) per next mode).
    Q, S, R : float or ndarray
        The supply's weights; a number stands for that multiple of ``I``.
    decay : float, optional
        Decay bound ``r`` (1: none).

    Returns
    -------
    ndarray, shape (n + m, n + m)
        Symmetric.

    Examples
    --------
    ``x⁺ = 0.5x + w``, ``z = x``, ``P = 2``, the ℓ2-gain supply with
    ``γ² = 5``:

    >>> from control_ncs.verify import supply_blocks
    >>> A, B, C, D = (np.array([[[x]]]) for x in (0.5, 1.0, 1.0, 0.0))
    >>> supply_blocks([1.0], A, B, C, D, 2 * np.eye(1), 2 * np.eye(1),
    ...               -1.0, 0.0, 5.0).tolist()
    [[-0.5, 1.0], [1.0, -3.0]]
    """
    p = np.asarray(probabilities, float)
    n, m = A.shape[-1], B.shape[-1]
    F = np.concatenate([A, B], axis=2)               # (M, n, n + m)
    # Σ_i p_i F_iᵀ P F_i as batched matrix products (BLAS): a plain
    # 4-operand einsum loops in C without BLAS (0.7 s at n = 64).
    T = np.tensordot(p, F.transpose(0, 2, 1) @ (P_next @ F), axes=1)
    T[:n, :n] -= decay ** 2 * P
    if np.ndim(Q) or Q != 0.0:
        H = np.concatenate([C, D], axis=2)           # (M, p, n + m)
        QH = Q * H if np.ndim(Q) == 0 else np.asarray(Q) @ H
        T -= np.tensordot(p, H.transpose(0, 2, 1) @ QH, axes=1)
    if np.ndim(S) or S != 0.0:
        Cbar, Dbar = np.tensordot(p, C, axes=1), np.tensordot(p, D, axes=1)
        CS = S * Cbar.T if np.ndim(S) == 0 else Cbar.T @ np.asarray(S)
        DS = S * Dbar if np.ndim(S) == 0 else Dbar.T @ np.asarray(S)
        T[:n, n:] -= CS
        T[n:, :n] -= CS.T
        T[n:, n:] -= DS + DS.T
    T[n:, n:] -= R * np.eye(m) if np.ndim(R) == 0 else np.asarray(R)
    return 0.5 * (T + T.T)


def dissipation_blocks(probabilities: np.ndarray, A: np.ndarray,
                       B: np.ndarray, C: np.ndarray, D: np.ndarray,
                       P: np.ndarray, P_next: np.ndarray, eta: float, *,
                       ofp_index: float = 0.0, decay: float = 1.0
                       ) -> np.ndarray:
    """``Θ_k`` of one phase from raw per-mode arrays.

    (:ref:`theory-passivity`, :ref:`theory-jump-system`.)

    The dissipation inequality ``E V(ξ⁺) - r² V(ξ) < E s(w, z)`` for
    ``V(ξ) = ξᵀPξ`` and the supply rate ``s = 2wᵀz - 2ρ zᵀz - 2η wᵀw``
    (``ρ = ofp_index``) reads ``[ξ; w]ᵀ Θ [ξ; w] < 0`` with::

        Θ = Σ_i p_i [A_i B_i]ᵀ P⁺ [A_i B_i] - [[r² P, C̄ᵀ], [C̄, D̄ + D̄ᵀ - 2ηI]]
            + 2ρ Σ_i p_i [C_i D_i]ᵀ [C_i D_i]

    ``C̄ = Σ p_i C_i``, ``D̄ = Σ p_i D_i``: ``wᵀz`` is linear in ``z``, so
    its expectation takes the mean output matrices; ``zᵀz`` is quadratic,
    so its expectation takes every mode's own. No argument is checked
    (internal callers only; the public functions check theirs).

    Parameters
    ----------
    probabilities : ndarray, shape (M,)
        Mode probabilities ``p_i`` of the phase.
    A, B, C, D : ndarray, shapes (M, n, n), (M, n, m), (M, m, n), (M, m, m)
        Per-mode matrices of the phase.
    P, P_next : ndarray, shape (n, n)
        ``P_k`` and ``P_{k+1}``.
    eta : float
        Input-feedforward level ``η``.
    ofp_index : float, optional
        Output-feedback level ``ρ``.
    decay : float, optional
        Decay bound ``r`` (1: none).

    Returns
    -------
    ndarray, shape (n + m, n + m)
        Symmetric.

    Examples
    --------
    One mode, ``G(z) = 1 + 1/(z - 0.5)``, ``P = 1``, as
    :func:`dissipation_matrices` gives it:

    >>> from control_ncs.verify import dissipation_blocks
    >>> A, B, C, D = (np.array([[[x]]]) for x in (0.5, 1.0, 1.0, 1.0))
    >>> dissipation_blocks([1.0], A, B, C, D, np.eye(1), np.eye(1), 0.0).tolist()
    [[-0.75, -0.5], [-0.5, -1.0]]
    """
    return supply_blocks(probabilities, A, B, C, D, P, P_next,
                         -2.0 * ofp_index, 1.0, -2.0 * eta, decay=decay)


def supply_certificate_check(sys: Any, P: Any, Q: Any, S: Any, R: Any, *,
                             decay: float = 1.0
                             ) -> tuple[bool, np.ndarray, np.ndarray]:
    """Exact check of a storage ``P_k`` (``P_{k,ℓ}``) for a quadratic supply.

    Returns ``(verified, λmax(Θ) per phase and row, λmin(P))``: verified
    when every ``Θ`` of :func:`supply_blocks` is ``≺ 0`` and every ``P ≻ 0``
    beyond rounding.
    """
    sys = as_jump(sys)
    P = _certificate_array(P, sys)
    m, N = sys.modes, sys.period
    rows = supply_rows(m)
    thetas = []
    for k in range(N):
        Pn = P[(k + 1) % N]
        P_next = Pn[0] if m.is_iid else Pn
        thetas += [supply_blocks(t, m.A[k], m.B[k], m.C[k], m.D[k], P[k, l],
                                 P_next, Q, S, R, decay=decay)
                   for l, t in enumerate(rows[k])]
    theta_max = np.array([np.linalg.eigvalsh(T).max() for T in thetas])
    flat = P.reshape((-1,) + P.shape[2:])
    P_min = np.array([np.linalg.eigvalsh(Pk).min() for Pk in flat])
    ok = all(t < -_float_margin(T) for t, T in zip(theta_max, thetas)) and \
        all(v > _float_margin(Pk) for v, Pk in zip(P_min, flat))
    return bool(ok), theta_max, P_min


def gain_certificate_check(sys: Any, P: Any, gamma: float
                           ) -> tuple[bool, np.ndarray, np.ndarray]:
    """Exact check of an ℓ2-gain certificate (:func:`supply_certificate_check`
    with ``Q = -I, S = 0, R = γ² I``): verified, it proves the loop's ℓ2
    gain (inputs adapted to the past, from rest) below ``gamma`` and the
    loop mean-square stable."""
    return supply_certificate_check(sys, P, -1.0, 0.0, float(gamma) ** 2)


def ifp_supremum(theta0: np.ndarray, n: int) -> float:
    """Supremum of ``η`` with ``Θ(η) = theta0 + 2η diag(0, I) ≺ 0``.

    ``Θ(η) ≺ 0`` iff its ``(1,1)`` block ``M11 ≺ 0`` and
    ``2η < -λmax(M22 - M21 M11⁻¹ M12)`` (Schur complement). Returns
    ``-inf`` when ``M11`` is not negative definite beyond rounding (no
    ``η`` works). Strict: every ``η`` below the value works, the value
    itself does not.

    Parameters
    ----------
    theta0 : ndarray, shape (n + m, n + m)
        ``Θ`` at ``η = 0`` (:func:`dissipation_blocks`).
    n : int
        Size of the state block.

    Returns
    -------
    float
        The supremum; ``-inf`` if no ``η`` works.

    Examples
    --------
    ``Θ`` of :func:`dissipation_blocks`' example: the Schur complement is
    ``-1 - 0.25/(-0.75) = -2/3``, so ``η < 1/3``:

    >>> from control_ncs.verify import ifp_supremum
    >>> round(ifp_supremum(np.array([[-0.75, -0.5], [-0.5, -1.0]]), 1), 12)
    0.333333333333
    """
    M11, M12, M22 = theta0[:n, :n], theta0[:n, n:], theta0[n:, n:]
    if n and np.linalg.eigvalsh(M11).max() >= -_float_margin(M11):
        return -np.inf
    S = M22 - M12.T @ np.linalg.solve(M11, M12) if n else M22
    return float(-np.linalg.eigvalsh(0.5 * (S + S.T)).max() / 2)


def feedthrough_bound(probabilities: np.ndarray, D: np.ndarray, *,
                      ofp_index: float = 0.0) -> tuple[float, int]:
    """The necessary feedthrough condition, as a bound on ``η``.

    (:ref:`theory-passivity`.)

    ``Θ_k ≺ 0`` needs its ``(2,2)`` block negative, hence
    ``D̄_k + D̄_kᵀ - 2ρ Σ_i p_i D_iᵀD_i ≻ 2ηI`` at every phase (``ρ = 0``:
    ``D̄ + D̄ᵀ ≻ 2ηI``, the paper's Assumption 1 at ``η = 0``). Every
    certifiable ``η`` lies strictly below the returned bound.

    Parameters
    ----------
    probabilities : ndarray, shape (N, M) or (M,)
        Mode probabilities per phase (one phase if 1-D).
    D : ndarray, shape (N, M, m, m) or (M, m, m)
        Per-mode feedthrough matrices.
    ofp_index : float, optional
        Output-feedback level ``ρ``.

    Returns
    -------
    bound : float
        ``min_k λmin(D̄_k + D̄_kᵀ - 2ρ Σ_i p_ki D_kiᵀ D_ki) / 2``.
    phase : int
        The phase ``k`` attaining it.

    Examples
    --------
    A feedthrough ``D = 1`` lost with probability 0.1 (``D̄ = 0.9``):

    >>> from control_ncs.verify import feedthrough_bound
    >>> feedthrough_bound([0.9, 0.1], np.array([[[1.0]], [[0.0]]]))
    (0.9, 0)
    """
    p = np.asarray(probabilities, float).reshape(-1, D.shape[-3])
    D = np.asarray(D, float).reshape(p.shape + D.shape[-2:])
    Dbar = np.einsum("km,kmij->kij", p, D)
    S = Dbar + Dbar.transpose(0, 2, 1)
    if ofp_index != 0.0:
        S = S - 2 * ofp_index * np.einsum("km,kmji,kmjl->kil", p, D, D)
    lam = np.linalg.eigvalsh(S)[:, 0] / 2
    k = int(np.argmin(lam))
    return float(lam[k]), k


#: Levels further below the feedthrough bound (in data scales) are checked at
#: that floor: lower ones swamp Θ in double precision (Θ(η) ≼ Θ(η0)).
LEVEL_FLOOR = 1e6


def level_floor(bound: float, *mats: np.ndarray) -> float:
    """The lowest level ``η0`` solved and checked for a requested ``η``.

    ``Θ(η) = Θ(η0) + 2(η - η0) diag(0, I) ≼ Θ(η0)`` for ``η ≤ η0``: a
    certificate at ``η0`` certifies every lower ``η`` exactly
    (:ref:`theory-passivity`). Callers solve at ``max(η, level_floor(...))``
    and return ``η``.

    Parameters
    ----------
    bound : float
        The feedthrough bound (:func:`feedthrough_bound`).
    *mats : ndarray
        The data; their largest spectral norm (at least 1) is the scale.

    Returns
    -------
    float
        ``bound - LEVEL_FLOOR * max(1, |bound|, scale)``.

    Examples
    --------
    >>> from control_ncs.verify import level_floor
    >>> level_floor(0.5, np.eye(2))
    -999999.5
    """
    scale = max([1.0, abs(bound)] + [
        float(np.linalg.norm(M.reshape(-1, M.shape[-1]), 2))
        for M in mats if M.size])
    return bound - LEVEL_FLOOR * scale


# -- public checks --------------------------------------------------------------
def square_system(sys: Any, name: str = "sys") -> JumpStateSpace:
    """``sys`` as a square jump system (a TransferFunction via control.ss).

    i.i.d. and Markov modes alike: the dissipation matrices are
    :ref:`theory-passivity`'s ``Θ_k`` for i.i.d. modes and
    :ref:`theory-markov`'s ``Θ_{k,ℓ}`` for a chain (see
    :func:`supply_rows`).
    """
    sys = as_jump(sys, name)
    m, p = sys.modes.B.shape[-1], sys.modes.C.shape[-2]
    if m != p:
        raise ControlDimension(f"{name}: passivity needs as many inputs as "
                               f"outputs (w and z of equal size), got {m} "
                               f"inputs and {p} outputs")
    return sys


def supply_rows(modes: Modes) -> np.ndarray:
    """The mode law each dissipation inequality averages, per phase.

    A storage ``V = ξᵀ P ξ`` may depend on what is known before the mode
    is drawn. For i.i.d. modes that is nothing new: one inequality per
    phase, averaged with ``p_k`` (:ref:`theory-passivity`,
    :ref:`theory-jump-system`). For Markov modes it is the previous mode
    ``ℓ = σ_{k-1}``: one inequality per ``(k, ℓ)``, averaged with the row
    ``t = T_{k-1}[ℓ, ·]`` (:ref:`theory-markov`, ``Θ_{k,ℓ}`` with ``P_{k,ℓ}``
    and ``P_{k+1,i}`` per next mode). Every ``ℓ`` is kept, so a certificate
    covers any initial mode.

    Parameters
    ----------
    modes : Modes
        A jump system's modes (``sys.modes``).

    Returns
    -------
    ndarray, shape (N, L, M)
        ``rows[k, ℓ]``: the law of the mode at phase ``k``; ``L = 1`` for
        i.i.d. modes, ``L = M`` for Markov modes.

    Examples
    --------
    A bursty chain (stay lost with probability 0.75) and its i.i.d.
    counterpart with the same marginals:

    >>> from control_ncs.verify import supply_rows
    >>> chain = ncs.jss([[[0.5]], [[2.0]]], [[1.0]], [[1.0]], [[1.0]],
    ...                    transition=[[0.9, 0.1], [0.25, 0.75]])
    >>> supply_rows(chain.modes).tolist()
    [[[0.9, 0.1], [0.25, 0.75]]]
    >>> p = chain.modes.probabilities
    >>> iid = ncs.jss(chain.modes.A, [[1.0]], [[1.0]], [[1.0]], p[0])
    >>> supply_rows(iid.modes).round(6).tolist()
    [[[0.714286, 0.285714]]]
    """
    if modes.is_iid:
        return modes.probabilities[:, None, :]
    return np.roll(modes.transitions(), 1, axis=0)


def supply_feedthrough_bound(sys: JumpStateSpace, ofp_index: float = 0.0
                             ) -> float:
    """The feedthrough bound of a jump system, over its supply rows.

    Markov modes average the feedthrough with each row ``T_{k-1}[ℓ, ·]``
    (:ref:`theory-markov`: ``H̄ = Σ t_i H_{k,i}``), i.i.d. modes with ``p_k``.

    Parameters
    ----------
    sys : JumpStateSpace
    ofp_index : float, optional
        Output-feedback level ``ρ``.

    Returns
    -------
    float
        Every certifiable ``η`` lies strictly below it.

    Examples
    --------
    >>> from control_ncs.verify import supply_feedthrough_bound
    >>> G = ncs.jss([[[0.5]], [[0.5]]], [[1.0]], [[1.0]],
    ...                [[[1.0]], [[0.0]]], transition=[[0.9, 0.1], [0.5, 0.5]])
    >>> supply_feedthrough_bound(G)           # row ℓ = 1: D̄ = 0.5
    0.5
    """
    rows = supply_rows(sys.modes)
    N, L, M = rows.shape
    D = np.repeat(sys.modes.D[:, None], L, axis=1)
    bound, _ = feedthrough_bound(rows.reshape(N * L, M),
                                 D.reshape((N * L,) + D.shape[2:]),
                                 ofp_index=ofp_index)
    return bound


def _certificate_array(P: Any, sys: JumpStateSpace) -> np.ndarray:
    """``P`` as a symmetric (N, L, n, n) stack, or a named error.

    ``L = 1`` for i.i.d. modes (``P_k``: shapes (N, n, n) or (n, n));
    ``L = M`` for Markov modes (``P_{k,ℓ}`` per previous mode ``ℓ``:
    shape (N, M, n, n); (N, n, n) or (n, n) give every ``ℓ`` the same).
    """
    n, N, M = sys.modes.A.shape[-1], sys.period, sys.modes.count
    markov = not sys.modes.is_iid
    given = np.shape(P)
    P = real_array(P, "P", ndim=(2, 3, 4) if markov else (2, 3))
    if P.ndim == 2:
        P = P[None]
    if P.ndim == 3:
        # one P_k per phase (Markov: the same for every previous mode)
        P = P[:, None]
    if P.shape[0] == 1 and N > 1:
        P = np.repeat(P, N, axis=0)
    if markov and P.shape[1] == 1 and P.ndim == 4:
        P = np.repeat(P, M, axis=1)
    if P.shape != (N, M if markov else 1, n, n):
        want = (f"({N}, {M}, {n}, {n}) (P_k,ℓ per phase k and previous mode "
                f"ℓ: Markov modes, theory: Markov losses), ({N}, {n}, {n})" if markov else
                f"({N}, {n}, {n}) (one P_k per phase)")
        raise ControlDimension(f"P: expected shape {want} or ({n}, {n}), "
                               f"got {given}")
    return 0.5 * (P + P.swapaxes(-1, -2))


def _public(P: np.ndarray, sys: JumpStateSpace) -> np.ndarray:
    """The (N, L, ...) stack as the user sees it: (N, ...) for i.i.d. modes."""
    return P[:, 0] if sys.modes.is_iid else P


def _levels(eta: Any, decay: Any, ofp_index: Any
            ) -> tuple[float, float, float]:
    # finite_real without allow_none never returns None
    return (finite_real(eta, "eta"), decay_bound(decay),
            finite_real(ofp_index, "ofp_index"))


def _thetas(sys: JumpStateSpace, P: np.ndarray, eta: float, rho: float,
            decay: float) -> list[np.ndarray]:
    """``Θ_{k,ℓ}`` for every phase and supply row, phase-major."""
    m, N = sys.modes, sys.period
    rows = supply_rows(m)
    out = []
    for k in range(N):
        Pn = P[(k + 1) % N]
        # i.i.d.: one P_{k+1}; Markov: P_{k+1,i} per next mode i (theory:
        # Markov losses)
        P_next = Pn[0] if m.is_iid else Pn
        out += [dissipation_blocks(t, m.A[k], m.B[k], m.C[k], m.D[k],
                                   P[k, l], P_next, eta, ofp_index=rho,
                                   decay=decay)
                for l, t in enumerate(rows[k])]
    return out


def _sup(sys: JumpStateSpace, P: np.ndarray, rho: float, decay: float
         ) -> float:
    n = sys.modes.A.shape[-1]
    return float(min(ifp_supremum(T, n)
                     for T in _thetas(sys, P, 0.0, rho, decay)))


def dissipation_matrices(sys: Any, P: Any, eta: float, *,
                         decay: float = 1.0, ofp_index: float = 0.0
                         ) -> list[np.ndarray]:
    """The matrices ``Θ_k`` of a closed-loop jump system.

    (:ref:`theory-passivity`.)

    ``Θ_k = Σ_i p_i [A_i B_i]ᵀ P_{k+1} [A_i B_i]
    + [[-r² P_k, -C̄ᵀ], [-C̄, 2ηI - D̄ - D̄ᵀ]]
    + 2ρ Σ_i p_i [C_i D_i]ᵀ [C_i D_i]`` with ``C̄ = Σ p_i C_i``,
    ``D̄ = Σ p_i D_i`` (the supply rate ``2wᵀz - 2ρzᵀz - 2ηwᵀw`` is linear
    in ``z`` but for its ``ρ`` term) and ``r`` the decay bound (``r = 1``:
    none); see :func:`dissipation_blocks`. ``Θ_k ≺ 0`` for all ``k``, with
    ``P_k ≻ 0`` and mean-square stability, certifies strict stochastic
    passivity with these indices (for ``ρ ≥ 0`` its ``(1,1)`` block is
    Lemma 1, so mean-square stability follows, with ``E V`` decaying at
    least like ``r^(2t)``).

    Markov modes (:ref:`theory-markov`): one ``Θ_{k,ℓ}`` per phase ``k`` and
    previous mode ``ℓ``, with ``P_{k,ℓ}`` in place of ``P_k``, ``P_{k+1,i}``
    per next mode in the quadratic term, and the row ``t = T_{k-1}[ℓ, ·]`` in
    place of ``p`` (:func:`supply_rows`); ``P`` then has shape (N, M, n, n).

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
        Square.
    P : array_like, shape (N, n, n), (N, M, n, n) or (n, n)
        ``P_k`` per phase (symmetrised before use).
    eta : float
        Input-feedforward level ``η``.
    decay : float, optional
        Decay bound ``r`` in (0, 1].
    ofp_index : float, optional
        Output-feedback level ``ρ`` (default 0).

    Returns
    -------
    list of ndarray, each (n + m, n + m)
        Phase-major: ``Θ_0, Θ_1, ...`` (Markov: ``Θ_{0,0}, Θ_{0,1}, ...``).

    Raises
    ------
    ControlArgument
        If ``sys`` is not a system.
    ControlDimension
        If ``sys`` is not square or ``P`` has the wrong shape.
    ValueError
        If ``P``, ``eta`` or ``ofp_index`` is not finite and real, or
        ``decay`` is not in (0, 1].

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> [T.round(2).tolist() for T in ncs.verify.dissipation_matrices(G, [[1.0]], 0.0)]
    [[[-0.75, -0.5], [-0.5, -1.0]]]
    """
    sys = square_system(sys)
    eta, decay, rho = _levels(eta, decay, ofp_index)
    return _thetas(sys, _certificate_array(P, sys), eta, rho, decay)


def certified_index(sys: Any, P: Any, *, decay: float = 1.0,
                    ofp_index: float = 0.0) -> float:
    """Largest ``η`` that the certificate ``P`` proves, exactly.

    ``Θ_k`` depends on ``η`` through ``2η diag(0, I)`` only, so the
    supremum of certified ``η`` is ``min_k`` of :func:`ifp_supremum`
    (a Schur complement). Strict inequality: every ``η`` below the
    returned value is certified, the value itself is not.

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
    P : array_like, shape (N, n, n), (N, M, n, n) or (n, n)
    decay : float, optional
        Decay bound ``r`` in (0, 1].
    ofp_index : float, optional
        Output-feedback level ``ρ`` held fixed (default 0).

    Returns
    -------
    float
        ``-inf`` when some ``M11`` is not negative definite (``P`` proves
        nothing).

    Raises
    ------
    ControlArgument, ControlDimension, ValueError
        As :func:`dissipation_matrices`.

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(ncs.verify.certified_index(G, [[1.0]]), 6)  # the index 1/3, at P = 1
    0.333333
    """
    sys = square_system(sys)
    _, decay, rho = _levels(0.0, decay, ofp_index)
    return _sup(sys, _certificate_array(P, sys), rho, decay)


@dataclass(repr=False)
class Certificate(Result):
    """Exact verification figures of a passivity certificate.

    Attributes
    ----------
    verified : bool
        All checks passed.
    eta : float
        Input-feedforward level ``η`` checked.
    decay : float
        Decay bound ``r`` checked (1 = none).
    P : ndarray, shape (N, n, n), or (N, M, n, n) for Markov modes
        The certificate ``P_k`` (Markov: ``P_{k,ℓ}`` per previous mode).
    theta_max : ndarray, shape (N,), or (N, M) for Markov modes
        ``λmax(Θ_k)`` (``λmax(Θ_{k,ℓ})``); must be < 0.
    P_min : ndarray, shape (N,), or (N, M) for Markov modes
        ``λmin(P_k)`` (``λmin(P_{k,ℓ})``); must be > 0.
    ms_radius : float
        Per-step spectral radius of the second-moment operator
        (:ref:`theory-mss`), computed independently of ``P``; must be < 1, and
        ``< r²`` with a decay bound (``E‖ξ‖²`` decays like ``r^(2t)``).
    eta_sup : float
        Supremum of the ``η`` certified by ``P`` at this ``ofp_index``
        (:func:`certified_index`).
    failures : list of str
        What failed, in words.
    ofp_index : float
        Output-feedback level ``ρ`` checked (0: none).

    See Also
    --------
    check_certificate, certify_index, certify_ofp_index : produce one.

    Examples
    --------
    ``G(z) = 1 + 1/(z - 0.5)`` with ``P = 1`` proves every ``η < 1/3``:

    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> cert = ncs.verify.check_certificate(G, [[1.0]], 0.3)
    >>> cert.verified, cert.failures
    (True, [])
    >>> cert.theta_max.round(4).tolist(), round(cert.eta_sup, 6)
    ([-0.0453], 0.333333)
    >>> ncs.verify.check_certificate(G, [[1.0]], 0.4).failures
    ['λmax(Θ_k) = 9.564e-02 is not < 0']
    """

    verified: bool
    eta: float
    decay: float
    P: np.ndarray
    theta_max: np.ndarray
    P_min: np.ndarray
    ms_radius: float
    eta_sup: float
    failures: list[str] = field(default_factory=list)
    ofp_index: float = 0.0

    _repr_fields = ("eta", "eta_sup", "ms_radius")

    @property
    def success(self) -> bool:
        """``verified``: every exact check passed."""
        return self.verified

    @property
    def status(self) -> str:
        """``'certified'`` or ``'not_verified'``."""
        return CERTIFIED if self.verified else NOT_VERIFIED

    @property
    def message(self) -> str:
        """One sentence: what was proven, or the first failure."""
        if self.verified:
            return (f"verified: P proves stochastic passivity at eta = "
                    f"{self.eta:.6g} (every eta < {self.eta_sup:.6g})")
        return "not verified: " + "; ".join(self.failures)

    def _details(self) -> list[str]:
        lines = [f"eta = {self.eta:.6g} (sup proved by P: "
                 f"{self.eta_sup:.6g}), ofp_index = {self.ofp_index:.6g}, "
                 f"decay = {self.decay:.6g}",
                 f"max_k λmax(Θ_k) = {np.max(self.theta_max):.3e} < 0, "
                 f"min_k λmin(P_k) = {np.min(self.P_min):.3e} > 0",
                 f"ms_radius = {self.ms_radius:.6g} < "
                 f"{min(1.0, self.decay ** 2):.6g}"]
        return lines + [f"failed: {f}" for f in self.failures[:5]]

    def figures(self) -> dict[str, Any]:
        """The measured numbers as a plain dict (for messages and reports).

        Returns
        -------
        dict
            ``eta``, ``ofp_index``, ``decay``, ``theta_max`` and ``P_min``
            (as lists), ``ms_radius`` and ``eta_sup``: plain Python values,
            ready for an error's ``figures`` or a JSON report.

        Examples
        --------
        >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
        >>> figures = ncs.verify.check_certificate(G, [[1.0]], 0.3).figures()
        >>> sorted(figures)
        ['P_min', 'decay', 'eta', 'eta_sup', 'ms_radius', 'ofp_index', 'theta_max']
        >>> figures["P_min"], round(figures["ms_radius"], 12)
        ([1.0], 0.25)
        """
        return dict(eta=self.eta, ofp_index=self.ofp_index,
                    decay=self.decay, theta_max=self.theta_max.tolist(),
                    P_min=self.P_min.tolist(), ms_radius=self.ms_radius,
                    eta_sup=self.eta_sup)


def _check(sys: JumpStateSpace, P: np.ndarray, eta: float, rho: float,
           decay: float) -> Certificate:
    """:func:`check_certificate` on checked arguments (``P``: (N, L, n, n))."""
    thetas = _thetas(sys, P, eta, rho, decay)
    shape = P.shape[:2]
    theta_max = np.array([np.linalg.eigvalsh(T).max() for T in thetas])
    theta_ok = [t < -_float_margin(T) for t, T in zip(theta_max, thetas)]
    flat = P.reshape((-1,) + P.shape[2:])
    P_min = np.array([np.linalg.eigvalsh(Pk).min() for Pk in flat])
    P_ok = [v > _float_margin(Pk) for v, Pk in zip(P_min, flat)]
    # the certified bracket decides: ρ < upper is proven, a point is not
    bracket = ms_radius(sys, bracket=True)
    rho_ms = bracket.radius
    failures = []
    if not all(theta_ok):
        failures.append(f"λmax(Θ_k) = {theta_max.max():.3e} is not < 0")
    if not all(P_ok):
        failures.append(f"λmin(P_k) = {P_min.min():.3e} is not > 0")
    if not bracket.upper <= 1.0:
        failures.append(f"ms_radius = {rho_ms:.6g} is not proven < 1 "
                        f"(certified bracket [{bracket.lower:.12g}, "
                        f"{bracket.upper:.12g}))")
    if decay < 1.0 and not bracket.upper <= decay ** 2:
        failures.append(f"ms_radius = {rho_ms:.6g} is not proven < r² = "
                        f"{decay ** 2:.6g} (certified bracket "
                        f"[{bracket.lower:.12g}, {bracket.upper:.12g}))")
    return Certificate(not failures, float(eta), float(decay),
                       _public(P, sys), _public(theta_max.reshape(shape), sys),
                       _public(P_min.reshape(shape), sys), rho_ms,
                       _sup(sys, P, rho, decay), failures, float(rho))


def check_certificate(sys: Any, P: Any, eta: float, *, decay: float = 1.0,
                      ofp_index: float = 0.0) -> Certificate:
    """Check a passivity certificate exactly (no solver involved).

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
        The closed loop (square).
    P : array_like, shape (N, n, n), (N, M, n, n) or (n, n)
        Candidate ``P_k`` (symmetrised before use).
    eta : float
        Input-feedforward level ``η`` to certify.
    decay : float, optional
        Mean-square decay bound ``r`` in (0, 1].
    ofp_index : float, optional
        Output-feedback level ``ρ`` to certify with it (default 0; supply
        rate ``2wᵀz - 2ρzᵀz - 2ηwᵀw``, see :func:`dissipation_blocks`).

    Returns
    -------
    Certificate
        ``verified`` is True only if every ``λmax(Θ_k)`` and ``-λmin(P_k)``
        is negative beyond the rounding bound of the eigenvalue computation
        and ``ms_radius < min(1, r²)``.

    Raises
    ------
    ControlArgument, ControlDimension, ValueError
        As :func:`dissipation_matrices`.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> ncs.verify.check_certificate(G, [[1.0]], 0.3).verified
    True
    """
    sys = square_system(sys)
    eta, decay, rho = _levels(eta, decay, ofp_index)
    return _check(sys, _certificate_array(P, sys), eta, rho, decay)


def certify_index(sys: Any, P: Any, *, decay: float = 1.0,
                  ofp_index: float = 0.0) -> Certificate:
    """Certificate of the largest ``η`` that ``P`` proves, exactly.

    Takes the supremum from :func:`certified_index` and steps just below it
    by the back-offs ``INDEX_BACKOFFS`` (``1e-6``, then ``1e-5``, ``1e-4``
    times ``max(1, |sup|)``: absolute below 1, relative above), returning
    the first :func:`check_certificate` that passes, else the last one
    tried (with ``verified`` False). Every verdict is the exact check's,
    never the Schur complement's.

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
    P : array_like, shape (N, n, n), (N, M, n, n) or (n, n)
    decay : float, optional
        Decay bound ``r`` in (0, 1].
    ofp_index : float, optional
        Output-feedback level ``ρ`` held fixed (default 0).

    Returns
    -------
    Certificate

    Raises
    ------
    ControlArgument, ControlDimension, ValueError
        As :func:`dissipation_matrices`.

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> cert = ncs.verify.certify_index(G, [[1.0]])
    >>> cert.verified, round(cert.eta, 5)
    (True, 0.33333)
    """
    sys = square_system(sys)
    _, decay, rho = _levels(0.0, decay, ofp_index)
    return _certify(sys, _certificate_array(P, sys), rho, decay)


def _certify(sys: JumpStateSpace, P: np.ndarray, rho: float, decay: float
             ) -> Certificate:
    """:func:`certify_index` on checked arguments."""
    sup = _sup(sys, P, rho, decay)
    if not np.isfinite(sup):
        # P proves nothing (some M11 is not negative definite): report the
        # figures (all failing) at a level below the feedthrough bound.
        low = supply_feedthrough_bound(sys, rho)
        return _check(sys, P, low - 1.0, rho, decay)
    for backoff in INDEX_BACKOFFS:          # never empty
        cert = _check(sys, P, sup - backoff * max(1.0, abs(sup)), rho, decay)
        if cert.verified:
            break
    return cert


def certify_ofp_index(sys: Any, P: Any, rho: float, *, eta: float = 0.0,
                      decay: float = 1.0) -> Certificate:
    """Certificate of the largest output-feedback ``ρ`` ``P`` proves.

    ``Θ_k(ρ) = Θ_k(ρ0) + 2(ρ - ρ0) W_k`` with
    ``W_k = Σ_i p_i [C_i D_i]ᵀ[C_i D_i] ≽ 0``. From a level ``ρ0`` at which
    the exact check passes (``rho`` less the back-offs ``INDEX_BACKOFFS``,
    times ``max(1, |rho|)``), ``-Θ_k(ρ0) = L Lᵀ`` (Cholesky) gives the
    supremum exactly: ``ρ0 + 1 / (2 λmax(L⁻¹ W_k L⁻ᵀ))``, minimised over
    ``k``. The value returned sits below that supremum by the same
    back-offs and passes :func:`check_certificate`; if no level passes, the
    last check tried is returned (``verified`` False).

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
    P : array_like, shape (N, n, n), (N, M, n, n) or (n, n)
    rho : float
        A guess of the level ``P`` proves (e.g. a solver's optimum); never
        the number certified.
    eta : float, optional
        Input-feedforward level ``η`` held fixed (default 0).
    decay : float, optional
        Decay bound ``r`` in (0, 1].

    Returns
    -------
    Certificate
        Its ``ofp_index`` is the certified ``ρ``.

    Raises
    ------
    ControlArgument, ControlDimension, ValueError
        As :func:`dissipation_matrices`.

    Examples
    --------
    ``G(z) = 2z/(z - 0.5)``: ``Re 1/G = 0.5 - 0.25 cos θ``, so its output
    feedback index is 1/4:

    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[2.0]], True)
    >>> cert = ncs.verify.certify_ofp_index(G, [[1.0]], 0.2)
    >>> cert.verified, 0.25 - 1e-5 < cert.ofp_index < 0.25
    (True, True)
    """
    sys = square_system(sys)
    eta, decay, rho = _levels(eta, decay, rho)
    return _certify_ofp(sys, _certificate_array(P, sys), eta, rho, decay)


def _certify_ofp(sys: JumpStateSpace, P: np.ndarray, eta: float,
                 guess: float, decay: float) -> Certificate:
    """:func:`certify_ofp_index` on checked arguments."""
    m = sys.modes
    for backoff in INDEX_BACKOFFS:          # never empty
        rho0 = guess - backoff * max(1.0, abs(guess))
        cert = _check(sys, P, eta, rho0, decay)
        if cert.verified:
            break
    if not cert.verified:
        return cert
    sup = np.inf
    rows = supply_rows(m).reshape(-1, m.count)
    phases = np.repeat(np.arange(sys.period), len(rows) // sys.period)
    for k, t, T in zip(phases, rows, _thetas(sys, P, eta, rho0, decay)):
        H = np.concatenate([m.C[k], m.D[k]], axis=2)
        W = np.tensordot(t, H.transpose(0, 2, 1) @ H, axes=1)
        try:
            L = np.linalg.cholesky(-T)
        except np.linalg.LinAlgError:
            return cert  # Θ(ρ0) ≺ 0 only within rounding: keep ρ0
        X = np.linalg.solve(L, np.linalg.solve(L, W).T)
        lam = np.linalg.eigvalsh(0.5 * (X + X.T)).max()
        if lam > 0:
            sup = min(sup, rho0 + 1.0 / (2.0 * lam))
    if not np.isfinite(sup):
        return cert  # no output enters the supply: ρ is unbounded
    for backoff in INDEX_BACKOFFS:
        level = sup - backoff * max(1.0, abs(sup))
        if not level > rho0:
            break
        better = _check(sys, P, eta, level, decay)
        if better.verified:
            return better
    return cert
