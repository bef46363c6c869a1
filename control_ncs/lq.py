"""Linear-quadratic control over a lossy actuator link (:ref:`theory-performance`).

With TCP-like acknowledgements the controller knows whether each command
arrived; the state is measured. The optimal cost-to-go is ``xᵀSx`` with
``S`` the stabilising solution of the *modified* Riccati equation of
Schenato et al. (2007),

``S = AᵀSA + Q - ν AᵀSB (BᵀSB + R)⁻¹ BᵀSA``,

``ν`` the probability that a command arrives. The optimal gain is the
loss-free formula at this ``S``; it exists only above a critical arrival
probability (for a scalar plant ``ν > 1 - 1/a²``). Over a bursty
(Gilbert–Elliott) link the cost-to-go depends on the previous link state,
and the equations are coupled (:func:`_bursty`).
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import matrix, no_extra_kwargs
from .jump import jss
from .network import GilbertElliott
from .plant import NetworkedStateSpace
from .stability import ms_radius

__all__ = ["dlqr"]

#: Value iteration: at most this many steps, stopped when the relative
#: change is below ``CONVERGED``; above ``DIVERGED`` times the data's scale
#: the iteration has no fixed point (below the critical probability).
MAX_ITERATIONS = 100_000
CONVERGED = 1e-14
DIVERGED = 1e12
#: Value-iteration steps per trial of the critical probability's bisection.
BISECTION_ITERATIONS = 5000


def _iterate(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray,
             nu: float, iterations: int = MAX_ITERATIONS,
             converged: float = CONVERGED) -> np.ndarray | None:
    """The stabilising solution by value iteration from ``S = Q``, or None
    if the iteration diverges (or has not converged in ``iterations``)."""
    S = Q.copy()
    scale = max(1.0, float(np.linalg.norm(Q)), float(np.linalg.norm(R)))
    for _ in range(iterations):
        BS = B.T @ S
        G = np.linalg.solve(BS @ B + R, BS @ A)
        new = A.T @ S @ A + Q - nu * (A.T @ S @ B) @ G
        new = 0.5 * (new + new.T)
        if not np.all(np.isfinite(new)) or np.linalg.norm(new) > \
                DIVERGED * scale:
            return None
        if np.linalg.norm(new - S) <= converged * max(
                1.0, float(np.linalg.norm(new))):
            return new
        S = new
    return None


def critical_arrival(A: np.ndarray, B: np.ndarray, Q: np.ndarray,
                     R: np.ndarray) -> tuple[float, bool]:
    """The arrival probability below which no solution exists, and whether
    it is exact: ``1 - 1/ρ(A)²`` when ``B`` is square and invertible
    (Schenato et al. 2007), else by bisection on convergence to 1e-4
    (the iteration slows down near the critical value; each trial is cut
    at ``BISECTION_ITERATIONS``, so the value is approximate)."""
    if B.shape[0] == B.shape[1] and np.linalg.cond(B) < 1e12:
        radius = float(np.abs(np.linalg.eigvals(A)).max())
        return (max(0.0, 1.0 - 1.0 / radius ** 2) if radius > 0 else 0.0,
                True)
    lo, hi = 0.0, 1.0
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        found = _iterate(A, B, Q, R, mid, BISECTION_ITERATIONS, 1e-8)
        lo, hi = (lo, mid) if found is not None else (mid, hi)
    return hi, False


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


def dlqr(*args: Any, arrival: float | None = None, **kwargs: Any
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Optimal LQ state feedback over a lossy actuator link.

    ``dlqr(sys, Q, R)`` or ``dlqr(A, B, Q, R)`` as :func:`control.dlqr`,
    for ``x⁺ = A x + θ B u``, ``θ = 1`` with probability ``arrival``
    (TCP-like: the controller knows past arrivals), minimising
    ``E Σ (xᵀQx + θ uᵀRu)``. The gain is for ``u = -K x``.

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

    Raises
    ------
    ValueError
        If ``arrival`` is at or below the critical probability (the message
        gives it), or the solution fails its checks (residual, mean-square
        stability of the loop).

    References
    ----------
    .. [1] L. Schenato, B. Sinopoli, M. Franceschetti, K. Poolla and
           S. Sastry, "Foundations of control and estimation over lossy
           networks", *Proceedings of the IEEE* 95(1), 2007.

    Examples
    --------
    ``x⁺ = 1.2 x + θ u``, ``q = r = 1``, half the commands lost:

    >>> import control_ncs as ncs
    >>> K, S, E = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.5)
    >>> round(float(S[0, 0]), 10)
    5.7626154148
    """
    no_extra_kwargs("dlqr", kwargs)
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
        return _bursty(A, B, Q, R, nu)
    S = _iterate(A, B, Q, R, nu)
    if S is None:
        critical, exact = critical_arrival(A, B, Q, R)
        about = "" if exact else "about "
        raise ValueError(
            f"arrival: {nu:g} is at or below the critical arrival probability "
            f"{about}{critical:.5g} (loss {1 - critical:.5g}): the expected "
            f"cost is unbounded for every controller; more arrivals are "
            f"needed")
    K = np.linalg.solve(B.T @ S @ B + R, B.T @ S @ A)
    residual = A.T @ S @ A + Q - nu * (A.T @ S @ B) @ K - S
    if np.linalg.norm(residual) > 1e-9 * max(1.0, float(np.linalg.norm(S))):
        raise ValueError(f"dlqr: the Riccati residual "
                         f"{np.linalg.norm(residual):.3g} fails the check")
    # the loop x⁺ = (A - θ B K) x must be mean-square stable
    loop = jss([A - B @ K, A], np.zeros((n, 1)), np.zeros((1, n)),
               np.zeros((1, 1)), [nu, 1 - nu])
    if not ms_radius(loop) < 1.0:
        raise ValueError("dlqr: the gain does not make the lossy loop "
                         "mean-square stable (the Riccati solution is not the "
                         "stabilising one)")
    return K, S, np.linalg.eigvals(A - nu * B @ K)


def _bursty(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray,
            link: GilbertElliott
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """TCP-like LQ over a Gilbert–Elliott actuator link: the coupled
    Riccati equations of the previous link state ``ℓ`` (0 lost, 1
    delivered), by value iteration from ``S_ℓ = Q``,

    ``S_ℓ = Q + Aᵀ S̄_ℓ A - g_ℓᵀ H_ℓ⁻¹ g_ℓ``, ``S̄_ℓ = Σ_i T[ℓ, i] S_i``,
    ``H_ℓ = Σ_i T[ℓ, i] θ_i (R + Bᵀ S_i B)``, ``g_ℓ = Σ_i T[ℓ, i] θ_i Bᵀ
    S_i A``, ``K_ℓ = H_ℓ⁻¹ g_ℓ`` (:ref:`theory-performance`)."""
    T = np.asarray(link.transition, float)
    theta = np.array([0.0, 1.0])
    n = A.shape[0]
    S = np.array([Q, Q])
    scale = max(1.0, float(np.linalg.norm(Q)), float(np.linalg.norm(R)))
    K = np.zeros((2, B.shape[1], n))
    def step(S: np.ndarray) -> np.ndarray:
        """One step of the coupled equations (and the gains ``K``)."""
        new = np.empty_like(S)
        for ell in range(2):
            t = T[ell] * theta
            H = sum(t[i] * (R + B.T @ S[i] @ B) for i in range(2))
            g = sum(t[i] * B.T @ S[i] @ A for i in range(2))
            K[ell] = np.linalg.solve(H, g)
            Sbar = T[ell, 0] * S[0] + T[ell, 1] * S[1]
            new[ell] = Q + A.T @ Sbar @ A - g.T @ K[ell]
        return 0.5 * (new + new.transpose(0, 2, 1))

    for _ in range(MAX_ITERATIONS):
        new = step(S)
        if not np.all(np.isfinite(new)) or np.linalg.norm(new) > \
                DIVERGED * scale:
            raise ValueError(
                f"sys: over this bursty link (fail {link.fail:g}, recover "
                f"{link.recover:g}) the coupled Riccati iteration diverges: "
                f"the expected cost is unbounded for every controller (the "
                f"link stays down too long for the plant); shorter bursts "
                f"or fewer losses are needed")
        done = np.linalg.norm(new - S) <= CONVERGED * max(
            1.0, float(np.linalg.norm(new)))
        S = new
        if done:
            break
    else:
        raise ValueError("dlqr: the coupled Riccati iteration did not "
                         "converge")
    residual = step(S) - S                  # also sets K from S
    if np.linalg.norm(residual) > 1e-9 * max(1.0, float(np.linalg.norm(S))):
        raise ValueError(f"dlqr: the coupled Riccati residual "
                         f"{np.linalg.norm(residual):.3g} fails the check")
    # the loop with gains on the previous link state must be mean-square
    # stable: Markov modes (ℓ, i), x⁺ = (A - θ_i B K_ℓ) x
    modes = [A - theta[i] * B @ K[ell] for ell in range(2) for i in range(2)]
    chain = np.kron(np.ones((2, 1)), np.eye(2))     # (ℓ, i) → (i, ·)
    pair_T = np.array([[T[i, j] if chain[a, i] else 0.0
                        for i in range(2) for j in range(2)]
                       for a in range(4)])
    loop = jss(np.array(modes), np.zeros((n, 1)), np.zeros((1, n)),
               np.zeros((1, 1)), None, transition=pair_T)
    if not ms_radius(loop) < 1.0:
        raise ValueError("dlqr: the gains do not make the bursty loop "
                         "mean-square stable (the Riccati solution is not "
                         "the stabilising one)")
    return K, S, np.array([np.linalg.eigvals(A - B @ K[ell])
                           for ell in range(2)])
