"""The estimator gain of output feedback over a lossy network
(:ref:`theory-output-feedback`).

When the controller measures ``y = C2 x`` and not the state, it keeps an
estimate ``x̂`` corrected by what arrives, ``x̂ ← x̂ + θ1 L_k Σ1,k (y - C2
x̂)``, and sends ``K_k x̂`` (``controller='estimator'`` in
:func:`control_ncs.feedback`). The loop separates: it is mean-square stable
exactly when the estimation-error loop (:func:`estimation_error_loop`, a
property of ``L``, the sensor schedule and ``α1`` alone) and the ``x̂`` loop
(``K``) both are. :func:`estimator_gain` finds ``L_k`` from the exact LMI of
:ref:`theory-output-feedback` and verifies it with the exact ``ms_radius``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from control.exception import ControlArgument

from ._checks import decay_bound, real_array
from ._results import Result
from .exceptions import (CERTIFIED, INFEASIBLE, NOT_VERIFIED, SOLVER_FAILED,
                         SynthesisError)
from ._lifting import unseen_modes
from .jump import JumpStateSpace
from .network import GilbertElliott
from .automata import LossAutomaton
from .plant import NetworkedStateSpace
from .stability import ms_radius

#: Balance the state when its scales spread by this factor (as synthesis)
BALANCE_FROM = 16.0

__all__ = ["EstimatorGain", "estimator_gain", "estimation_error_loop"]


class EstimatorGain(Result):
    """Verified estimator gains ``L_k`` of the estimator controller.

    Parameters
    ----------
    gains : ndarray, shape (N, n, nmeas)
        ``L_k`` per phase; the correction at step ``k`` uses ``L_{k mod N}``.
    ms_radius : float
        Exact per-step mean-square rate of the estimation-error loop.
    lyapunov : ndarray, shape (N, n, n)
        The certificate ``P_k`` of the LMI.
    report : object
        What the solver said (:class:`control_ncs.lmi.SolveReport`).

    Attributes
    ----------
    gains, ms_radius, lyapunov, report
        As above.

    Notes
    -----
    ``numpy.asarray(L)`` is the ``(n, nmeas)`` matrix when ``N = 1`` and the
    stack otherwise, so ``L`` can be passed as ``estimator_gain`` to
    :func:`control_ncs.feedback`.

    Examples
    --------
    ``x⁺ = 1.2 x + w + u`` measured through a sensor that loses 20 % of its
    packets (the error loop's rate is at least ``0.2 · 1.2² = 0.288``):

    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, sensor_loss=0.2)
    >>> L = ncs.estimator_gain(P)
    >>> L.gains.shape, round(L.ms_radius, 4)
    ((1, 1, 1), 0.288)
    """

    def __init__(self, gains: np.ndarray, ms_radius: float,
                 lyapunov: np.ndarray, report: Any = None):
        self.gains = np.asarray(gains, float)
        self.gains.flags.writeable = False
        self.ms_radius = float(ms_radius)
        self.lyapunov = lyapunov
        self.report = report

    @property
    def period(self) -> int:
        """The number of gains ``L_k`` (their period)."""
        return self.gains.shape[0]

    def __array__(self, dtype=None, copy=None):
        out = self.gains[0] if self.period == 1 else self.gains
        return np.array(out, dtype=dtype)

    _repr_fields = ("period", "ms_radius")

    #: Only gains whose error loop passed the exact check are returned.
    success = True
    status = CERTIFIED

    @property
    def message(self) -> str:
        """One sentence: what the exact check of the error loop proved."""
        return (f"certified: the estimation-error loop is mean-square "
                f"stable, ms_radius = {self.ms_radius:.6g}")

    def _details(self) -> list[str]:
        return [f"L_k of shape {self.gains.shape[1:]} over {self.period} "
                f"phase(s)"]


def _check_plant(P: Any) -> NetworkedStateSpace:
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if P.sensor_delay is not None or P.input_delay is not None:
        raise ControlArgument(
            "P: the estimation-error loop here is for a sensor link that "
            "loses messages without delaying them; over a delayed link "
            "close the loop with controller='estimator' (it keeps "
            "predicting over the delay) and analyse that loop")
    if isinstance(P.sensor_link, LossAutomaton):
        P._refuse_budget("the estimation error's mean square")
    return P


def _sensor_chain(P: NetworkedStateSpace) -> np.ndarray | None:
    """The sensor link's transition (lost, arrived), or None when its losses
    are i.i.d. (a float, or a Gilbert–Elliott link with equal rows)."""
    link = P.sensor_link
    if isinstance(link, GilbertElliott) and not link.is_bernoulli:
        return link.transition
    return None


def _gains(P: NetworkedStateSpace, L: Any) -> np.ndarray:
    L = real_array(L, "L", ndim=(2, 3))
    L = L[None] if L.ndim == 2 else L
    want = (P.nstates, P.C2.shape[0])
    if L.shape[1:] != want or L.shape[0] == 0:
        from control.exception import ControlDimension
        raise ControlDimension(f"L: expected gains of shape {want} (n, nmeas) "
                               f"or (N_L, {want[0]}, {want[1]}), got {L.shape}")
    return L


def estimation_error_loop(P: NetworkedStateSpace, L: Any) -> JumpStateSpace:
    """The estimation-error loop ``e⁺ = (I - R_{k+1})(A e + B1 w)``.

    (:ref:`theory-output-feedback`.)

    ``R_k = θ1,k L_k Σ1,k C2``: ``e = x - x̂`` after the correction. Its
    mean-square stability, with that of the ``x̂`` loop, is the loop's
    (separation).

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network: Bernoulli or bursty (Gilbert–Elliott)
        sensor losses.
    L : array_like, shape (n, nmeas) or (N_L, n, nmeas)
        Estimator gains.

    Returns
    -------
    JumpStateSpace
        ``w → e``, period ``lcm(P.period, N_L)``, two modes per phase
        (measurement lost, arrived). The mode at step ``k`` is the arrival
        ``θ1,k+1`` of the correction it ends with; over a bursty sensor link
        the modes are the link's Markov chain (which moves at every step,
        scheduled or not), so the rate is exact there too.

    Examples
    --------
    The scalar ``x⁺ = 2x`` measured directly, losing 20 % of the messages:
    with ``L = 1`` an arrived message resets the error, so the rate is
    ``α1 · 2² = 0.8``.

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, sensor_loss=0.2)
    >>> round(ncs.ms_radius(ncs.estimation_error_loop(P, [[1.0]])), 12)
    0.8
    """
    P = _check_plant(P)
    Lk = _gains(P, L)
    N = math.lcm(P.period, Lk.shape[0])
    n = P.nstates
    a1 = float(P.sensor_loss)
    chain = _sensor_chain(P)
    A = np.empty((N, 2, n, n))
    B = np.empty((N, 2, n, P.B1.shape[1]))
    for k in range(N):
        j = k + 1
        R = Lk[j % Lk.shape[0]] @ P.sensor_schedule.selection(j) @ P.C2
        for theta in (0, 1):
            keep = np.eye(n) - theta * R
            A[k, theta] = keep @ P.A
            B[k, theta] = keep @ P.B1
    C = np.broadcast_to(np.eye(n), (N, 2, n, n))
    D = np.zeros((N, 2, n, P.B1.shape[1]))
    law: dict = (dict(probabilities=np.tile([a1, 1 - a1], (N, 1)))
                 if chain is None else
                 dict(probabilities=None,
                      transition=np.broadcast_to(chain, (N, 2, 2))))
    return JumpStateSpace(A, B, C, D, dt=P.dt, **law,
                          nominal=np.ones(N, int),
                          states=[f"{s}_err" for s in P.state_labels],
                          outputs=[f"{s}_err" for s in P.state_labels],
                          inputs=P.disturbance_labels,
                          name=f"{P.name} (estimation error)")


def _undetected_modes(P: NetworkedStateSpace) -> list:
    """Eigenvalues ``|λ| ≥ 1`` of the monodromy ``A^N`` that no scheduled
    sensor sees over a period (PBH test of the lifted pair)."""
    return unseen_modes(P.A, [P.sensor_schedule.selection(k) @ P.C2
                              for k in range(P.period)])


def estimator_gain(P: NetworkedStateSpace, *, decay: float | None = None,
                   solver: str | None = None) -> EstimatorGain:
    """Estimator gains ``L_k`` with a mean-square stable error loop.

    (:ref:`theory-output-feedback`.)

    Solves the exact LMI of :ref:`theory-output-feedback` (feasible if and only
    if the lossy, scheduled sensor link is mean-square detectable) and verifies
    the answer with the exact ``ms_radius`` of :func:`estimation_error_loop`,
    never the solver's word.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant ``y = C2 x`` (any ``C2``) with its network; Bernoulli or
        bursty (Gilbert–Elliott) sensor losses. Over a bursty link the LMI
        has one storage per phase and link state and stays exact: the gain
        acts only when a measurement arrives, so one gain per phase is
        optimal there (:ref:`theory-output-feedback`).
    decay : float in (0, 1], optional
        Ask for an error loop with ``ms_radius < decay²``.
    solver : str, optional
        cvxpy solver (default Clarabel).

    Returns
    -------
    EstimatorGain
        ``gains`` of shape ``(P.period, n, nmeas)``; pass it as
        ``estimator_gain`` to :func:`control_ncs.feedback`.

    Raises
    ------
    ValueError
        Before solving, if ``(A, C2)`` is not detectable through the sensor
        schedule (an unstable mode that no scheduled sensor sees), or
        ``decay`` is not in ``(0, 1]``.
    SynthesisError
        ``reason='infeasible'`` with a proof when the losses alone forbid
        it: losing every message of a period, probability ``α1^h`` (``h``
        phases schedule a sensor), leaves ``e⁺ = A^N e``, so the rate is at
        least ``(α1^h ρ(A)^{2N})^{1/N}``; ``'solver_failed'`` or
        ``'not_verified'`` when the solver found nothing that passes the
        exact check (nothing is proven then).

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [2] S. Boyd, L. El Ghaoui, E. Feron and V. Balakrishnan, *Linear Matrix
           Inequalities in System and Control Theory*, SIAM, 1994.

    Examples
    --------
    ``x⁺ = 2x`` seen by ``y = x`` over a link losing 20 %: the error rate
    must be below 1 (it is at least ``α1 · 4 = 0.8``).

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, sensor_loss=0.2)
    >>> L = ncs.estimator_gain(P)
    >>> bool(0.8 - 1e-9 <= L.ms_radius < 1)
    True
    """
    from . import lmi
    P = _check_plant(P)
    r = decay_bound(decay)
    N = P.period
    missed = _undetected_modes(P)
    if missed:
        raise ValueError(
            f"P: (A, C2) is not detectable through the sensor schedule: the "
            f"mode(s) with eigenvalue {', '.join(f'{m:.4g}' for m in missed)}"
            f"{' of the monodromy A^N' if N > 1 else ''} "
            f"are never seen by a scheduled sensor; no estimator gain "
            f"exists (add a sensor, or schedule one that sees them)")
    a1 = float(P.sensor_loss)
    chain = _sensor_chain(P)
    heard = int(P.sensor_schedule.pattern.any(axis=1).sum())
    rho_A = max(abs(np.linalg.eigvals(P.A)))
    if chain is None:
        bound = (a1 ** heard * rho_A ** (2 * N)) ** (1.0 / N)
        why = (f"losing all {heard} sensor message(s) of a period "
               f"(probability α1^{heard})")
    else:
        # the link stays down k steps with probability T[0,0]^k: the error
        # then grows as A^k uncorrected
        bound = float(chain[0, 0]) * rho_A ** 2
        why = (f"the sensor link staying down (probability "
               f"{chain[0, 0]:.6g} per step)")
    if bound >= r ** 2:
        raise SynthesisError(
            f"P: no estimator gain exists: {why} leaves the error "
            f"uncorrected, so its mean-square rate is at least "
            f"{bound:.6g} ≥ {r ** 2:.6g}", INFEASIBLE, {"lower_bound": bound})
    S1 = np.array([P.sensor_schedule.selection(k) for k in range(N)])
    # solved in balanced coordinates e = T ẽ, T = diag(t) (powers of two,
    # exact): Ã = T⁻¹AT, C̃2 = C2 T, and L = T L̃; the gain is then checked
    # on the error loop in the plant's own coordinates
    A0, C0 = np.asarray(P.A, float), np.asarray(P.C2, float)
    t = lmi.balancing_scale(np.abs(A0), np.zeros(A0.shape[0]),
                            np.abs(C0).sum(axis=0), BALANCE_FROM)
    t = np.ones(A0.shape[0]) if t is None else t
    At, Ct = A0 * (1 / t)[:, None] * t[None, :], C0 * t[None, :]
    if chain is None:
        model = lmi.estimator_model(At, Ct, S1, a1, r)
    else:
        model = lmi.markov_estimator_model(At, Ct, S1, chain, r)
    report = lmi.solve(model.problem, solver)  # solver warnings: a status
    first = model.P[0] if chain is None else model.P[0][0]
    if first.value is None:
        raise SynthesisError(
            f"estimator_gain: the solver found no estimator gain (status "
            f"{report.status!r}); nothing is proven either way",
            SOLVER_FAILED, {"status": report.status})
    if chain is None:
        Pt = np.array([0.5 * (X.value + X.value.T) for X in model.P])
        L = np.array([t[:, None] * (np.linalg.solve(Pt[k], model.Z[k].value)
                                    @ S1[k]) for k in range(N)])
    else:
        # P per phase and link state; L_{k+1} = E_{k,1}⁻¹ Z_k with
        # E_{k,1} = Σ_j T[1, j] P_{k+1,j}
        Pt = np.array([[0.5 * (X.value + X.value.T) for X in pair]
                       for pair in model.P])
        L = np.empty((N, A0.shape[0], C0.shape[0]))
        for k in range(N):
            j = (k + 1) % N
            E1 = chain[1, 0] * Pt[j, 0] + chain[1, 1] * Pt[j, 1]
            L[j] = t[:, None] * (np.linalg.solve(E1, model.Z[k].value)
                                 @ S1[j])
    Pk = Pt / t[..., :, None] / t[..., None, :]     # T⁻¹ P̃ T⁻¹
    rate = ms_radius(estimation_error_loop(P, L))
    if not rate < r ** 2:
        raise SynthesisError(
            f"estimator_gain: the solver's gain fails the exact check: the "
            f"error loop's ms_radius is {rate:.6g}, not below {r ** 2:.6g} "
            f"(solver status {report.status!r}); nothing is proven",
            NOT_VERIFIED, {"ms_radius": rate, "status": report.status})
    return EstimatorGain(L, rate, Pk, report)
