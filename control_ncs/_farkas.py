"""Proofs that no storage exists for a quadratic supply, checked exactly.

(:ref:`theory-performance`, :ref:`theory-certified`.) When a solver
declares the supply's LMI infeasible it returns multipliers (a Farkas
certificate); :func:`supply_dual_check` re-derives from them, with plain
linear algebra, the contradiction that rules out every storage. Only a
certificate that passes makes :func:`control_ncs.dissipativity` say
``'infeasible'``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from control.exception import ControlDimension

from ._checks import real_array
from .jump import as_jump
from .verify import _float_margin, supply_blocks, supply_rows

__all__: list[str] = []


def supply_dual_check(sys: Any, Z: Any, Q: Any, S: Any, R: Any, *,
                      decay: float = 1.0) -> tuple[bool, float, float]:
    """Exact check of a proof that no storage exists for a supply.

    (:ref:`theory-performance`.) ``Θ_{k,ℓ}(P) = Θ⁰_{k,ℓ} + 𝓛_{k,ℓ}(P)``
    is affine in the storage. Multipliers ``Z_{k,ℓ} ⪰ 0`` (not all zero)
    with ``Y = 𝓛*(Z) ⪰ 0`` and ``Σ <Θ⁰_{k,ℓ}, Z_{k,ℓ}> ≥ 0`` rule out every
    ``P ≻ 0`` with ``Θ(P) ≺ 0``: for such a ``P``,
    ``0 > Σ <Θ(P), Z> = Σ <Θ⁰, Z> + Σ <P, Y> ≥ 0``. ``Z`` (a solver's
    Farkas certificate) is first projected on the PSD cone, then ``Y`` and
    the sum are recomputed here; each sign is claimed beyond a rounding
    bound.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    Z : array_like, shape (N, L, n + m, n + m)
        One multiplier per phase and supply row (:func:`supply_rows`).
    Q, S, R : float or ndarray
        The supply's weights, as for :func:`supply_blocks`.
    decay : float, optional
        Decay bound ``r``.

    Returns
    -------
    proven : bool
    value : float
        ``Σ <Θ⁰, Z>`` (must be ≥ 0, and ``Z`` not zero).
    Y_min : float
        ``min λmin(Y_{k,ℓ})`` (must be ≥ 0).

    Examples
    --------
    ``x⁺ = a x + w``, ``z = x + w``, ``a = 0.5`` or ``0.9``: no storage
    proves the sector ``(z - 0.5w)(2w - z) ≥ 0`` (``Q = -1, S = 1.25,
    R = -1``); ``Z = I`` shows it.

    >>> from control_ncs._farkas import supply_dual_check
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])
    >>> ok, value, Y_min = supply_dual_check(sys, np.eye(2)[None, None],
    ...                                      -1.0, 1.25, -1.0)
    >>> ok, round(value, 6), round(Y_min, 6)
    (True, 0.5, 0.53)
    """
    sys = as_jump(sys)
    m, N = sys.modes, sys.period
    rows = supply_rows(m)
    L, n, nw = rows.shape[1], m.A.shape[-1], m.B.shape[-1]
    Z = real_array(Z, "Z", ndim=(4,))
    if Z.shape != (N, L, n + nw, n + nw):
        raise ControlDimension(f"Z: expected shape {(N, L, n + nw, n + nw)},"
                               f" got {Z.shape}")
    w, V = np.linalg.eigh(0.5 * (Z + Z.swapaxes(-1, -2)))
    Z = (V * np.maximum(w, 0.0)[..., None, :]) @ V.swapaxes(-1, -2)
    zero = np.zeros((n, n))
    Y = np.zeros((N, L, n, n))
    value, err = 0.0, 0.0
    for k in range(N):
        F = np.concatenate([m.A[k], m.B[k]], axis=-1)
        nxt = (k + 1) % N
        for ell in range(L):
            t = rows[k, ell]
            T0 = supply_blocks(t, m.A[k], m.B[k], m.C[k], m.D[k], zero,
                               zero if m.is_iid else np.zeros((len(t), n, n)),
                               Q, S, R, decay=decay)
            value += float(np.sum(T0 * Z[k, ell]))
            err += _float_margin(T0) * float(np.trace(Z[k, ell]))
            FZF = F @ Z[k, ell] @ F.swapaxes(-1, -2)         # (M, n, n)
            for i in np.flatnonzero(t > 0):
                Y[nxt, i if not m.is_iid else 0] += t[i] * FZF[i]
            Y[k, ell] -= decay ** 2 * Z[k, ell, :n, :n]
    Y = 0.5 * (Y + Y.swapaxes(-1, -2))
    Y_low = np.linalg.eigvalsh(Y)[..., 0]
    size = float(np.abs(Z).max()) * max(1.0, float(np.abs(
        np.concatenate([m.A, m.B], axis=-1)).max()) ** 2)
    tol = 16 * (n + nw) * len(m.A[0]) * np.finfo(float).eps * size
    proven = bool(np.any(Z) and value > err and Y_low.min() > tol)
    return proven, value, float(Y_low.min())
