"""Estimation and LQG over lossy links: the Kalman filter with intermittent
observations (:ref:`theory-estimation`).

A measurement ``y = C x + v`` reaches the estimator only when the sensor
link delivers it. :func:`dlqe` is :func:`control.dlqe` for that link: the
stationary gain applied on arrival, with the *a priori* error covariance
``S``, the stabilising solution of the modified algebraic Riccati equation
(MARE) of Sinopoli et al. (2004), exact for this estimator and an upper
bound on the time-varying Kalman filter's expected covariance; over a
Gilbert–Elliott link the coupled equations of the link's states.
:func:`critical_arrival` gives the arrival probabilities below which the
error cannot stay bounded (for any estimator, for a fixed gain, for the
time-varying filter where it is known); :func:`isestimable` decides a given
link, bursty included. :func:`lqg` closes the loop over both links: with
acknowledgements (TCP-like) separation holds and the cost has a closed
form; without (UDP-like) the best controller of the estimator's structure
is searched on the exact cost, above the TCP-like optimum, a proven lower
bound. The equations are solved by :mod:`control_ncs._mare`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from . import _lqg_loops, _lqg_sampled, _mare
from ._checks import flag, matrix, no_extra_kwargs
from ._mare import MareError, RiccatiSolution
from ._results import CertifiedResult
from .exceptions import (NOT_FOUND, NOT_MSS, NOT_VERIFIED,
                         CertificationError, SynthesisError)
from .gain import PeriodicGain
from .jump import jss
from .lq import dlqr
from .network import GilbertElliott
from .performance import norm
from .plant import NetworkedStateSpace, nss
from .stability import ms_radius
from .loop import feedback

__all__ = ["dlqe", "critical_arrival", "CriticalArrival", "isestimable",
           "lqg", "LQGResult", "RiccatiSolution"]


# -- arguments ------------------------------------------------------------------
def _sensor_plant(P: NetworkedStateSpace, who: str) -> None:
    """Refuse what the estimation of this module does not cover."""
    delayed = P.sensor_delay is not None or P.actuator_delay is not None \
        or P.input_delay is not None
    if delayed or not P.sensor_schedule.pattern.all():
        raise ControlArgument(
            f"P: {who} covers a sensor link that carries every measurement "
            f"at every step (no schedule, no delays); for schedules or "
            f"delays use estimator_gain and feedback")


def _system(args: tuple, arrival: Any, who: str
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """``(A, G, C, link)`` from ``(P,)``, ``(sys,)`` or ``(A, G, C)``;
    ``link`` is an arrival probability or a bursty GilbertElliott link."""
    if len(args) == 1:
        sys = args[0]
        if isinstance(sys, NetworkedStateSpace):
            if arrival is not None:
                raise ControlArgument("arrival: a NetworkedStateSpace carries "
                                      "its sensor link; do not give arrival")
            _sensor_plant(sys, who)
            link = sys.sensor_link
            if not (isinstance(link, GilbertElliott)
                    and not link.is_bernoulli):
                link = 1.0 - float(sys.sensor_loss)
            return (np.asarray(sys.A, float), np.asarray(sys.B1, float),
                    np.asarray(sys.C2, float), link)
        if not isinstance(sys, ct.StateSpace):
            raise ControlArgument(f"sys: expected a discrete-time StateSpace "
                                  f"or matrices, got {type(sys).__name__}")
        if ct.isctime(sys, strict=True):
            raise ValueError(f"sys: continuous-time; {who} needs a "
                             f"discrete-time plant (sample it first)")
        A, G, C = (np.asarray(M, float) for M in (sys.A, sys.B, sys.C))
    elif len(args) == 3:
        A = matrix(args[0], "A", (None, None))
        G = matrix(args[1], "G", (A.shape[0], None))
        C = matrix(args[2], "C", (None, A.shape[0]))
    else:
        raise ControlArgument(f"{who}: expected (P, QN, RN), (sys, QN, RN) "
                              f"or (A, G, C, QN, RN), got {len(args) + 2} "
                              f"positional arguments")
    if A.shape[0] != A.shape[1]:
        raise ControlDimension(f"A: expected a square matrix, got {A.shape}")
    if isinstance(arrival, GilbertElliott) or (
            arrival is not None and not isinstance(arrival, (int, float,
                                                             np.number))):
        raise ValueError(f"arrival: expected a probability in (0, 1], got "
                         f"{type(arrival).__name__}; a bursty link is given "
                         f"as nss(..., sensor_loss=gilbert_elliott(...))")
    lam = 1.0 if arrival is None else float(arrival)
    if isinstance(arrival, bool) or not 0.0 < lam <= 1.0:
        raise ValueError(f"arrival: expected a probability in (0, 1], got "
                         f"{arrival!r}")
    return A, G, C, lam


def _covariances(G: np.ndarray, C: np.ndarray, QN: Any, RN: Any
                 ) -> tuple[np.ndarray, np.ndarray]:
    QN = matrix(QN, "QN", (G.shape[1], G.shape[1]))
    RN = matrix(RN, "RN", (C.shape[0], C.shape[0]))
    QN, RN = 0.5 * (QN + QN.T), 0.5 * (RN + RN.T)
    if np.linalg.eigvalsh(QN)[0] < -1e-12 * max(1.0, np.abs(QN).max()):
        raise ValueError("QN: expected a positive semidefinite covariance")
    if np.linalg.eigvalsh(RN)[0] <= 0:
        raise ValueError("RN: expected a positive definite covariance")
    return QN, RN


def _reversed_chain(link: GilbertElliott) -> np.ndarray:
    """``T̃[j, i] = π_i T[i, j] / π_j = P(γ_{k-1} = i | γ_k = j)``."""
    T = np.asarray(link.transition, float)
    pi = np.array([link.fail, link.recover]) / (link.fail + link.recover)
    return (pi[None, :] * T.T) / pi[:, None]


def _weights(link: Any, previous: bool) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's weights ``(a, b)`` for the link (:mod:`._mare`)."""
    if not previous and not isinstance(link, GilbertElliott):
        return _mare.bernoulli(link)
    if isinstance(link, GilbertElliott):
        Tr = _reversed_chain(link)
    else:                       # a memoryless chain: rows (1 - λ, λ)
        Tr = np.tile([1.0 - link, link], (2, 1))
    if previous:                # gains L_ℓ on the previous arrival ℓ
        return Tr, Tr * np.array([[0.0], [1.0]])
    return Tr, Tr * np.array([[0.0, 1.0]])      # one gain, on arrival


def _link_text(link: Any) -> str:
    if isinstance(link, GilbertElliott):
        return (f"Gilbert–Elliott, fail {link.fail:g}, recover "
                f"{link.recover:g}")
    return "loss-free" if link == 1.0 else f"Bernoulli, arrival {link:g}"


# -- dlqe ----------------------------------------------------------------------
def dlqe(*args: Any, arrival: float | None = None,
         previous_arrival: bool = False, full_output: bool = False,
         **kwargs: Any) -> tuple:
    """Stationary Kalman filter over a lossy sensor link.

    ``dlqe(A, G, C, QN, RN, arrival=λ)`` or ``dlqe(P, QN, RN)`` as
    :func:`control.dlqe`, for ``x⁺ = A x + B u + G w``, ``y = C x + v``
    with the measurement delivered with probability ``λ`` (or by the
    sensor link of a ``NetworkedStateSpace``, Bernoulli or Gilbert–Elliott)
    and the predictor ``x̂⁺ = A x̂ + B u + γ L (y - C x̂)``, ``γ`` the
    arrival. ``S`` solves the modified algebraic Riccati equation
    ``S = A S Aᵀ + W - λ A S Cᵀ (C S Cᵀ + RN)⁻¹ C S Aᵀ``, ``W = G QN Gᵀ``,
    as an equation (policy iteration from a stabilising gain, each step an
    exact solve; :ref:`theory-estimation`); its residual and the
    mean-square stability of the error loop are checked.

    Parameters
    ----------
    *args
        ``(A, G, C, QN, RN)``, ``(sys, QN, RN)`` (a discrete-time
        ``StateSpace``: ``G = sys.B``, ``C = sys.C``, as python-control), or
        ``(P, QN, RN)`` with ``P`` a ``NetworkedStateSpace``: ``G = P.B1``,
        ``C = P.C2``, the arrivals from its sensor link (every sensor in one
        packet, no schedule, no delays). ``QN ⪰ 0``, ``RN ≻ 0``: process and
        measurement noise covariances.
    arrival : float, optional
        Probability that a measurement arrives, in (0, 1] (default 1: the
        loss-free :func:`control.dlqe`). A bursty link is given through a
        ``NetworkedStateSpace``.
    previous_arrival : bool, optional
        Gains that also read whether the previous measurement arrived,
        ``L_ℓ`` for ``ℓ = γ_{k-1}``: a jump estimator with one step of loss
        history, better than one gain also on a memoryless link.
    full_output : bool, optional
        Also return how the equation was solved and its checks.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    L : ndarray, shape (n, p)
        The predictor gain used when a measurement arrives (python-control's
        ``L``; the filter form the estimator controller reads is ``L_f = S
        Cᵀ (C S Cᵀ + RN)⁻¹``, ``L = A L_f``). With ``previous_arrival``, shape
        ``(2, n, p)``: ``L_ℓ`` after a loss (``ℓ = 0``) and after an arrival.
    S : ndarray, shape (n, n)
        The stationary *a priori* error covariance of this estimator: exact
        for it, the best of any fixed gain, and an upper bound on the
        time-varying Kalman filter's expected covariance. Over a bursty link,
        shape ``(2, n, n)``: ``E[e eᵀ | γ_k = j]`` given the current arrival
        ``j`` (lost, arrived); with ``previous_arrival`` ``E[e eᵀ | γ_{k-1} =
        ℓ]``, the covariance each ``L_ℓ`` is designed for. The unconditional
        covariance is ``π_0 S[0] + π_1 S[1]``.
    E : ndarray
        Eigenvalues of ``A - L C`` (python-control's ``E``: the error loop
        when a measurement arrives), shape ``(n,)``, or ``(2, n)`` per gain.
    info : RiccatiSolution
        Only with ``full_output=True``.

    Raises
    ------
    SynthesisError
        ``reason='not_mss'`` (also a ``ValueError``) when no fixed gain keeps
        the error bounded: the arrival probability is at or below
        ``fixed_gain`` of :func:`critical_arrival` (the message states it),
        or the bursty link stays down too long. ``'not_found'`` or
        ``'not_verified'`` when nothing was found or the answer fails its
        checks (nothing proven).
    ValueError
        A bad covariance or probability, or ``(A, C)`` not detectable.

    References
    ----------
    .. [1] B. Sinopoli, L. Schenato, M. Franceschetti, K. Poolla, M. I.
           Jordan and S. S. Sastry, "Kalman filtering with intermittent
           observations", *IEEE TAC* 49(9), 2004.
    .. [2] S. C. Smith and P. Seiler, "Estimation with lossy measurements:
           jump estimators for jump systems", *IEEE TAC* 48(12), 2003.

    Examples
    --------
    ``x⁺ = 1.5 x + w``, ``y = x + v``, 40 % of the measurements lost:

    >>> L, S, E = ncs.dlqe([[1.5]], [[1.0]], [[1.0]], [[1.0]], [[1.0]],
    ...                    arrival=0.6)
    >>> round(float(S[0, 0]), 9), round(float(L[0, 0]), 9)
    (22.935995893, 1.437332877)

    Without losses it is python-control's:

    >>> L, S, E = ncs.dlqe([[1.5]], [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    >>> bool(np.allclose(S, ct.dlqe([[1.5]], [[1.0]], [[1.0]], [[1.0]],
    ...                             [[1.0]])[1]))
    True
    """
    no_extra_kwargs("dlqe", kwargs)
    previous = flag(previous_arrival, "previous_arrival")
    full_output = flag(full_output, "full_output")
    if len(args) not in (3, 5):
        raise ControlArgument(f"dlqe: expected (P, QN, RN), (sys, QN, RN) or "
                              f"(A, G, C, QN, RN), got {len(args)} "
                              f"positional arguments")
    A, G, C, link = _system(args[:-2], arrival, "dlqe")
    QN, RN = _covariances(G, C, args[-2], args[-1])
    W = G @ QN @ G.T
    W = 0.5 * (W + W.T)
    missed = _mare.undetectable(A, C)
    if missed:
        raise ValueError(
            f"(A, C): the unstable mode(s) "
            f"{', '.join(f'{m:.4g}' for m in missed)} are not seen by the "
            f"measurement: no estimator keeps the error bounded")
    if not isinstance(link, GilbertElliott) and not previous and link < 1:
        th = _closed_threshold(A, C)
        if th is not None and link <= th.upper:
            _refuse(link, th, "")
    a, b = _weights(link, previous)
    eq = _mare.Equation(A, C, W, RN, a, b)
    try:
        sol = _mare.solve(eq)
    except MareError as err:
        if err.reason != NOT_MSS:
            raise
        if isinstance(link, GilbertElliott) or previous:
            raise MareError(
                f"arrival: over this link ({_link_text(link)}) no "
                f"estimator gain{'s' if previous else ''} keep"
                f"{'' if previous else 's'} the error bounded ({err}); more "
                f"arrivals or shorter bursts are needed", NOT_MSS,
                err.figures) from None
        _refuse(link, _mare.threshold(A, C), str(err))
    info = sol.result(_link_text(link))
    if isinstance(link, GilbertElliott) and not previous:
        L, S = sol.gains[1], sol.X
        E = np.linalg.eigvals(A - L @ C)
    elif previous:
        L, S = sol.gains, sol.X
        E = np.array([np.linalg.eigvals(A - Lk @ C) for Lk in L])
    else:
        L, S = sol.gains[0], sol.X[0]
        E = np.linalg.eigvals(A - L @ C)
    return (L, S, E, info) if full_output else (L, S, E)


def _closed_threshold(A: np.ndarray, C: np.ndarray
                      ) -> _mare.Threshold | None:
    """``λ_max`` when a closed form gives it (cheap), else None."""
    if _mare.closed_form_gain(A, C) is None and C.shape[0] != 1:
        return None
    return _mare.threshold(A, C)


def _fixed_gain_text(th: _mare.Threshold) -> str:
    if th.exact:
        why = ("C sees the whole unstable subspace: 1 - 1/ρ(A)²"
               if th.how == "subspace" else
               "one measurement: 1 - 1/Π|μ|² over the unstable "
               "eigenvalues μ")
        return f"fixed_gain = {th.upper:.6g} (exact, {why})"
    return (f"fixed_gain in [{th.lower:.6g}, {th.upper:.6g}] (the upper end "
            f"certified by a gain, the lower end on the LMI solver's word)")


def _refuse(lam: float, th: _mare.Threshold, why: str) -> None:
    if not th.exact and lam >= th.upper:
        # a gain is certified at th.upper and solvability only grows with
        # the arrivals: a solution exists, the solver did not reach it
        raise MareError(
            f"arrival: {lam:g} is above the certified critical probability "
            f"{th.upper:.6g}, so a stabilising solution exists, but no "
            f"stabilising start was found ({why}): the solver did not "
            f"reach it", NOT_FOUND, dict(arrival=lam, critical=th.upper))
    raise MareError(
        f"arrival: {lam:g} is at or below the critical arrival probability "
        f"of a stationary gain, {_fixed_gain_text(th)}: no fixed gain keeps "
        f"the error covariance bounded; more arrivals are needed"
        + (f" ({why})" if why else ""), NOT_MSS,
        dict(arrival=lam, fixed_gain=th.upper, fixed_gain_lower=th.lower,
             exact=th.exact))


# -- critical probabilities ------------------------------------------------------
@dataclass(frozen=True, repr=False)
class CriticalArrival(CertifiedResult):
    """Critical arrival probabilities of a filter over a lossy link.

    Three numbers, ``lower ≤ λ_c ≤ fixed_gain`` (:ref:`theory-estimation`):
    below ``lower`` no estimator keeps the error bounded; above
    ``fixed_gain`` a stationary gain does (:func:`dlqe`); the time-varying
    Kalman filter's threshold ``λ_c`` lies between, known in some cases.

    Attributes
    ----------
    lower : float
        ``max(0, 1 - 1/ρ(A)²)``: necessary for any estimator.
    fixed_gain : float
        ``λ_max``: above it a fixed gain makes the error mean-square stable.
        Exact by a closed form, or the certified upper end of the
        bisection (a gain passed the exact check there).
    fixed_gain_bracket : tuple of float
        ``(lower end, fixed_gain)``: equal for a closed form; otherwise the
        lower end is where the LMI's solver found no gain (its word, not a
        proof).
    fixed_gain_exact : bool
        Whether ``fixed_gain`` is a closed form.
    fixed_gain_how : str
        ``'subspace'`` (``C`` sees the whole unstable subspace: ``1 -
        1/ρ(A)²``), ``'one channel'`` (one measurement: ``1 - 1/Π|μ|²`` over
        the unstable eigenvalues ``μ``, the dual of Elia's fading-channel
        capacity) or ``'bisection'``.
    value : float or None
        ``λ_c`` where it is known, else None.
    exact : bool
        Whether ``λ_c`` is known: ``C`` sees the whole unstable subspace
        (Plarre and Bullo 2009), or the unstable eigenvalues are real, of
        distinct moduli and each seen by ``C`` (the simplest non-degenerate
        systems of Mo and Sinopoli 2012); decided from the structure, never
        from numbers close to each other; or ``fixed_gain`` (certified) is
        no more than ``lower``, which closes the bracket (a double
        integrator seen through its position: both are 0).
    bracket : tuple of float
        ``(value, value)`` when exact, else ``(lower, fixed_gain)``.
    critical_recover : float or None
        Over a Gilbert–Elliott link, when ``C`` sees the whole unstable
        subspace: a stationary gain exists iff ``recover >
        critical_recover = 1 - 1/ρ(A)²``, whatever ``fail``; None otherwise
        (decide a link with :func:`isestimable`).
    trials : int
        LMIs solved by the bisection (0 for a closed form).
    inconclusive : int
        Bisection trials the solver left open, counted as below.
    success : bool
        True.
    status : str
        ``'certified'``.
    message : str
        The numbers in one sentence.

    Examples
    --------
    Sinopoli et al.'s example: one unstable eigenvalue, 1.25, seen by ``C``:

    >>> A = [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]]
    >>> res = ncs.critical_arrival(A, [[1, 0, 2]])
    >>> res.lower, res.fixed_gain, res.value, res.exact
    (0.36, 0.36, 0.36, True)
    """

    lower: float
    fixed_gain: float
    fixed_gain_bracket: tuple
    fixed_gain_exact: bool
    fixed_gain_how: str
    value: float | None
    exact: bool
    bracket: tuple
    critical_recover: float | None
    trials: int
    inconclusive: int

    _repr_fields: ClassVar[tuple[str, ...]] = ("lower", "fixed_gain", "value")

    @property
    def message(self) -> str:
        """The three numbers in one sentence."""
        fg = (f"fixed_gain = {self.fixed_gain:.6g} (exact)"
              if self.fixed_gain_exact else
              f"fixed_gain in [{self.fixed_gain_bracket[0]:.6g}, "
              f"{self.fixed_gain:.6g}]")
        vc = (f"the time-varying filter's threshold is {self.value:.6g}"
              if self.exact else
              f"the time-varying filter's threshold lies in "
              f"[{self.bracket[0]:.6g}, {self.bracket[1]:.6g}]")
        return f"lower = {self.lower:.6g}, {fg}; {vc}"

    def _details(self) -> list[str]:
        out = [f"fixed gain: {self.fixed_gain_how}"
               + (f" ({self.trials} LMIs, {self.inconclusive} left open)"
                  if self.trials else "")]
        if self.critical_recover is not None:
            out.append(f"bursty link: a gain exists iff recover > "
                       f"{self.critical_recover:.6g}")
        return out


def _non_degenerate(A: np.ndarray, C: np.ndarray) -> bool:
    """The simplest non-degenerate structure: the unstable eigenvalues are
    real, of distinct moduli, and each one's eigenvector is seen by ``C``."""
    mu, V = np.linalg.eig(A)
    unstable = np.abs(mu) >= _mare.UNSTABLE
    if not unstable.any():
        return True
    if np.any(mu[unstable].imag != 0):
        return False
    moduli = np.sort(np.abs(mu[unstable].real))
    if np.any(np.diff(moduli) <= 1e-6 * moduli[1:]):
        return False
    scale = max(1.0, float(np.linalg.norm(C, 2)))
    return all(np.linalg.norm(C @ V[:, k].real) > 1e-9 * scale *
               np.linalg.norm(V[:, k].real) for k in np.flatnonzero(unstable))


def critical_arrival(*args: Any, tol: float = 1e-7,
                     **kwargs: Any) -> CriticalArrival:
    """Critical arrival probabilities of a filter over a lossy link.

    ``critical_arrival(A, C)``, ``critical_arrival(sys)`` or
    ``critical_arrival(P)`` (its ``A`` and ``C2``): ``lower = 1 - 1/ρ(A)²``
    (no estimator below), ``fixed_gain`` (Sinopoli et al.'s ``λ_max``: a
    stationary gain exists above it, exact in closed form or by the
    certified bisection of its LMI) and the time-varying filter's threshold
    ``λ_c`` where it is known (:ref:`theory-estimation`).

    Parameters
    ----------
    *args
        ``(A, C)``, a discrete-time ``StateSpace`` (its ``A``, ``C``) or a
        ``NetworkedStateSpace`` (its ``A``, ``C2``). ``(A, C)`` must be
        detectable.
    tol : float, optional
        Width of the bisection's final bracket.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    CriticalArrival

    Raises
    ------
    ValueError
        If ``(A, C)`` is not detectable, or ``tol`` is not in (0, 1).

    References
    ----------
    .. [1] B. Sinopoli et al., "Kalman filtering with intermittent
           observations", *IEEE TAC* 49(9), 2004.
    .. [2] K. Plarre and F. Bullo, "On Kalman filtering for detectable
           systems with intermittent observations", *IEEE TAC* 54(2), 2009.
    .. [3] Y. Mo and B. Sinopoli, "Kalman filtering with intermittent
           observations: tail distribution and critical value", *IEEE TAC*
           57(3), 2012.
    .. [4] N. Elia, "Remote stabilization over fading channels", *Systems &
           Control Letters* 54(3), 2005.

    Examples
    --------
    ``a = 2`` measured directly: ``1 - 1/4``.

    >>> ncs.critical_arrival([[2.0]], [[1.0]]).value
    0.75

    Two unstable modes, 1.5 and 1.2, read by one sensor: the time-varying
    filter needs ``1 - 1/1.5²`` only, a fixed gain ``1 - 1/(1.5·1.2)²``:

    >>> res = ncs.critical_arrival([[1.5, 0], [0, 1.2]], [[1.0, 1.0]])
    >>> round(res.value, 6), round(res.fixed_gain, 6)
    (0.555556, 0.691358)
    """
    no_extra_kwargs("critical_arrival", kwargs)
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol: expected a number in (0, 1), got {tol!r}")
    if len(args) == 1:
        sys = args[0]
        if isinstance(sys, NetworkedStateSpace):
            A, C = np.asarray(sys.A, float), np.asarray(sys.C2, float)
        elif isinstance(sys, ct.StateSpace):
            A, C = np.asarray(sys.A, float), np.asarray(sys.C, float)
        else:
            raise ControlArgument(f"sys: expected a StateSpace or (A, C), got "
                                  f"{type(sys).__name__}")
    elif len(args) == 2:
        A = matrix(args[0], "A", (None, None))
        C = matrix(args[1], "C", (None, A.shape[0]))
    else:
        raise ControlArgument(f"critical_arrival: expected (A, C) or (sys), "
                              f"got {len(args)} positional arguments")
    if A.shape[0] != A.shape[1]:
        raise ControlDimension(f"A: expected a square matrix, got {A.shape}")
    try:
        th = _mare.threshold(A, C, tol=float(tol))
    except ValueError as err:
        raise ValueError(f"(A, C): {err}") from None
    rho = _mare.spectral_radius(A)
    lower = max(0.0, 1.0 - 1.0 / rho ** 2) if rho > 0 else 0.0
    subspace = _mare.closed_form_gain(A, C) is not None
    # λ_c lies in [lower, fixed_gain] always: a closed bracket is exact too
    exact = subspace or _non_degenerate(A, C) or th.upper <= lower
    return CriticalArrival(
        lower=lower, fixed_gain=th.upper,
        fixed_gain_bracket=(th.lower, th.upper), fixed_gain_exact=th.exact,
        fixed_gain_how=th.how, value=lower if exact else None, exact=exact,
        bracket=(lower, lower) if exact else (lower, th.upper),
        critical_recover=lower if subspace else None, trials=th.trials,
        inconclusive=th.inconclusive)


def isestimable(*args: Any, **kwargs: Any) -> bool:
    """Whether a stationary gain keeps the estimation error bounded.

    ``isestimable(P)`` (its ``A``, ``C2`` and sensor link) or
    ``isestimable(A, C, sensor_loss)`` with ``sensor_loss`` a loss
    probability or a :class:`control_ncs.GilbertElliott` link: True when
    some fixed gain makes the error loop mean-square stable (:func:`dlqe`
    then succeeds). Over a bursty link this is a point of the region in
    ``(fail, recover)`` (:ref:`theory-estimation`).

    Parameters
    ----------
    *args
        ``(P,)`` or ``(A, C, sensor_loss)``.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    bool
        Decided exactly by the closed forms (the lost part alone, or ``C``
        seeing the whole unstable subspace: ``(1 - r) ρ(A)² < 1`` over a
        bursty link, whatever ``f``; one measurement over a Bernoulli link);
        otherwise True with a gain that passed the exact check, False when
        the fixed-gain LMI is infeasible (the solver's word).

    Raises
    ------
    CertificationError
        ``reason='solver_failed'`` when the LMI decides neither way.
    ValueError
        If ``(A, C)`` is not detectable.

    Examples
    --------
    ``a = 2`` measured directly over a link losing bursts: an arrival ends
    every loss run, so only ``recover`` matters (``(1 - r)·4 < 1``):

    >>> link = ncs.gilbert_elliott(fail=0.5, recover=0.8)
    >>> ncs.isestimable([[2.0]], [[1.0]], link)
    True
    >>> ncs.isestimable([[2.0]], [[1.0]], ncs.gilbert_elliott(0.01, 0.7))
    False
    """
    no_extra_kwargs("isestimable", kwargs)
    if len(args) == 1 and isinstance(args[0], NetworkedStateSpace):
        P = args[0]
        _sensor_plant(P, "isestimable")
        A, C = np.asarray(P.A, float), np.asarray(P.C2, float)
        link: Any = P.sensor_link
    elif len(args) == 3:
        A = matrix(args[0], "A", (None, None))
        C = matrix(args[1], "C", (None, A.shape[0]))
        link = args[2]
        if not isinstance(link, GilbertElliott):
            loss = float(matrix([[link]], "sensor_loss", (1, 1))[0, 0])
            if not 0.0 <= loss <= 1.0 or isinstance(link, bool):
                raise ValueError(f"sensor_loss: expected a probability in "
                                 f"[0, 1] or a GilbertElliott link, got "
                                 f"{link!r}")
            link = loss
    else:
        raise ControlArgument("isestimable: expected (P) or (A, C, "
                              "sensor_loss)")
    missed = _mare.undetectable(A, C)
    if missed:
        raise ValueError(f"(A, C): the unstable mode(s) "
                         f"{', '.join(f'{m:.4g}' for m in missed)} are not "
                         f"seen by the measurement")
    if isinstance(link, GilbertElliott) and link.is_bernoulli:
        link = link.loss
    if not isinstance(link, GilbertElliott):
        lam = 1.0 - float(link)
        if lam == 0.0:
            return _mare.spectral_radius(A) < _mare.UNSTABLE
        th = _closed_threshold(A, C)
        if th is not None:
            return bool(lam > th.upper)
        weights = _mare.bernoulli(lam)
    else:
        weights = _weights(link, False)
    n, p = A.shape[0], C.shape[0]
    eq = _mare.Equation(A, C, np.eye(n), np.eye(p), *weights)
    try:
        verdict, *_ = _mare.decide(eq)
    except MareError as err:
        raise CertificationError(str(err), err.reason, err.figures) from None
    return bool(verdict)


# -- LQG --------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class LQGResult(CertifiedResult):
    """The cost of an LQG design over lossy links, and its bound.

    Attributes
    ----------
    cost : float
        The loop's exact stationary cost ``lim E(xᵀQx + uᵀRu)``
        (``= ncs.norm(CL, 2)**2``).
    lower_bound : float
        The TCP-like optimum (its closed form, :ref:`theory-estimation`): no
        controller of the estimator's structure does better, with or without
        acknowledgements (a proven bound).
    gap : float
        ``cost - lower_bound`` (0 to rounding for TCP-like).
    closed_form : float
        The TCP-like closed form ``tr(S_c W) + tr((AᵀS_cA + Q - S_c) P̃)``.
    acknowledgements : bool
        TCP-like (True) or UDP-like (False).
    estimation, control : RiccatiSolution
        How the filter's and the controller's modified Riccati equations
        were solved (the TCP-like pair; the UDP-like search starts there).
    ms_radius : float
        The loop's mean-square rate (below 1).
    search : dict
        UDP-like: the local search (``start_cost``, ``iterations``,
        ``gradient_norm``, ``converged``, ``message``; gradient analytic);
        empty for TCP-like.
    success : bool
        True.
    status : str
        ``'certified'``: the cost is the exact figure of a mean-square
        stable loop.
    message : str
        The cost and its gap in one sentence.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             sensor_loss=0.2, actuator_loss=0.1)
    >>> K, CL, J = ncs.lqg(P, [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    >>> round(K.result.cost, 6), round(K.result.gap, 12)
    (4.360314, 0.0)
    """

    cost: float
    lower_bound: float
    gap: float
    closed_form: float
    acknowledgements: bool
    estimation: RiccatiSolution
    control: RiccatiSolution
    ms_radius: float
    search: dict

    _repr_fields: ClassVar[tuple[str, ...]] = ("cost", "lower_bound", "gap")

    @property
    def message(self) -> str:
        """The cost and what bounds it."""
        if self.acknowledgements:
            return (f"certified: the TCP-like optimum, cost {self.cost:.6g} "
                    f"(the closed form {self.closed_form:.6g})")
        return (f"certified: cost {self.cost:.6g}, a local optimum of the "
                f"exact UDP-like cost, {self.gap:.3g} above the proven lower "
                f"bound {self.lower_bound:.6g}")

    def _details(self) -> list[str]:
        out = [f"loop ms_radius {self.ms_radius:.6g}"]
        if self.search:
            out.append(f"search: {self.search.get('iterations')} BFGS "
                       f"iterations from cost "
                       f"{self.search.get('start_cost', np.nan):.6g}, "
                       f"gradient norm "
                       f"{self.search.get('gradient_norm', np.nan):.3g}")
        return out


def _lqg_plant(P: Any) -> tuple[float, float]:
    """The arrival probabilities ``(λ, ν̄)`` of a plant lqg covers."""
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    # a sampled plant's input delay is the continuous design's (checked
    # there); the links are checked here
    _sensor_plant(P if P.input_delay is None or P.continuous is None
                  else P.with_network(input_delay=None), "lqg")
    bursty = [name for name, link in (("sensor", P.sensor_link),
                                      ("actuator", P.actuator_link))
              if isinstance(link, GilbertElliott) and not link.is_bernoulli]
    if bursty or not P.actuator_schedule.pattern.all():
        raise ControlArgument(
            f"P: lqg covers Bernoulli links without schedules (the "
            f"{' and '.join(bursty) or 'actuator'} link is not); design the "
            f"estimator with dlqe and the gain with dlqr or h2syn")
    if np.any(P.D21 != 0):
        raise ControlArgument("P: lqg takes the measurement noise from RN; "
                              "give P with D21 = 0")
    return 1.0 - float(P.sensor_loss), 1.0 - float(P.actuator_loss)


def _cost_plant(P: NetworkedStateSpace, data: _lqg_loops.LoopData
                ) -> NetworkedStateSpace:
    """``P`` with ``w = [process; measurement]`` (unit) and ``z = [Q^½ x;
    R^½ u]``."""
    n, m = data.B.shape
    g, p = data.G.shape[1], data.C.shape[0]
    nq, nr = data.Qh.shape[0], data.Rh.shape[0]
    B = np.hstack([data.G, np.zeros((n, p)), data.B])
    Cz = np.vstack([data.Qh, np.zeros((nr, n)), data.C])
    D = np.zeros((nq + nr + p, g + p + m))
    D[nq:nq + nr, g + p:] = data.Rh
    D[nq + nr:, g:g + p] = data.Rv
    return nss(data.A, B, Cz, D, P.dt, nmeas=p, ncon=m,
               sensor_loss=P.sensor_link, actuator_loss=P.actuator_link,
               inputs=[f"w[{i}]" for i in range(g)] +
               [f"v[{i}]" for i in range(p)] + list(P.input_labels[-m:]),
               outputs=[f"zx[{i}]" for i in range(nq)] +
               [f"zu[{i}]" for i in range(nr)] +
               list(P.output_labels[-p:]),
               states=list(P.state_labels), name=f"{P.name} (LQG cost)")


def lqg(P: NetworkedStateSpace, Q: Any, R: Any, QN: Any, RN: Any,
        acknowledgements: bool = True, **kwargs: Any) -> tuple:
    """LQG control over a lossy sensor link and a lossy actuator link.

    For ``x⁺ = A x + θ2 B2 u + B1 w``, ``w ~ N(0, QN)``, measured as ``y =
    C2 x + v``, ``v ~ N(0, RN)``, each measurement delivered with
    probability ``1 - sensor_loss`` and each command with ``1 -
    actuator_loss`` (Bernoulli links of ``P``), the estimator controller
    minimising ``J = lim E(xᵀQx + uᵀRu)`` (``u`` the applied input)
    (:ref:`theory-estimation`). With acknowledgements (TCP-like) separation
    holds: the filter of :func:`dlqe` and the gain of :func:`dlqr`, with the
    closed-form cost. Without (UDP-like) the estimator adds the command's
    expected effect, separation fails, and the pair ``(K, L_f)`` is found by
    a local search (BFGS, analytic gradient) on the exact cost from the
    TCP-like pair; the TCP-like optimum is a proven lower bound.

    On a plant sampled from a continuous one (``nss(sys_c, ..., dt=h)``)
    the weights are continuous, as Jitterbug's ``lqgdesign`` takes them:
    ``J = lim (1/T) E ∫ (xᵀQx + uᵀRu) dt`` with the input held (and the
    state between the samples counted), ``QN`` the intensity of the
    continuous process noise on ``B1`` and ``RN`` the covariance of the
    sampled measurement's noise. The design is the sampled LQG of van
    Loan's sampled loss (with its cross term) and noise
    (:ref:`theory-lqg-continuous`), and ``J`` the continuous cost of the
    loop (:func:`control_ncs.cost`), checked against the closed form. It
    covers a lossy sensor link (the filter of :func:`dlqe`) and a constant
    input delay ``input_delay=([τ], [1.0])`` on loss-free links (the state
    augmented by ``u_{k-1}``).

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant (its ``A``, ``B1``, ``B2``, ``C2``, ``D21 = 0``) and its
        Bernoulli links; no schedules or delays (but a constant sub-sample
        input delay on a sampled continuous plant). Its performance outputs
        are not used: the cost is ``Q``, ``R``.
    Q, R : array_like
        State and input weights, ``Q ⪰ 0``, ``R ≻ 0`` (continuous ones for
        a sampled continuous plant).
    QN, RN : array_like
        Process (``w``, entering through ``B1``) and measurement noise
        covariances, ``QN ⪰ 0``, ``RN ≻ 0`` (for a sampled continuous
        plant ``QN`` is the continuous noise's intensity).
    acknowledgements : bool, optional
        TCP-like (default) or UDP-like.
    **kwargs
        Reserved: any keyword raises ``TypeError``.

    Returns
    -------
    K : PeriodicGain or control.StateSpace
        ``controller='estimator'``, ``u = K x̂`` (the package's sign,
        :ref:`guide-sign`), with
        its ``estimator_gain`` ``L_f`` (the filter form) and ``K.result`` an
        :class:`LQGResult`. ``feedback(P', K)`` closes the TCP-like loop
        (the estimator's builder adds the command that arrived); the
        UDP-like loop is ``CL``. With a constant input delay: the
        controller as a discrete LTI system on ``[x̂⁻; u_{k-1}]`` (its
        ``result`` attribute the :class:`LQGResult`).
    CL : JumpStateSpace
        The exact loop, ``w = [process; measurement]`` noise of unit
        covariance (scaled inside) and ``z = [Q^½ x; R^½ u]``:
        ``ncs.norm(CL, 2)**2 == J`` (``ncs.cost(CL).cost == J`` for a
        sampled continuous plant, whose process noise is continuous).
        TCP-like: ``feedback`` of ``P`` with that noise and cost; UDP-like:
        the jump system on ``[x; x̂]`` with modes ``(γ, ν)``.
    J : float
        The exact stationary cost (per time unit for a sampled continuous
        plant).

    Raises
    ------
    SynthesisError
        ``'not_mss'`` (also a ``ValueError``) when the filter or the
        controller has no stabilising solution (an arrival probability at
        or below its critical value); ``'not_found'`` when the UDP-like
        search finds no mean-square stable start; ``'not_verified'`` when a
        figure fails its cross-check.
    ControlArgument
        A plant lqg does not cover (bursty links, schedules, delays,
        ``D21 ≠ 0``; with continuous weights, a lossy actuator link, or
        an input delay that is not constant or beside a lossy sensor).

    References
    ----------
    .. [1] L. Schenato, B. Sinopoli, M. Franceschetti, K. Poolla and S. S.
           Sastry, "Foundations of control and estimation over lossy
           networks", *Proceedings of the IEEE* 95(1), 2007.

    Examples
    --------
    ``x⁺ = 1.2 x + θ2 u + w``, ``y = x + v``, 20 % of the measurements and
    10 % of the commands lost, unit weights and noises:

    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             sensor_loss=0.2, actuator_loss=0.1)
    >>> K, CL, J = ncs.lqg(P, [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    >>> round(J, 6), bool(J == ncs.norm(CL, 2) ** 2)
    (4.360314, True)
    >>> K, CL, J = ncs.lqg(P, [[1.0]], [[1.0]], [[1.0]], [[1.0]],
    ...                    acknowledgements=False)
    >>> bool(J >= K.result.lower_bound)
    True

    Continuous weights on the integrator ``ẋ = u + w`` sampled at ``h =
    0.5``, measured with noise of variance 0.01:

    >>> G = ct.ss([[0.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
    ...           [0.0, 0.0]])
    >>> P = ncs.nss(G, nmeas=1, ncon=1, dt=0.5)
    >>> K, CL, J = ncs.lqg(P, [[1.0]], [[0.1]], [[1.0]], [[0.01]])
    >>> round(J, 6), bool(abs(ncs.cost(CL).cost - J) < 1e-9)
    (0.607419, True)
    """
    no_extra_kwargs("lqg", kwargs)
    tcp = flag(acknowledgements, "acknowledgements")
    lam, nu = _lqg_plant(P)
    if P.continuous is not None:
        return _lqg_continuous(P, Q, R, QN, RN, tcp, lam, nu)
    A, B = np.asarray(P.A, float), np.asarray(P.B2, float)
    G, C = np.asarray(P.B1, float), np.asarray(P.C2, float)
    n, m = B.shape
    Q = matrix(Q, "Q", (n, n))
    R = matrix(R, "R", (m, m))
    QN, RN = _covariances(G, C, QN, RN)
    W = G @ QN @ G.T
    _, S, _, est = dlqe(A, G, C, QN, RN, arrival=lam, full_output=True)
    Kc, Sc, _, ctrl = dlqr(A, B, Q, R, arrival=nu, full_output=True)
    Lf = S @ C.T @ np.linalg.inv(C @ S @ C.T + RN)
    P_post = S - lam * Lf @ C @ S          # the a posteriori covariance P̃
    Qs = 0.5 * (Q + Q.T)
    closed = float(np.trace(Sc @ W) + np.trace((A.T @ Sc @ A + Qs - Sc)
                                               @ P_post))
    data = _lqg_loops.LoopData(A, B, G @ _lqg_loops.sqrt_psd(QN), C,
                               _lqg_loops.sqrt_psd(RN),
                               _lqg_loops.sqrt_psd(Qs),
                               _lqg_loops.sqrt_psd(0.5 * (R + R.T)), lam, nu)
    K0 = -Kc
    search: dict[str, Any] = {}
    if tcp:
        CL = feedback(_cost_plant(P, data), PeriodicGain(
            K0, controller="estimator", estimator_gain=Lf))
        J = norm(CL, 2, print_warning=False) ** 2
        if not abs(J - closed) <= 1e-8 * max(1.0, closed):
            raise SynthesisError(
                f"lqg: the loop's exact cost {J:.10g} and the closed form "
                f"{closed:.10g} disagree", NOT_VERIFIED,
                dict(cost=J, closed_form=closed))
        K, Lfin = K0, Lf
    else:
        K, Lfin, J_search, search = _lqg_loops.search(data, K0, Lf)
        if not np.isfinite(J_search):
            raise SynthesisError(
                "lqg: no mean-square stable start of the UDP-like search was "
                "found (the TCP-like pair, its command shrunk)", NOT_FOUND,
                dict(lower_bound=closed))
        CL = _udp_loop(P, data, K, Lfin)
        J = norm(CL, 2, print_warning=False) ** 2
        if J < closed * (1 - 1e-9) or not abs(J - J_search) <= 1e-8 * J:
            raise SynthesisError(
                f"lqg: the UDP-like cost {J:.10g} fails its cross-checks "
                f"(search {J_search:.10g}, lower bound {closed:.10g})",
                NOT_VERIFIED, dict(cost=J, search=J_search,
                                   lower_bound=closed))
    result = LQGResult(cost=J, lower_bound=closed, gap=J - closed,
                       closed_form=closed, acknowledgements=tcp,
                       estimation=est, control=ctrl,
                       ms_radius=ms_radius(CL), search=search)
    gain = PeriodicGain(K, controller="estimator", estimator_gain=Lfin,
                        result=result)
    return gain, CL, J


def _lqg_continuous(P: NetworkedStateSpace, Q: Any, R: Any, QN: Any,
                    RN: Any, tcp: bool, lam: float, nu: float) -> tuple:
    """LQG with continuous weights on a sampled plant
    (:ref:`theory-lqg-continuous`): van Loan's sampled loss and noise, the
    (modified) Kalman filter, the LQ gain with its cross term, the loop's
    continuous cost (:func:`control_ncs.cost`) checked against the closed
    form."""
    from .intersample import cost
    delay = P.input_delay
    n, m = P.nstates, P.ncon
    if nu < 1.0 or (delay is not None and (
            delay.taus.size != 1 or delay.late or lam < 1.0)):
        raise ControlArgument(
            "P: lqg with continuous weights covers a loss-free actuator "
            "link, a lossy sensor link without input delay, and a constant "
            "input delay (input_delay=([tau], [1.0])) on loss-free links "
            "(Jitterbug's lqgdesign); design other timings with h2syn")
    Q = matrix(Q, "Q", (n, n))
    R = matrix(R, "R", (m, m))
    sys_c: Any = P.continuous
    G1 = np.asarray(sys_c.B, dtype=float)[:, :P.B1.shape[1]]
    QN, RN = _covariances(G1, np.asarray(P.C2, float), QN, RN)
    s = _lqg_sampled.sample(P, Q, R, QN, None if delay is None
                            else float(delay.taus[0]))
    C = s.C2
    _, S, _, est = dlqe(s.Phi, np.eye(n), C, s.R1d, RN, arrival=lam,
                        full_output=True)
    Lf = S @ C.T @ np.linalg.inv(C @ S @ C.T + RN)
    L, Sc, ctrl = _lqg_sampled.control(s, dlqr)
    closed = _lqg_sampled.closed_form(s, L, Sc, S - lam * Lf @ C @ S)
    plant = _lqg_sampled.cost_plant(P, s, Q, R, QN, RN)
    K: Any = (_lqg_sampled.delay_controller(s, L, Lf) if delay is not None
              else PeriodicGain(L, controller="estimator", estimator_gain=Lf))
    CL = feedback(plant, K)
    J = cost(CL).cost
    if not abs(J - closed) <= 1e-8 * max(1.0, closed):
        raise SynthesisError(
            f"lqg: the loop's continuous cost {J:.10g} and the closed form "
            f"{closed:.10g} disagree", NOT_VERIFIED,
            dict(cost=J, closed_form=closed))
    result = LQGResult(cost=J, lower_bound=closed, gap=J - closed,
                       closed_form=closed, acknowledgements=tcp,
                       estimation=est, control=ctrl,
                       ms_radius=ms_radius(CL), search={})
    if delay is None:
        K = PeriodicGain(L, controller="estimator", estimator_gain=Lf,
                         result=result)
    else:
        K.result = result
    return K, CL, J


def _udp_loop(P: NetworkedStateSpace, data: _lqg_loops.LoopData,
              K: np.ndarray, Lf: np.ndarray) -> Any:
    """The UDP-like loop as a jump system (modes ``(γ, ν)``)."""
    As, Bs, Cs, Ds, p = _lqg_loops.modes(data, K, Lf, acknowledged=False)
    g, pm = data.G.shape[1], data.C.shape[0]
    nq, nr = data.Qh.shape[0], data.Rh.shape[0]
    states = list(P.state_labels)
    return jss(As, Bs, Cs, Ds, p, P.dt,
               states=states + [f"{s}_hat" for s in states],
               inputs=[f"w[{i}]" for i in range(g)] +
               [f"v[{i}]" for i in range(pm)],
               outputs=[f"zx[{i}]" for i in range(nq)] +
               [f"zu[{i}]" for i in range(nr)],
               name=f"{P.name} (UDP-like LQG)")
