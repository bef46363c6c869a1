"""The continuous-time cost of a sampled loop with timing jitter
(:ref:`theory-intersample-cost`, Jitterbug's cost).

A plant sampled from a continuous-time one (``nss(sys_c, ..., dt=h)``) runs
in continuous time between the samples, driven by continuous white noise
of unit intensity on the columns of ``B1``; its input is held, and with
sub-sample delays it switches from the old to the new command ``τ`` after
the sample. :func:`cost` gives Jitterbug's

    J = lim (1/T) E ∫₀ᵀ z(t)ᵀ z(t) dt,   z(t) = C1 x(t) + D12 u(t),

behaviour between the samples included, exactly: a block-triangular matrix
exponential per integral (van Loan) and one linear solve for the jump
system's stationary second moment. The pure functions below
(:func:`intersample_weight`, :func:`sampled_noise`, :func:`sampled_loss`,
:func:`delay_augmented_loss`) are the pieces, and what a design for ``J``
needs.

The loop's record
-----------------
A builder that closes the loop of a plant with ``P.continuous`` stores
``CL.info['sampling']``, a dict; ``X`` is the loop state (``nX``), ``w``
the loop's input (``nw``), ``N`` phases, ``M`` modes per phase, as in
``CL.modes``; the period ``k`` starts at the sample ``kh``:

``h`` : float
    The sampling period.
``plant`` : tuple (A, B, C, D)
    The continuous-time generalized plant, inputs ``[w; u]``, outputs
    ``[z; y]`` (the last ``ncon`` and ``nmeas``).
``nmeas``, ``ncon`` : int
``x`` : slice, or ndarray (n, nX)
    Where ``x_k = x(kh)`` sits in ``X_k`` (a slice), or its rows when the
    loop's coordinates mix it with other things (the predictor's
    ``[x̂; e]``).
``u``, ``u_w`` : ndarray (N, M, ncon, nX) and (N, M, ncon, nw)
    The command applied in period ``k`` once its delay has passed,
    ``u_k = u[k, i] X_k + u_w[k, i] w_k`` in mode ``i`` (``w_k`` reaches it
    through the sampled measurement's ``D21``).
``u_prev`` : ndarray (N, M, ncon, nX)
    The input held from the previous period, ``u_{k-1}``, applied until
    the delay has passed (read only where ``tau > 0``).
``tau`` : ndarray (N, M)
    The delay from the sample to the switch, in time units, ``[0, h)``.
``omega`` : ndarray (N, M, nX, n), optional
    Where a disturbance added to ``x_{k+1}`` (the plant noise of the
    period, ``ω_k``) enters ``X_{k+1}``; absent: at ``x`` only.

Sampling jitter (the sample taken ``s`` after ``kh``, ``0 ≤ s ≤ τ``;
``nss(..., timing=...)``, :ref:`theory-sampling-jitter`) adds (optional
in a record written by hand, always written by the builders): ``s`` (N,
M); ``u_n`` (N, M, ncon, n), the rows of ``u_k`` on ``n_s``, the noise the
plant gathered from ``kh`` to the sample (it reaches ``u_k`` through ``y_k
= C2 x(kh + s)``); ``n_noise`` (N, M, nX, n), where ``n_s`` enters
``X_{k+1}`` through the loop (what the controller read, and ``Γ0(τ)
u_k``); its share of the period's own noise ``ω_k = n(h)`` is ``omega``'s.
A controller with memory reads the sample at the end of the previous
step: its loop runs on pairs of modes and these rows are per pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import scipy.linalg

from ._blas import serial_blas
from ._checks import choice, positive_real
from ._results import Result
from .jump import JumpStateSpace, as_jump
from ._timing import input_delay_sampling
from .stability import ms_radius, second_moment_operator
from .stationary import (output_power, phase_forcing,
                         stationary_covariances, stationary_of_stable)

__all__ = ["cost", "CostResult"]


# -- the integrals of one period (van Loan 1978) ------------------------------
def _van_loan(F: np.ndarray, Q: np.ndarray, L: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """``(∫_0^L e^{Fᵀs} Q e^{Fs} ds, e^{FL})`` from one exponential of
    ``[[-Fᵀ, Q], [0, F]] L`` (:ref:`theory-intersample-cost`)."""
    d = F.shape[0]
    H = np.zeros((2 * d, 2 * d))
    H[:d, :d], H[:d, d:], H[d:, d:] = -F.T, Q, F
    E = scipy.linalg.expm(H * L)
    I = E[d:, d:].T @ E[:d, d:]
    return 0.5 * (I + I.T), E[d:, d:]


def _gramian(A: np.ndarray, B1: np.ndarray, t: float) -> np.ndarray:
    """``Σ(t) = ∫_0^t e^{As} B1 B1ᵀ e^{Aᵀs} ds``, the noise gathered in
    ``t``."""
    if t == 0.0:
        return np.zeros_like(A)
    return _van_loan(A.T, B1 @ B1.T, t)[0]


def _weights(A: np.ndarray, B2: np.ndarray, C1: np.ndarray, D12: np.ndarray,
             h: float, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``W(τ)`` on ``ψ = [x; u_{k-1}; u_k]`` and the block
    ``Y = ∫_0^{h-τ} e^{Aᵀr} C1ᵀ (C1 Γ(r) + D12) dr`` of its second flow
    (``Γ(r) = ∫_0^r e^{As} ds B2``), which the noise of a late sample
    meets."""
    n, m = B2.shape
    d = n + 2 * m
    F1, F2 = np.zeros((d, d)), np.zeros((d, d))
    F1[:n, :n] = F2[:n, :n] = A
    F1[:n, n:n + m] = B2                       # the old input on [0, τ)
    F2[:n, n + m:] = B2                        # the new one on [τ, h)
    M1 = np.hstack([C1, D12, np.zeros_like(D12)])
    M2 = np.hstack([C1, np.zeros_like(D12), D12])
    I2, _ = _van_loan(F2, M2.T @ M2, h - tau)
    if tau > 0.0:
        I1, E1 = _van_loan(F1, M1.T @ M1, tau)
        W = I1 + E1.T @ I2 @ E1                # the flows chained at τ
    else:
        W = I2
    return 0.5 * (W + W.T), I2[:n, n + m:]


def intersample_weight(A: Any, B2: Any, C1: Any, D12: Any, h: float,
                       tau: float = 0.0) -> np.ndarray:
    """The cost of one period as a quadratic form ``W(τ)``.

    With ``ψ = [x_k; u_{k-1}; u_k]`` and the input switching from
    ``u_{k-1}`` to ``u_k`` at ``τ``, ``E ∫_{kh}^{(k+1)h} zᵀz dt = ψᵀ W(τ) ψ
    + c(h)`` (:ref:`theory-intersample-cost`; ``c`` from
    :func:`sampled_noise`): two chained flows, each one van Loan
    exponential.

    Parameters
    ----------
    A, B2 : array_like, shapes (n, n), (n, m)
        The continuous plant's dynamics and control input.
    C1, D12 : array_like, shapes (p, n), (p, m)
        ``z = C1 x + D12 u``.
    h : float
        The sampling period.
    tau : float, optional
        The delay from the sample to the switch, in ``[0, h)``.

    Returns
    -------
    ndarray, shape (n + 2m, n + 2m)
        Symmetric, positive semidefinite.

    Examples
    --------
    The integrator ``ẋ = u``, ``z = x``, ``h = 1``: with ``τ = 0``,
    ``∫_0^1 (x + t u)² dt = x² + x u + u²/3``.

    >>> from control_ncs.intersample import intersample_weight
    >>> intersample_weight([[0.0]], [[1.0]], [[1.0]], [[0.0]], 1.0).round(6)
    array([[1.      , 0.      , 0.5     ],
           [0.      , 0.      , 0.      ],
           [0.5     , 0.      , 0.333333]])
    """
    A, B2, C1, D12 = _arrays(A, B2, C1, D12)
    h = positive_real(h, "h")
    if not 0.0 <= tau < h:
        raise ValueError(f"tau: expected a delay in [0, h) with h = {h}, got "
                         f"{tau!r}")
    return _weights(A, B2, C1, D12, h, float(tau))[0]


def sampled_noise(A: Any, B1: Any, C1: Any, h: float
                  ) -> tuple[np.ndarray, float]:
    """The plant noise over one period: ``R1d`` and its cost ``c(h)``.

    Continuous white noise of unit intensity on ``B1`` adds ``ω_k ~ N(0,
    R1d)`` to ``x_{k+1}``, ``R1d = Σ(h) = ∫_0^h e^{As} B1 B1ᵀ e^{Aᵀs} ds``;
    on its own inside the period it costs ``c(h) = ∫_0^h tr(C1ᵀC1 Σ(t))
    dt`` — with the continuous weight ``C1ᵀC1``, not a sampled one. Both
    from one three-block exponential (van Loan;
    :ref:`theory-intersample-cost`).

    Parameters
    ----------
    A, B1 : array_like, shapes (n, n), (n, m1)
        The continuous plant's dynamics and noise input.
    C1 : array_like, shape (p, n)
        ``z = C1 x + …``.
    h : float
        The sampling period.

    Returns
    -------
    R1d : ndarray, shape (n, n)
    c : float

    Examples
    --------
    The integrator ``ẋ = w``, ``z = x``: ``Σ(t) = t``, so ``R1d = h`` and
    ``c = h²/2``.

    >>> from control_ncs.intersample import sampled_noise
    >>> R1d, c = sampled_noise([[0.0]], [[1.0]], [[1.0]], 0.5)
    >>> float(R1d[0, 0]), round(c, 12)
    (0.5, 0.125)
    """
    A, B1, C1 = _arrays(A, B1, C1)
    h = positive_real(h, "h")
    n = A.shape[0]
    H = np.zeros((3 * n, 3 * n))
    H[:n, :n] = H[n:2 * n, n:2 * n] = -A
    H[:n, n:2 * n] = np.eye(n)
    H[n:2 * n, 2 * n:] = B1 @ B1.T
    H[2 * n:, 2 * n:] = A.T
    F = scipy.linalg.expm(H * h)
    R1d = F[2 * n:, 2 * n:].T @ F[n:2 * n, 2 * n:]
    area = F[2 * n:, 2 * n:].T @ F[:n, 2 * n:]          # ∫_0^h Σ(t) dt
    return 0.5 * (R1d + R1d.T), float(np.trace(C1.T @ C1 @ area))


def sampled_loss(A: Any, B2: Any, C1: Any, D12: Any, h: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sampled loss function ``Q1, Q12, Q2`` of a held input.

    ``∫_0^h zᵀz dt = xᵀQ1x + 2xᵀQ12u + uᵀQ2u`` (plus the noise's
    ``c(h)``) for the input ``u`` held over the period (Åström and
    Wittenmark): the blocks of ``W(0)`` (:func:`intersample_weight`).
    ``Q2 > 0`` even when ``D12 = 0``: the input moves ``z`` inside the
    period.

    Parameters
    ----------
    A, B2 : array_like, shapes (n, n), (n, m)
        The continuous plant's dynamics and control input.
    C1, D12 : array_like, shapes (p, n), (p, m)
        ``z = C1 x + D12 u``.
    h : float
        The sampling period.

    Returns
    -------
    Q1 : ndarray, shape (n, n)
    Q12 : ndarray, shape (n, m)
    Q2 : ndarray, shape (m, m)

    Examples
    --------
    >>> from control_ncs.intersample import sampled_loss
    >>> Q1, Q12, Q2 = sampled_loss([[0.0]], [[1.0]], [[1.0]], [[0.0]], 1.0)
    >>> float(Q1[0, 0]), float(Q12[0, 0]), round(float(Q2[0, 0]), 6)
    (1.0, 0.5, 0.333333)
    """
    W = intersample_weight(A, B2, C1, D12, h)
    n = np.shape(np.atleast_2d(A))[0]
    m = (W.shape[0] - n) // 2
    return W[:n, :n], W[:n, n + m:], W[n + m:, n + m:]


def delay_augmented_loss(A: Any, B2: Any, C1: Any, D12: Any, h: float,
                         tau: float) -> tuple[np.ndarray, ...]:
    """The sampled plant and loss with a constant input delay ``τ``.

    State ``ξ_k = [x_k; u_{k-1}]``, input ``u_k``:
    ``ξ_{k+1} = Φa ξ_k + Γa u_k + [ω_k; 0]`` with ``Φa = [[Φ, Γ1(τ)], [0,
    0]]``, ``Γa = [Γ0(τ); I]``; the period costs ``ξᵀQ1ξ + 2ξᵀQ12u +
    uᵀQ2u`` (plus ``c(h)``), the blocks of ``W(τ)``. The discrete Riccati
    equation with cross term ``Q12`` on ``(Φa, Γa)`` gives the optimal
    state feedback, as Jitterbug's ``lqgdesign`` (:ref:`theory-intersample-cost`).

    Parameters
    ----------
    A, B2 : array_like, shapes (n, n), (n, m)
        The continuous plant's dynamics and control input.
    C1, D12 : array_like, shapes (p, n), (p, m)
        ``z = C1 x + D12 u``.
    h : float
        The sampling period.
    tau : float
        The constant delay, in ``[0, h)``.

    Returns
    -------
    Phi_a : ndarray, shape (n + m, n + m)
    Gamma_a : ndarray, shape (n + m, m)
    Q1 : ndarray, shape (n + m, n + m)
    Q12 : ndarray, shape (n + m, m)
    Q2 : ndarray, shape (m, m)

    Examples
    --------
    The integrator with half a period's delay: ``x_{k+1} = x_k + u_{k-1}/2
    + u_k/2``.

    >>> from control_ncs.intersample import delay_augmented_loss
    >>> Pa, Ga, *_ = delay_augmented_loss([[0.0]], [[1.0]], [[1.0]], [[0.0]],
    ...                                   1.0, 0.5)
    >>> Pa.tolist(), Ga.tolist()
    ([[1.0, 0.5], [0.0, 0.0]], [[0.5], [1.0]])
    """
    A, B2, C1, D12 = _arrays(A, B2, C1, D12)
    W = intersample_weight(A, B2, C1, D12, h, tau)
    n, m = B2.shape
    Phi, G0, G1 = input_delay_sampling(A, B2, float(h), [float(tau)])
    Phi_a = np.block([[Phi, G1[0]], [np.zeros((m, n + m))]])
    Gamma_a = np.vstack([G0[0], np.eye(m)])
    return Phi_a, Gamma_a, W[:n + m, :n + m], W[:n + m, n + m:], \
        W[n + m:, n + m:]


def _arrays(*mats: Any) -> list[np.ndarray]:
    return [np.atleast_2d(np.asarray(X, float)) for X in mats]


# -- the cost of a loop ---------------------------------------------------------
@dataclass(frozen=True, repr=False)
class CostResult(Result):
    """Jitterbug's cost of a loop, exact, with its figures.

    Attributes
    ----------
    cost : float
        ``J = lim (1/T) E ∫₀ᵀ zᵀz dt`` per time unit (a sampled continuous
        plant), or ``‖G‖₂²`` per step (a discrete plant); ``inf`` when the
        loop is not mean-square stable.
    ms_radius : float
        The loop's second-moment radius (:func:`control_ncs.ms_radius`);
        ``J`` is finite exactly when it is below 1.
    dt : float or True
        The sampling period ``h``.
    noise_cost : float
        ``c(h)/h``: what the plant noise costs on its own inside the
        periods (0 for a discrete plant).
    residual : float
        Relative residual of the stationary second moment, re-checked over
        one period after the solve (``nan`` when ``cost`` is ``inf``).
    continuous : bool
        True for the continuous-time cost of a sampled plant.

    Examples
    --------
    >>> G = ct.ss([[0.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
    ...           [0.0, 0.0]])
    >>> P = ncs.nss(G, nmeas=1, ncon=1, dt=0.5)
    >>> res = ncs.cost(ncs.feedback(P, [[-2.0]]))
    >>> res.status, round(res.cost, 9), float(res) == res.cost
    ('exact', 0.416666667, True)
    """

    cost: float
    ms_radius: float
    dt: Any
    noise_cost: float
    residual: float
    continuous: bool

    _repr_fields: ClassVar[tuple[str, ...]] = ("cost", "ms_radius")

    @property
    def success(self) -> bool:
        """True when the cost is finite."""
        return math.isfinite(self.cost)

    @property
    def status(self) -> str:
        """``'exact'``, or ``'not_mss'`` (the cost is infinite)."""
        return "exact" if self.success else "not_mss"

    @property
    def message(self) -> str:
        """One sentence: which cost, and on what it rests."""
        if not self.success:
            return (f"not mean-square stable (ms_radius = "
                    f"{self.ms_radius:.6g} >= 1): the cost is infinite")
        if self.continuous:
            return ("the continuous-time cost, between the samples included, "
                    "from the loop's stationary second moment")
        return "a discrete plant: the cost is the H2 norm squared, per step"

    def __float__(self) -> float:
        return float(self.cost)

    def _details(self) -> list[str]:
        out = [f"cost {self.cost:.6g} (ms_radius {self.ms_radius:.6g}, "
               f"dt = {self.dt})"]
        if self.continuous and self.success:
            out.append(f"of which the noise inside the periods "
                       f"{self.noise_cost:.6g}")
        if self.success:
            out.append(f"second moment residual {self.residual:.2e}")
        return out


def cost(sys: Any, *, method: str = "auto", tol: float = 1e-12) -> CostResult:
    """Jitterbug's continuous-time cost of a sampled loop.

    For a loop closed (:func:`control_ncs.feedback`) on a plant sampled
    from a continuous-time one, ``nss(sys_c, ..., dt=h)`` with or without
    ``input_delay``, ``J = lim (1/T) E ∫₀ᵀ z(t)ᵀz(t) dt`` with continuous
    white noise of unit intensity on the columns of ``B1``, discrete
    unit-variance noise ``w_k`` on the sampled measurement (``D21``), and
    ``z(t) = C1 x(t) + D12 u(t)`` weighting the input the actuator holds at
    time ``t`` (switching ``τ`` after the sample). Exact: the period's
    integrals in closed form and the loop's stationary second moment with
    the plant noise added (:ref:`theory-intersample-cost`). ``J`` is
    per time unit; it is not ``norm(CL, 2)**2``, which counts ``z`` at the
    samples only and holds ``w`` over the period. For a loop without the
    record of a continuous plant (a discrete plant) the cost is
    ``norm(sys, 2)**2``, per step.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
        The closed loop.
    method : {'auto', 'dense', 'matrix-free'}, optional
        How the stationary second moment is solved
        (:func:`control_ncs.stationary_covariances`).
    tol : float, optional
        Relative residual asked of the matrix-free solve.

    Returns
    -------
    CostResult
        ``cost`` (``inf`` when the loop is not mean-square stable, with its
        ``ms_radius``), and the figures it rests on; ``float(result)`` is
        the cost.

    Raises
    ------
    ValueError
        If ``D11 ≠ 0`` (white noise straight into ``z`` has infinite
        power), or a noise is both continuous (a column of ``B1``) and
        discrete (a column of ``D21``); or the loop's mean-square radius
        is below 1 but its certified bracket still contains 1 (undecided:
        no steady state is proven).
    ControlArgument
        Unknown ``method``.

    See Also
    --------
    control_ncs.norm, control_ncs.ms_radius

    Examples
    --------
    The integrator ``ẋ = u + w``, ``z = x``, ``y = x``, ``u = -k y`` with
    ``k h = 1``: ``J = 5h/6``, while the sampled loop's ``‖G‖₂²`` is
    ``h²``.

    >>> G = ct.ss([[0.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
    ...           [0.0, 0.0]])
    >>> P = ncs.nss(G, nmeas=1, ncon=1, dt=0.5)
    >>> CL = ncs.feedback(P, [[-2.0]])
    >>> round(ncs.cost(CL).cost, 9), round(ncs.norm(CL, 2)**2, 9)
    (0.416666667, 0.25)

    Half a period's delay on half of the samples (``h = 1``, ``k = 1``):
    ``J = 59/48``.

    >>> P = ncs.nss(G, nmeas=1, ncon=1, dt=1.0,
    ...             input_delay=([0.0, 0.5], [0.5, 0.5]))
    >>> round(ncs.cost(ncs.feedback(P, [[-1.0]])).cost * 48, 9)
    59.0
    """
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    record = sys.info.get("sampling") if isinstance(sys.info, dict) else None
    bracket = ms_radius(sys, bracket=True)
    radius = float(bracket.radius)
    if record is None:
        if not radius < 1.0:
            return CostResult(math.inf, radius, sys.dt_step, 0.0, math.nan,
                              False)
        J = output_power(sys, method=method, tol=tol)
        _, residual = _solve(sys, method, tol)
        return CostResult(J, radius, sys.dt_step, 0.0, residual, False)
    with serial_blas():
        # small exponentials, one per timing: LAPACK on several threads of
        # a busy machine waits longer than it computes (40x at n = 10)
        plan = _plan(sys, record)
    if not radius < 1.0:
        return CostResult(math.inf, radius, plan.h, plan.c / plan.h,
                          math.nan, True)
    # the noisy loop has the loop's modes: its radius is the one certified
    Q, residual = _solve(plan.noisy, method, tol, bracket)
    return CostResult(_evaluate(plan, Q), radius, plan.h, plan.c / plan.h,
                      residual, True)


@dataclass(frozen=True)
class _Plan:
    """What :func:`cost` evaluates once the second moment is known."""

    h: float
    c: float
    noisy: JumpStateSpace        # the loop driven by its discrete noise and ω
    S: np.ndarray                # (N, M, d, nX): ψ_k on X_k
    G: np.ndarray                # (N, M, d, nw): ψ_k on w_k
    W: np.ndarray                # (N, M, d, d): W(τ) of each mode
    extra: np.ndarray            # (N, M): the late sample's terms per mode


def _plan(sys: JumpStateSpace, record: dict) -> _Plan:
    """Check the record against the loop and compute every integral."""
    A, B, C, D = (np.asarray(X, float) for X in record["plant"])
    h, m2, p2 = float(record["h"]), int(record["ncon"]), int(record["nmeas"])
    n, m1, p1 = A.shape[0], B.shape[1] - m2, C.shape[0] - p2
    B1, B2, C1 = B[:, :m1], B[:, m1:], C[:p1]
    D11, D12, D21 = D[:p1, :m1], D[:p1, m1:], D[p1:, :m1]
    modes = sys.modes
    N, M, nX = modes.A.shape[0], modes.A.shape[1], modes.A.shape[-1]
    names = sys.jump_inputs
    if np.any(D11 != 0):
        raise ValueError("sys: D11 ≠ 0: white noise fed straight through to z "
                         "has infinite power (the continuous cost needs "
                         "D11 = 0)")
    both = np.flatnonzero(np.any(B1 != 0, axis=0) & np.any(D21 != 0, axis=0))
    if both.size:
        raise ValueError(
            f"sys: the noise {[names[j] for j in both]} enters both the "
            f"continuous plant (a column of B1) and the sampled measurement "
            f"(a column of D21); give each noise one meaning, continuous or "
            f"discrete")
    x = record["x"]
    rows = np.eye(nX)[x] if isinstance(x, slice) else np.asarray(x, float)
    u, u_w, u_prev = (np.asarray(record[k], float)
                      for k in ("u", "u_w", "u_prev"))
    tau = np.asarray(record["tau"], float)
    changed = [k for k in ("algebra", "feedback", "interconnect")
               if k in sys.info]
    if changed or (
            rows.shape != (n, nX) or u.shape != (N, M, m2, nX)
            or u_prev.shape != u.shape or u_w.shape != (N, M, m2, m1)
            or tau.shape != (N, M) or modes.B.shape[-1] != m1
            or modes.C.shape[-2] != p1):
        raise ValueError(
            "sys: info['sampling'] was recorded for the loop as "
            "feedback() closed it, and this system was changed since "
            f"({', '.join(changed) or 'its modes, state or signals differ'}); "
            "compute the cost of the loop feedback() returns")
    omega = np.asarray(record.get("omega", np.broadcast_to(
        rows.T, (N, M, nX, n))), float)
    s = np.asarray(record.get("s", np.zeros((N, M))), float)
    u_n = np.asarray(record.get("u_n", np.zeros((N, M, m2, n))), float)
    n_noise = np.asarray(record.get("n_noise", np.zeros((N, M, nX, n))), float)
    if np.any(tau < 0) or np.any(tau >= h) or np.any(s < 0) or np.any(s > tau):
        raise ValueError("sys: info['sampling'] needs 0 <= s <= tau < h")
    R1d, c = sampled_noise(A, B1, C1, h)
    discrete = ~np.any(B1 != 0, axis=0)        # the columns of sampled noise
    nw = int(discrete.sum())
    d = n + 2 * m2
    S = np.concatenate([np.broadcast_to(rows, (N, M, n, nX)), u_prev, u], 2)
    G = np.zeros((N, M, d, nw))
    G[:, :, n + m2:] = u_w[..., discrete]
    W = np.empty((N, M, d, d))
    extra = np.zeros((N, M))
    late = bool(np.any(s > 0))
    Bn = np.zeros((N, M, nX, nw + (2 if late else 1) * n))
    Bn[..., :nw] = modes.B[..., discrete]
    cache: dict = {}
    for k in range(N):
        for i in range(M):
            key = (float(s[k, i]), float(tau[k, i]))
            if key not in cache:
                cache[key] = _timing(A, B1, B2, C1, D12, h, R1d, *key,
                                     late)
            W[k, i], root, Z, Sigma = cache[key]
            p = modes.probabilities[k, i]
            # the late sample's noise: in ψ (u_k's rows), against the
            # noise still to come, and in X_{k+1} (theory: intersample cost)
            Hn = u_n[k, i]
            extra[k, i] = p * (np.trace(W[k, i][n + m2:, n + m2:]
                                        @ Hn @ Sigma @ Hn.T)
                               + 2.0 * np.trace(Hn @ Z))
            maps = (np.hstack([omega[k, i], n_noise[k, i]]) if late
                    else omega[k, i])
            Bn[k, i, :, nw:] = maps @ root
    noisy = JumpStateSpace(
        modes.A, Bn, modes.C, np.zeros(modes.C.shape[:-1] + (Bn.shape[-1],)),
        modes.probabilities if modes.is_iid else None, sys.dt_step,
        transition=modes.transition)
    return _Plan(h, c, noisy, S, G, W, extra)


def _timing(A: np.ndarray, B1: np.ndarray, B2: np.ndarray, C1: np.ndarray,
            D12: np.ndarray, h: float, R1d: np.ndarray, s: float, tau: float,
            late: bool) -> tuple[np.ndarray, ...]:
    """The integrals of one timing ``(s, τ)``: ``W(τ)``, a square root of the covariance of the noise reaching ``X_{k+1}``
    (``[ω; n_s]`` when some sample of the loop is late, else ``ω``), the
    cross term's ``Z = Σ(s) e^{Aᵀ(τ-s)} Y`` and ``Σ(s)``."""
    W, Y = _weights(A, B2, C1, D12, h, tau)
    Sigma = _gramian(A, B1, s)
    if late:
        E = scipy.linalg.expm(A * (h - s))
        cov = np.block([[R1d, E @ Sigma], [Sigma @ E.T, Sigma]])
        Z = Sigma @ scipy.linalg.expm(A.T * (tau - s)) @ Y
    else:
        cov, Z = R1d, np.zeros_like(Y)
    return W, _root(cov), Z, Sigma


def _root(cov: np.ndarray) -> np.ndarray:
    """``R`` with ``R Rᵀ = cov`` for a positive semidefinite ``cov``."""
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    return vecs * np.sqrt(np.clip(vals, 0.0, None))


def _solve(sys: JumpStateSpace, method: str, tol: float,
           bracket: Any = None) -> tuple[np.ndarray, float]:
    """The stationary second moment and its residual over one period
    (ValueError if the radius' certified bracket contains 1); ``bracket``
    the certified radius of ``sys``'s modes, when already known."""
    if bracket is None:
        Q = stationary_covariances(sys, method=method, tol=tol)
    elif bracket.stable is not True:
        raise ValueError(f"sys: not proven mean-square stable "
                         f"({bracket.message}): the noise-driven second "
                         "moment has no steady state")
    else:
        Q = stationary_of_stable(sys, method, tol)
    modes = sys.modes
    N = sys.period
    shape = Q.shape[1:]
    scale = max(float(np.abs(Q).max()), np.finfo(float).tiny)
    residual = 0.0
    for k in range(N):
        step = second_moment_operator(sys, k).matvec(Q[k].ravel())
        T = None if modes.is_iid else modes.transitions()[k]
        step = step.reshape(shape) + phase_forcing(
            modes.B[k], modes.probabilities[k], T)
        residual = max(residual,
                       float(np.abs(step - Q[(k + 1) % N]).max()) / scale)
    return Q, residual


def _evaluate(plan: _Plan, Q: np.ndarray) -> float:
    """``J = (1/Nh) Σ_k [Σ_i tr(W_i (S_i Q_i S_iᵀ + π_i G_i G_iᵀ)) + extra
    + c(h)]`` (:ref:`theory-intersample-cost`, step 3)."""
    modes = plan.noisy.modes
    p = modes.probabilities
    if modes.is_iid:                     # Q_k is the whole second moment
        Q = p[:, :, None, None] * Q[:, None]
    psi = (plan.S @ Q @ np.swapaxes(plan.S, -1, -2)
           + p[:, :, None, None] * (plan.G @ np.swapaxes(plan.G, -1, -2)))
    total = np.einsum("kiab,kiba->", plan.W, psi) + plan.extra.sum()
    N = p.shape[0]
    return float((total + N * plan.c) / (N * plan.h))


def cost_open_loop(plant: Any) -> Any:
    """The open loop whose H2 norm² is the continuous-time cost ``J``.

    For a :class:`~control_ncs.JumpPlant` of a plant sampled from a
    continuous-time one (``plant.sampling``): per mode, the performance
    output becomes ``h^{-1/2} W(τ)^{1/2} ψ`` with ``ψ = [x_k; u_{k-1};
    u_k]`` (the cost of the period, :func:`intersample_weight`), the
    continuous noise enters the loop state as ``ω_k ~ N(0, R1d)`` where the
    sampling record says, the discrete (measurement) noise keeps its way
    in, and one more input-output pair carries the noise's own cost
    ``c(h)/h``; so the loop this plant closes with a gain has
    ``‖G‖₂² = J`` of :func:`cost` (:ref:`theory-intersample-cost`). The
    designs minimise ``J`` by minimising that norm.

    Parameters
    ----------
    plant : JumpPlant
        With a sampling record (built from ``nss(sys_c, ..., dt=h)``).

    Returns
    -------
    JumpPlant
        Same state, gain and modes; new ``Bw``, ``Cz``, ``Du``, ``Dw``.

    Raises
    ------
    ValueError
        A plant without a continuous-time model, ``D11 ≠ 0``, or a noise
        that is both continuous and discrete.
    """
    from dataclasses import replace
    s = plant.sampling
    if s is None:
        raise ValueError("plant: a discrete plant has no cost between the "
                         "samples; its H2 norm is its cost")
    A, B, C, D = (np.asarray(X, float) for X in s["plant"])
    h, m2, p2 = float(s["h"]), int(s["ncon"]), int(s["nmeas"])
    m1, p1 = B.shape[1] - m2, C.shape[0] - p2
    B1, B2, C1 = B[:, :m1], B[:, m1:], C[:p1]
    D11, D12, D21 = D[:p1, :m1], D[:p1, m1:], D[p1:, :m1]
    if np.any(D11 != 0):
        raise ValueError("plant: D11 ≠ 0: white noise fed straight through "
                         "to z has infinite power")
    if np.any(np.any(B1 != 0, axis=0) & np.any(D21 != 0, axis=0)):
        raise ValueError("plant: a noise enters both the continuous plant "
                         "(B1) and the sampled measurement (D21); give each "
                         "noise one meaning")
    if np.any(np.asarray(s.get("s", 0.0)) > 0):
        raise ValueError("plant: a design for the cost with late samples "
                         "(sampling jitter) is not available; compute the "
                         "cost of a given loop with cost()")
    discrete = ~np.any(B1 != 0, axis=0)
    N, M = s["tau"].shape
    roots = {}
    with serial_blas():          # small exponentials (see cost)
        R1d, c = sampled_noise(A, B1, C1, h)
        for tau in np.unique(s["tau"]):
            # z = R^T psi with R R^T = W: z^T z = psi^T W psi
            roots[float(tau)] = _root(intersample_weight(
                A, B2, C1, D12, h, float(tau))).T / math.sqrt(h)
    rows = np.concatenate([s["x"], s["u_prev"], s["u"]], axis=2)
    Wr = np.array([[roots[float(s["tau"][k, i])] for i in range(M)]
                   for k in range(N)])                       # (N, M, r, d)
    d = rows.shape[2]
    nk = plant.Bu.shape[-1]
    zero_v = np.zeros((N, M, d, nk))
    zero_v[:, :, -m2:] = s["u_v"]
    zero_w = np.zeros((N, M, d, int(discrete.sum())))
    zero_w[:, :, -m2:] = s["u_w"][..., discrete]
    Cz, Du, Dw = Wr @ rows, Wr @ zero_v, Wr @ zero_w
    # the inputs: ω (R1d^½ per unit noise), the discrete noises, the noise's
    # own cost; the outputs: the period's cost, then √(c/h) on that input
    omega = s["omega"] @ _root(R1d)         # ω = R e, R R^T = R1d
    nx = plant.A.shape[-1]
    Bw = np.concatenate([omega, plant.Bw[..., discrete],
                         np.zeros((N, M, nx, 1))], axis=3)
    r = Cz.shape[2]
    extra = np.zeros((N, M, 1, nx))
    Cz = np.concatenate([Cz, extra], axis=2)
    Du = np.concatenate([Du, np.zeros((N, M, 1, nk))], axis=2)
    n = omega.shape[-1]
    Dw_full = np.zeros((N, M, r + 1, n + Dw.shape[-1] + 1))
    Dw_full[:, :, :r, n:n + Dw.shape[-1]] = Dw
    Dw_full[:, :, r, -1] = math.sqrt(max(c, 0.0) / h)

    def widen(X: Any, ndim: int) -> Any:
        """Noise read by the controller: only the discrete columns, with
        zeros for ω and the constant's input."""
        if X is None:
            return None
        shape = X.shape[:-1]
        out = np.zeros(shape + (n + int(discrete.sum()) + 1,))
        out[..., n:n + int(discrete.sum())] = X[..., discrete]
        return out

    names = ([f"omega[{i}]" for i in range(n)]
             + [name for name, keep in zip(plant.inputs or [], discrete)
                if keep] + ["noise cost"])
    return replace(plant, Bw=Bw, Cz=Cz, Du=Du, Dw=Dw_full,
                   Ew=widen(plant.Ew, 0), Gw=widen(plant.Gw, 0),
                   inputs=names if plant.inputs else None,
                   outputs=[f"J[{i}]" for i in range(r + 1)],
                   sampling=None)
