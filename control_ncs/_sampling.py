"""The record a loop of a sampled continuous plant keeps for its cost.

Builders that close the loop of a plant sampled from a continuous-time one
(``P.continuous``) store ``CL.info['sampling']``: the continuous plant, and
per phase and mode where the state and the held input sit on the loop
state. :mod:`control_ncs.intersample` reads it (its module docstring
defines every entry); nothing else does.
"""

from __future__ import annotations

import warnings
from typing import Any, Callable

import numpy as np

from .exceptions import ScheduleWarning
from .jump import JumpStateSpace
from .plant import NetworkedStateSpace

__all__: list[str] = []


def _per_mode(rows: Any, N: int) -> np.ndarray:
    """Rows given per mode, the same at every phase, as (N, M, ., .)."""
    X = np.asarray(rows, float)
    return np.repeat(X[None], N, axis=0) if X.ndim == 3 else X


def sampling_entry(P: NetworkedStateSpace, *, x: slice | np.ndarray,
                   u: Any, u_w: Any, u_prev: Any, tau: Any, period: int,
                   omega: Any = None) -> dict:
    """``CL.info['sampling']`` from the rows a builder computed.

    ``u``, ``u_w``, ``u_prev``: per mode (M, ., .), the same at every phase,
    or per phase and mode (N, M, ., .); ``tau``: (M,) or (N, M); ``omega``:
    None (the plant's noise enters at ``x`` only) or like ``u``.
    """
    sys = _continuous(P)
    N = period
    entry = dict(
        h=float(P.dt),
        plant=tuple(np.array(X, float) for X in (sys.A, sys.B, sys.C, sys.D)),
        nmeas=P.nmeas, ncon=P.ncon, x=x,
        u=_per_mode(u, N), u_w=_per_mode(u_w, N), u_prev=_per_mode(u_prev, N),
        tau=np.broadcast_to(np.asarray(tau, float),
                            (N, np.shape(u)[-3])).copy())
    if omega is not None:
        entry["omega"] = _per_mode(omega, N)
    return entry


def undelayed_entry(P: NetworkedStateSpace, CL: JumpStateSpace,
                    close: Callable[[NetworkedStateSpace], JumpStateSpace]
                    ) -> dict:
    """The record of a loop closed without delays (the input acts at once).

    ``close(Q)`` closes the plant ``Q`` exactly as ``CL`` was closed. It is
    called once, on ``P`` with two more outputs and one more input: ``z``
    gains the applied input ``u`` and the state ``x``, ``w`` gains a
    disturbance ``ω`` added to ``x⁺``. Every mode of that loop whose
    matrices on ``w`` and ``z`` are those of a mode of ``CL`` gives its
    rows: ``u``, ``x`` and where ``ω`` enters. Modes that ``CL`` merged may
    differ only in inputs that neither move the continuous plant nor reach
    ``z`` (checked).
    """
    n, m1, m2, p1 = P.nstates, P.B1.shape[1], P.ncon, P.C1.shape[0]
    B2c = np.asarray(_continuous(P).B, float)[:, m1:]
    D12 = np.asarray(P.D12, float)
    Z = np.zeros
    B = np.hstack([P.B1, np.eye(n), P.B2])
    C = np.vstack([P.C1, Z((m2, n)), np.eye(n), P.C2])
    D = np.block([[P.D11, Z((p1, n)), P.D12],
                  [Z((m2, m1 + n)), np.eye(m2)],
                  [Z((n, m1 + n + m2))],
                  [P.D21, Z((P.nmeas, n + m2))]])
    with warnings.catch_warnings():     # the schedule was warned about
        warnings.simplefilter("ignore", ScheduleWarning)
        Q = P.with_network(A=P.A, B=B, C=C, D=D, inputs=None, outputs=None,
                           continuous=None)
    wide = close(Q).modes
    ours = CL.modes
    N, M, nX = ours.A.shape[0], ours.A.shape[1], ours.A.shape[-1]
    iu, ix = slice(p1, p1 + m2), slice(p1 + m2, p1 + m2 + n)
    x_rows, u, u_w, omega = (Z((N, M, n, nX)), Z((N, M, m2, nX)),
                             Z((N, M, m2, m1)), Z((N, M, nX, n)))
    for k in range(N):
        for j in range(M):
            found = [i for i in range(wide.A.shape[1]) if all(
                _same(W, O) for W, O in (
                    (wide.A[k, i], ours.A[k, j]),
                    (wide.B[k, i, :, :m1], ours.B[k, j]),
                    (wide.C[k, i, :p1], ours.C[k, j]),
                    (wide.D[k, i, :p1, :m1], ours.D[k, j])))]
            if not found:
                raise RuntimeError("the loop with its inputs recorded does "
                                   "not match the loop closed")
            seen = [(wide.C[k, i, ix], B2c @ wide.C[k, i, iu],
                     D12 @ wide.C[k, i, iu], B2c @ wide.D[k, i, iu, :m1],
                     D12 @ wide.D[k, i, iu, :m1], wide.B[k, i, :, m1:m1 + n])
                    for i in found]
            if any(not all(_same(a, b) for a, b in zip(seen[0], other))
                   for other in seen[1:]):
                raise ValueError(
                    "P: modes the loop merged apply inputs that move the "
                    "continuous plant differently (A has an eigenvalue "
                    "2πik/h, k ≠ 0: sampling at h hides the difference); "
                    "the merged loop does not define the cost between the "
                    "samples")
            i = found[0]
            if np.any(wide.D[k, i, ix, :m1] != 0):
                raise RuntimeError("the plant's state depends on the noise "
                                   "of its own step")
            x_rows[k, j] = wide.C[k, i, ix]
            u[k, j] = wide.C[k, i, iu]
            u_w[k, j] = wide.D[k, i, iu, :m1]
            omega[k, j] = wide.B[k, i, :, m1:m1 + n]
    rows = x_rows[0, 0]
    if not np.all(x_rows == rows):
        raise RuntimeError("the plant's state moves within the loop state "
                           "from mode to mode")
    x: slice | np.ndarray = rows
    if np.array_equal(rows[:, :n], np.eye(n)) and not np.any(rows[:, n:]):
        x = slice(0, n)
    return sampling_entry(P, x=x, u=u, u_w=u_w, u_prev=np.zeros_like(u),
                          tau=np.zeros((N, M)), period=N, omega=omega)


def _continuous(P: NetworkedStateSpace) -> Any:
    if P.continuous is None:
        raise ValueError("P: a discrete plant has no cost between samples")
    return P.continuous


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    scale = 1.0 + max(np.abs(a).max(initial=0.0), np.abs(b).max(initial=0.0))
    return bool(np.allclose(a, b, rtol=0.0, atol=1e-12 * scale))
