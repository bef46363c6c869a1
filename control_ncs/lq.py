"""Linear-quadratic control over a lossy actuator link (:ref:`theory-performance`).

With TCP-like acknowledgements the controller knows whether each command
arrived; the state is measured. The optimal cost-to-go is ``xᵀSx`` with
``S`` the stabilising solution of the *modified* Riccati equation of
Schenato et al. (2007),

``S = AᵀSA + Q - ν AᵀSB (BᵀSB + R)⁻¹ BᵀSA``,

``ν`` the probability that a command arrives. The optimal gain is the
loss-free formula at this ``S``; it exists only above a critical arrival
probability. The equation is the dual of the estimator's
(:ref:`theory-estimation`): ``A → Aᵀ``, ``C → Bᵀ``, solved as an equation
by the same kernel (:mod:`control_ncs._mare`: a stabilising start, then
policy iteration on exact fixed-gain solves, every answer checked). Over a
bursty (Gilbert–Elliott) link the cost-to-go depends on the previous link
state, and the equations are coupled.
"""

from __future__ import annotations

from typing import Any, Iterator

import control as ct
import numpy as np
import scipy.linalg as sla
from control.exception import ControlArgument, ControlDimension

from . import _mare
from ._checks import flag, matrix, no_extra_kwargs
from ._mare import MareError
from .exceptions import NOT_FOUND, NOT_MSS
from .network import GilbertElliott
from .plant import NetworkedStateSpace

__all__ = ["dlqr"]


def critical_control_arrival(A: np.ndarray, B: np.ndarray
                             ) -> _mare.Threshold:
    """The arrival probability above which a gain makes ``x⁺ = A x + θ B
    u``, ``u = -K x``, mean-square stable (the modified Riccati equation
    then has its stabilising solution): the estimator's ``λ_max`` of the
    dual pair ``(Aᵀ, Bᵀ)`` (:func:`control_ncs._mare.threshold`). Exact
    (``1 - 1/ρ(A)²``) when ``B`` reaches the whole unstable subspace, exact
    (``1 - 1/Π|μ_u|²``) for one input, a certified bracket otherwise.

    Raises
    ------
    ValueError
        If ``(A, B)`` is not stabilisable.
    """
    try:
        return _mare.threshold(A.T, B.T)
    except ValueError as err:
        raise ValueError(f"(A, B) is not stabilisable: {err}".replace(
            "seen by the measurement", "reached by the input").replace(
            "makes the error stable", "stabilises the loop")) from None


def _threshold_text(th: _mare.Threshold) -> str:
    """The critical probability as the error message states it."""
    if th.exact:
        why = ("B reaches the whole unstable subspace: 1 - 1/ρ(A)²"
               if th.how == "subspace" else
               "one input: 1 - 1/Π|μ|² over the unstable eigenvalues μ")
        return (f"critical arrival probability {th.upper:.6g} (exact, "
                f"{why}; loss {1 - th.upper:.6g})")
    return (f"critical arrival probability, which lies in "
            f"[{th.lower:.6g}, {th.upper:.6g}] (the upper end certified by "
            f"a gain, the lower end on the LMI solver's word)")


def _plant(args: tuple, arrival: Any) -> tuple[np.ndarray, np.ndarray, Any]:
    """``(A, B, ν)`` from ``(sys,)`` or ``(A, B)``, and the arrival law:
    a probability, or a bursty actuator link (:class:`GilbertElliott`)."""
    if len(args) == 1:
        sys = args[0]
        if isinstance(sys, NetworkedStateSpace):
            if arrival is not None:
                raise ControlArgument("arrival: a NetworkedStateSpace carries "
                                      "its actuator link; do not give arrival")
            delayed = sys.sensor_delay is not None or \
                sys.actuator_delay is not None or sys.input_delay is not None
            if sys.period != 1 or delayed \
                    or isinstance(sys.sensor_link, GilbertElliott) \
                    or sys.sensor_loss:
                raise ControlArgument(
                    "sys: dlqr solves LQ over a lossy actuator link with the "
                    "state measured (period 1, sensor_loss=0, no delays); "
                    "for schedules, sensor losses or delays design with "
                    "h2syn (z = [Q^½ x; R^½ u]) or passivesyn")
            sys._refuse_budget("dlqr (LQ in mean)")
            link = sys.actuator_link
            A, B = np.asarray(sys.A, float), np.asarray(sys.B2, float)
            if isinstance(link, GilbertElliott) and not link.is_bernoulli:
                return A, B, link
            return A, B, 1.0 - float(sys.actuator_loss)
        if not isinstance(sys, ct.StateSpace):
            raise ControlArgument(f"sys: expected a discrete-time StateSpace "
                                  f"or (A, B), got {type(sys).__name__}")
        if ct.isctime(sys, strict=True):
            raise ValueError("sys: continuous-time; dlqr needs a discrete-time "
                             "plant (sample it first)")
        A, B = np.asarray(sys.A, float), np.asarray(sys.B, float)
    elif len(args) == 2:
        A = matrix(args[0], "A", (None, None))
        B = matrix(args[1], "B", (A.shape[0], None))
    else:
        raise ControlArgument(f"dlqr: expected (sys, Q, R) or (A, B, Q, R), "
                              f"got {len(args) + 2} positional arguments")
    if A.shape[0] != A.shape[1]:
        raise ControlDimension(f"A: expected a square matrix, got {A.shape}")
    if arrival is not None and not isinstance(arrival, (int, float,
                                                         np.number)):
        raise ValueError(
            f"arrival: expected a probability in (0, 1], got "
            f"{type(arrival).__name__}; a bursty link is given as "
            f"nss(..., actuator_loss=gilbert_elliott(...))")
    nu = 1.0 if arrival is None else float(arrival)
    if not 0.0 < nu <= 1.0 or isinstance(arrival, bool):
        raise ValueError(f"arrival: expected a probability in (0, 1], got "
                         f"{arrival!r}")
    return A, B, nu


def dlqr(*args: Any, arrival: float | None = None,
         full_output: bool = False, **kwargs: Any) -> tuple:
    """Optimal LQ state feedback over a lossy actuator link.

    ``dlqr(sys, Q, R)`` or ``dlqr(A, B, Q, R)`` as :func:`control.dlqr`,
    for ``x⁺ = A x + θ B u``, ``θ = 1`` with probability ``arrival``
    (TCP-like: the controller knows past arrivals), minimising
    ``E Σ (xᵀQx + θ uᵀRu)``. The gain is for ``u = -K x`` (see
    :ref:`guide-sign`). The modified
    Riccati equation is solved as an equation (policy iteration from a
    stabilising gain, each step an exact solve; :ref:`theory-estimation`),
    and its answer is checked: the residual, and the mean-square stability
    of the lossy loop, proven.

    Parameters
    ----------
    *args
        ``(sys, Q, R)`` or ``(A, B, Q, R)``. ``sys``: a discrete-time
        ``StateSpace`` (its ``A``, ``B``), or a ``NetworkedStateSpace``
        whose actuator link gives the law of the arrivals (period 1, no
        sensor loss, no delays): Bernoulli, ``arrival = 1 -
        actuator_loss``, or bursty (Gilbert–Elliott); its ``B2`` is ``B``.
        ``Q``, ``R``: state and input weights, ``Q ⪰ 0``, ``R ≻ 0``.
    arrival : float, optional
        Probability that a command arrives, in (0, 1] (default 1: the
        loss-free :func:`control.dlqr`). A bursty link is given through a
        ``NetworkedStateSpace``.
    full_output : bool, optional
        Also return how the equation was solved and its checks.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    K : ndarray
        The gain, ``u = -K x``. Over a bursty link, one per previous link
        state (lost, delivered), shape ``(2, m, n)``: the controller knows
        from the acknowledgement whether its last command arrived. With one
        actuator link the two are equal (only a command that arrives acts,
        so the state ``ℓ`` scales ``H_ℓ`` and ``g_ℓ`` alike); the cost
        ``S_ℓ`` is what the knowledge changes.
    S : ndarray
        The solution of the modified Riccati equation (cost ``x₀ᵀSx₀``;
        with unit process noise ``B1`` the stationary cost is
        ``tr(B1ᵀ S B1)``). Over a bursty link the coupled equations' ``S_ℓ``
        per previous link state, shape ``(2, n, n)`` (stationary cost
        ``Σ_ℓ π_ℓ tr(B1ᵀ S_ℓ B1)``).
    E : ndarray
        Eigenvalues of the mean closed loop ``A - ν B K``; over a bursty
        link those of ``A - B K_ℓ`` (commands arriving), shape ``(2, n)``.
    info : RiccatiSolution
        Only with ``full_output=True``: the residual, the certified
        mean-square rate of the loop and how the equation was solved.

    Raises
    ------
    SynthesisError
        ``reason='not_mss'`` (also a ``ValueError``) if ``arrival`` is at or
        below the critical probability: the message states it, exact (a
        closed form: ``B`` reaching the whole unstable subspace, or one
        input) or as the bracket of a certified bisection; over a bursty
        link, if the link stays down too long for the plant.
        ``'not_found'`` or ``'not_verified'`` (nothing proven) if no
        stabilising start was found or the answer fails its checks.
    ValueError
        A bad weight or arrival probability.

    References
    ----------
    .. [1] L. Schenato, B. Sinopoli, M. Franceschetti, K. Poolla and
           S. Sastry, "Foundations of control and estimation over lossy
           networks", *Proceedings of the IEEE* 95(1), 2007.
    .. [2] N. Elia, "Remote stabilization over fading channels", *Systems &
           Control Letters* 54(3), 2005.

    Examples
    --------
    ``x⁺ = 1.2 x + θ u``, ``q = r = 1``, half the commands lost:

    >>> K, S, E = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.5)
    >>> round(float(S[0, 0]), 10)
    5.7626154148

    Just above the critical probability ``1 - 1/1.2² = 0.305556`` the cost
    is large but finite:

    >>> K, S, E = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]],
    ...                    arrival=0.305656)
    >>> round(float(S[0, 0]))
    9956
    """
    no_extra_kwargs("dlqr", kwargs)
    full_output = flag(full_output, "full_output")
    if len(args) not in (3, 4):
        raise ControlArgument(f"dlqr: expected (sys, Q, R) or (A, B, Q, R), "
                              f"got {len(args)} positional arguments")
    A, B, nu = _plant(args[:-2], arrival)
    n, m = B.shape
    Q = matrix(args[-2], "Q", (n, n))
    R = matrix(args[-1], "R", (m, m))
    Q, R = 0.5 * (Q + Q.T), 0.5 * (R + R.T)
    if np.linalg.eigvalsh(Q)[0] < -1e-12 * max(1.0, np.abs(Q).max()):
        raise ValueError("Q: expected a positive semidefinite weight")
    if np.linalg.eigvalsh(R)[0] <= 0:
        raise ValueError("R: expected a positive definite weight")
    if isinstance(nu, GilbertElliott):
        K, S, E, sol = _bursty(A, B, Q, R, nu)
    else:
        K, S, E, sol = _bernoulli(A, B, Q, R, nu)
    return (K, S, E, sol) if full_output else (K, S, E)


def _bernoulli(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray,
               nu: float) -> tuple:
    """The MARE of one Bernoulli actuator link, as the dual estimator's."""
    if nu < 1.0:
        # a closed-form threshold refuses at once, before any solve
        low = _closed_threshold(A, B)
        if low is not None and nu <= low.upper:
            _refuse(nu, low, "")
    eq = _mare.Equation(A.T, B.T, Q, R, *_mare.bernoulli(nu))
    if nu == 1.0:
        quick = _loss_free(eq, A, B, Q, R)
        if quick is not None:
            return quick
    try:
        sol = _mare.solve(eq)
    except MareError as err:
        if err.reason != NOT_MSS:
            raise
        _refuse(nu, critical_control_arrival(A, B), str(err))
    S, K = sol.X[0], sol.gains[0].T
    link = "loss-free" if nu == 1.0 else f"Bernoulli, arrival {nu:g}"
    return K, S, np.linalg.eigvals(A - nu * B @ K), sol.result(link)


def _loss_free(eq: _mare.Equation, A: np.ndarray, B: np.ndarray,
               Q: np.ndarray, R: np.ndarray) -> tuple | None:
    """The loss-free equation (the plain DARE) by SciPy's generalized
    Schur solver, checked as every answer of the equation kernel is: the
    residual of the equation, and the loop's mean-square stability proven
    by the Collatz–Wielandt bound of ``𝓛(Y) = A_Kᵀ Y A_K``, ``A_K = A - B
    K``, at ``Y = S`` (``S = A_Kᵀ S A_K + Q + KᵀRK``: the bound is below 1
    when ``Q + KᵀRK ≻ 0``) or else at the Stein solution of ``Y = A_Kᵀ Y
    A_K + I``. The spectral radius of that map is exactly ``ρ(A_K)²``
    (the eigenvalues of ``A_K ⊗ A_K`` are the products of ``A_K``'s).
    None when the solver fails or a check does not pass: the caller then
    solves the equation by the kernel's own route."""
    try:
        S = sla.solve_discrete_are(A, B, Q, R)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(S)):
        return None
    S = 0.5 * (S + S.T)
    X = S[None]
    L = eq.gains(X)                           # Kᵀ, the dual's gain
    # eq.residual(X), its gain computed once
    g = eq.apply(L, X) + eq.forcing(L)
    g = 0.5 * (g + g.transpose(0, 2, 1))
    residual = float(np.linalg.norm(X - g) / max(1.0, np.linalg.norm(X)))
    if not residual <= _mare.RESIDUAL:
        return None
    K = L[0].T
    E = np.linalg.eigvals(A - B @ K)
    radius = float(np.max(np.abs(E))) ** 2 if E.size else 0.0
    bracket = None
    for Y in _certificates(S, A - B @ K):
        bracket = _mare.collatz_wielandt(eq, L, Y[None], steps=1)
        if bracket is not None and bracket[1] < 1.0:
            break
        bracket = None
    if bracket is None:
        return None
    sol = _mare.Solution(X, L, residual, bracket[1], bracket[0], radius,
                         "loss-free Riccati equation (generalized Schur)",
                         0, "schur")
    return K, S, E, sol.result("loss-free")


def _certificates(S: np.ndarray, Acl: np.ndarray) -> Iterator[np.ndarray]:
    """Candidates ``Y ≻ 0`` for the stability bound of the loss-free loop:
    the cost ``S``, then the Stein solution of ``Y = A_Kᵀ Y A_K + I``."""
    yield S
    try:
        Y = sla.solve_discrete_lyapunov(Acl.T, np.eye(Acl.shape[0]))
    except (ValueError, np.linalg.LinAlgError):
        return
    if np.all(np.isfinite(Y)):
        yield 0.5 * (Y + Y.T)


def _closed_threshold(A: np.ndarray, B: np.ndarray
                      ) -> _mare.Threshold | None:
    """The critical probability when a closed form gives it, else None."""
    if _mare.undetectable(A.T, B.T):
        return None
    if _mare.closed_form_gain(A.T, B.T) is None and B.shape[1] != 1:
        return None
    return critical_control_arrival(A, B)


def _refuse(nu: float, th: _mare.Threshold, why: str) -> None:
    if not th.exact and nu >= th.upper:
        # a gain is certified at th.upper and solvability only grows with
        # the arrivals: a solution exists, the solver did not reach it
        raise MareError(
            f"arrival: {nu:g} is above the certified critical probability "
            f"{th.upper:.6g}, so a stabilising solution exists, but no "
            f"stabilising start was found ({why}): the solver did not "
            f"reach it", NOT_FOUND, dict(arrival=nu, critical=th.upper))
    raise MareError(
        f"arrival: {nu:g} is at or below the {_threshold_text(th)}: no gain "
        f"makes the lossy loop mean-square stable, so the expected cost is "
        f"unbounded; more arrivals are needed"
        + (f" ({why})" if why else ""), NOT_MSS,
        dict(arrival=nu, critical=th.upper, critical_lower=th.lower,
             exact=th.exact))


def _bursty(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray,
            link: GilbertElliott) -> tuple:
    """TCP-like LQ over a Gilbert–Elliott actuator link: the coupled
    Riccati equations of the previous link state ``ℓ`` (0 lost, 1
    delivered),

    ``S_ℓ = Q + Σ_i T[ℓ, i] Aᵀ S_i A - T[ℓ, 1] AᵀS_1B (BᵀS_1B + R)⁻¹
    BᵀS_1A``, ``K_ℓ = (BᵀS_1B + R)⁻¹ BᵀS_1A``

    (only a delivered command acts, so both gains are equal), the dual of
    the estimator's with the link's forward chain: weights ``a = T``,
    ``b = T`` on the delivered column (:ref:`theory-estimation`)."""
    T = np.asarray(link.transition, float)
    b = T * np.array([0.0, 1.0])[None, :]
    eq = _mare.Equation(A.T, B.T, Q, R, T, b)
    try:
        sol = _mare.solve(eq)
    except MareError as err:
        if err.reason != NOT_MSS:
            raise
        raise MareError(
            f"sys: over this bursty link (fail {link.fail:g}, recover "
            f"{link.recover:g}) no gain makes the loop mean-square stable "
            f"({err}): the expected cost is unbounded for every controller "
            f"(the link stays down too long for the plant); shorter bursts "
            f"or fewer losses are needed", NOT_MSS, err.figures) from None
    S = sol.X
    K = np.array([sol.gains[1].T, sol.gains[1].T])
    E = np.array([np.linalg.eigvals(A - B @ K[ell]) for ell in range(2)])
    return K, S, E, sol.result(f"Gilbert–Elliott, fail {link.fail:g}, "
                               f"recover {link.recover:g}")
