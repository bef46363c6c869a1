"""Local refinement of structured gains on the exact quantities
(:ref:`theory-mss`, :ref:`theory-passivity`, :ref:`theory-synthesis`).

Where the gain is structured (a sensor schedule zeroes the columns of
silent sensors, a hold actuator or the predictor's ``[I 0]`` hides part of
the loop's state, :ref:`theory-synthesis`, :ref:`theory-predictor`,
:ref:`theory-jump-system`) the synthesis LMIs ``'block'`` and ``'extended'``
are only sufficient, and 2-3 times too pessimistic in the loss they accept
(the batch reactor below). This module works on the gain's free entries directly, with
the exact figures of a *given* gain:

1. **stabilise**: minimise the exact mean-square rate ``ms_radius``
(:ref:`theory-mss`)
   over the free entries of ``K_k``. The rate is the spectral radius of the
   second-moment monodromy, nonsmooth where its leading eigenvalue is
   multiple; its gradient where it is simple comes from the right and left
   Perron eigenvectors ``Q``, ``V`` propagated over the period:
   ``∂ρ/∂K_k = 2 Σ_i w_ki Bu_kiᵀ V_{k+1} Acl_ki Q_k E_kᵀ / ⟨V_0, Q_0⟩``.
   BFGS with a weak Wolfe line search minimises it, as HIFOO does for
   structured H∞ (Lewis & Overton, *Nonsmooth optimization via
   quasi-Newton methods*, Math. Program. 2013): the inverse-Hessian
   approximation becomes ill-conditioned along the nonsmooth directions
   instead of failing, and the line search never needs a derivative that
   does not exist.
2. **certify and improve η**: the η of a fixed gain comes only from the
   analysis of that closed loop, :func:`control_ncs.passivity_certificate`
   (exactly verified; never the optimiser's number). Where it falls short
   of ``eta`` (or ``eta`` is None) the same quasi-Newton scheme climbs the
   analysis LMI's optimum ``η*(K)`` over the free entries, its gradient
   from the LMI's dual variables (envelope theorem, :class:`IndexObjective`); the
   gain it ends at is certified again by the analysis, and kept only if
   that certificate is better.

Why this stage 2, by measurement (the batch reactor of the tests, sensor
schedule, actuator loss 0.6, the gain of least ``ms_radius`` = 0.972,
analysis η = -282.07): alternating convex steps (``P`` fixed: an LMI in
``(K, η)`` by a Schur complement; ``K`` fixed: the analysis LMI) are
monotone but moved η from -282.067 to -282.059 in two rounds (the P-step
leaves the K-step no room: the constraint is tight at the optimum); the
dual-gradient climb reached -224.4 in 16 iterations (1.7 s). A
convex-concave (inner approximation) iteration was not implemented: it
linearises the same bilinear term around the analysis optimum ``(P, K)``,
where the alternation above already finds no room. At a fixed level such as ``eta=-100`` stage 1 sets
most of the certified loss threshold and stage 2 the rest: on the sensor
schedule case stage 1 alone certifies nothing at loss 0.55 (η = -107
there), with stage 2 the loss 0.57 is certified.

Starting points: a given gain (e.g. the sufficient LMI's), the
unstructured (full-information) mean-square LQ gain restricted to the
structure and the zero gain, taken in the order of their measured rate,
lowest first; then, if none reaches the target rate (or, ``eta`` given, a
certificate), a continuation in the loss probability (modes interpolated
from the loss-free one to the plant's, each level started from the last)
and seeded random restarts. The search stops at the first gain certified
at a given ``eta``. Everything is deterministic given ``seed``; the work
is bounded by ``time_limit``. Before any search the synthesis checks the
one exact refutation available without a solver
(:func:`autonomous_rate`: states no gain reaches).

What it guarantees: a gain returned as certified passed
:func:`control_ncs.verify.check_certificate` (``Θ_k ≺ 0``, ``P_k ≻ 0``,
``ms_radius < min(1, r²)``). What it does not: global optimality — the
problem is nonconvex, a local method can stop in a local minimum, and a
failure to certify proves nothing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension

from .._checks import (choice, decay_bound, finite_real, positive_int,
                      positive_real, real_array)
from .._results import Result
from ..exceptions import CERTIFIED, NOT_FOUND, TIME_LIMIT
from ..gain import PeriodicGain, actuators, controllers
from ..openloop import JumpPlant
from ..plant import NetworkedStateSpace
from ..stability import ms_radius as exact_ms_radius
from ..verify import Certificate
from ._local import (CONTINUATION, ETA_STEP, RESTART_SCALES, RESTARTS,
                     STAGE2_ITERATIONS, TARGET_FRACTION, IndexObjective,
                     Loop, bfgs, certificate_of, certified_search, continued,
                     lq_gain, projected, restrict)

__all__ = ["refine_gain", "RefineResult"]


@dataclass(repr=False)
class RefineResult(Result):
    """What :func:`refine_gain` found, and how far it moved the gain.

    Attributes
    ----------
    gains : ndarray, shape (N, nu, nk)
        The refined ``K_k`` (zero outside the free entries).
    verified : bool
        True when ``certificate`` passed the exact checks.
    certificate : Certificate or None
        The exact certificate of the closed loop with ``gains``
        (:func:`control_ncs.verify.check_certificate`); None when no
        certificate was found.
    eta : float
        Certified dissipation (``nan`` when not verified).
    ms_radius : float
        Exact per-step mean-square rate of the closed loop with ``gains``.
    start : str
        Which starting point led to ``gains``: ``'given'``, ``'full'``
        (the unstructured gain restricted), ``'zero'``,
        ``'continuation'`` or ``'restart'``.
    ms_radius_before : float
        The rate at that starting point.
    eta_before : float
        The η certified at the first stabilising gain, before stage 2
        (``nan`` if none was certified there).
    iterations : int
        Quasi-Newton iterations of stage 1 plus alternations of stage 2.
    evaluations : int
        Evaluations of the rate and its gradient.
    stopped : str
        Why it stopped: ``'certified'``, ``'converged'``, ``'time_limit'``.
    message : str
        One sentence for humans.
    starts : list of tuple
        ``(start, ms_radius at the start, ms_radius reached)`` per start
        tried, in order.
    time : float
        Seconds spent.

    Examples
    --------
    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1)
    >>> res = ncs.refine_gain(P, eta=0.0)
    >>> res.verified, res.stopped, bool(res.ms_radius < 1)
    (True, 'certified', True)
    """

    gains: np.ndarray
    verified: bool
    certificate: Certificate | None
    eta: float
    ms_radius: float
    start: str
    ms_radius_before: float
    eta_before: float
    iterations: int
    evaluations: int
    stopped: str
    message: str
    starts: list = field(default_factory=list)
    time: float = 0.0

    _repr_fields = ("eta", "ms_radius", "start", "iterations", "stopped")

    @property
    def success(self) -> bool:
        """``verified``: the refined gain's certificate passed."""
        return self.verified

    @property
    def status(self) -> str:
        """``'certified'``, or ``'time_limit'`` / ``'not_found'``."""
        if self.verified:
            return CERTIFIED
        return TIME_LIMIT if self.stopped == TIME_LIMIT else NOT_FOUND

    def _details(self) -> list[str]:
        return [f"ms_radius {self.ms_radius_before:.6g} -> "
                f"{self.ms_radius:.6g} from the start {self.start!r}",
                f"eta {self.eta_before:.6g} -> {self.eta:.6g}, "
                f"{self.iterations} iterations, {self.time:.3f} s"]


# -- the driver -----------------------------------------------------------------
def _refine(plant: JumpPlant, eta: float | None, decay: float,
            given: np.ndarray | None, rng: np.random.Generator,
            deadline: float | None, max_iterations: int) -> RefineResult:
    """Stages 1 and 2 on checked arguments."""
    began = time.perf_counter()
    loop = Loop(plant, plant.probabilities, plant.transition)
    bound = min(1.0, decay ** 2)
    target = math.log(TARGET_FRACTION * bound)
    edge = math.log(bound)
    iterations = 0
    tried: list[tuple] = []

    def out_of_time():
        return deadline is not None and time.perf_counter() > deadline

    certified: dict = {}

    def settled(f, x):
        """At the target rate, or (a level given) already certified there:
        further starts are not needed."""
        if f <= target:
            return True
        if eta is None or not f < edge:
            return False
        key = x.tobytes()
        if key not in certified:
            certified[key] = certificate_of(plant.close(loop.gains(x)), eta,
                                       decay)
        return certified[key] is not None

    # starting points, best (lowest rate) first
    starts = []
    if given is not None:
        starts.append(("given", given.flat[loop.free].copy()))
    G = lq_gain(plant, plant.probabilities)
    near = projected(plant, loop, G)
    if near is not None:
        starts.append(("projected", near))
    starts.append(("full", restrict(loop, G)))
    starts.append(("zero", np.zeros(loop.free.size)))
    scored = sorted(((loop.rate(x)[0], j, name, x)
                     for j, (name, x) in enumerate(starts)),
                    key=lambda s: (s[0], s[1]))
    best = None            # (f, x, start, f at start)
    stopped = "converged"
    for f0, _, name, x in scored:
        if out_of_time():
            stopped = TIME_LIMIT
            break
        x, f, its, why = bfgs(loop.rate, x, target, deadline,
                               max_iterations)
        iterations += its
        tried.append((name, math.exp(f0), math.exp(f)))
        if best is None or f < best[0]:
            best = (f, x, name, f0)
        if why == TIME_LIMIT:
            stopped = TIME_LIMIT
        if why == TIME_LIMIT or settled(f, x):
            break
    if best is None:
        f0, _, name, x = scored[0]
        best = (f0, x, name, f0)
    if (not settled(best[0], best[1]) and plant.nominal is not None
            and not out_of_time()):
        # continuation in the loss probability from the best start
        x = starts[[s[0] for s in starts].index(best[2])][1]
        f0 = loop.rate(x)[0]
        for t in CONTINUATION:
            level = Loop(plant, *continued(plant, t))
            x, f, its, why = bfgs(level.rate, x,
                                   target if t == 1.0 else -np.inf,
                                   deadline, max_iterations)
            iterations += its
            loop.evaluations += level.evaluations
            if why == TIME_LIMIT:
                stopped = TIME_LIMIT
                break
        f = loop.rate(x)[0]
        tried.append(("continuation", math.exp(f0), math.exp(f)))
        if f < best[0]:
            best = (f, x, "continuation", f0)
    for restart in range(RESTARTS):
        if settled(best[0], best[1]) or out_of_time():
            break
        scale = max(1.0, float(np.abs(best[1]).max(initial=0.0)))
        spread = RESTART_SCALES[restart % len(RESTART_SCALES)]
        x = best[1] + spread * scale * rng.standard_normal(best[1].size)
        f0 = loop.rate(x)[0]
        x, f, its, why = bfgs(loop.rate, x, target, deadline,
                               max_iterations)
        iterations += its
        tried.append(("restart", math.exp(f0), math.exp(f)))
        if f < best[0]:
            best = (f, x, "restart", f0)
    f, x, start, f0 = best
    K = loop.gains(x)

    def result(K, cert, eta_before, stopped, message):
        rate = exact_ms_radius(plant.close(K))
        ok = cert is not None and cert.verified
        return RefineResult(
            K, ok, cert, float(cert.eta) if ok else float("nan"), rate,
            start, math.exp(f0), eta_before, iterations, loop.evaluations,
            stopped, message, tried, time.perf_counter() - began)

    if not f < edge:
        why = ("the time limit was reached" if stopped == TIME_LIMIT else
               "the local search converged")
        return result(K, None, float("nan"), stopped,
                      f"refinement found no mean-square stabilising gain: "
                      f"{why} at ms_radius {math.exp(f):.6g} >= "
                      f"{bound:.6g} (a local method: nothing is proven)")
    cert = certified.get(x.tobytes()) if x.tobytes() in certified \
        else certificate_of(plant.close(K), eta, decay)
    eta_before = float(cert.eta) if cert is not None else float("nan")
    if (cert is None or eta is None) and plant.is_iid and not out_of_time():
        # stage 2: the certified η of a fixed gain is the analysis LMI's;
        # climb its optimum η*(K) (the LMI of theory: passivity is written for
        # i.i.d. modes: Markov loops keep the stage-1 gain)
        index = IndexObjective(plant, loop, decay)
        x0 = K.flat[loop.free].copy()
        goal = -np.inf if eta is None else -(eta + ETA_STEP * max(
            1.0, abs(eta)))
        x2, _, its, why = bfgs(index.value, x0, goal, deadline,
                                min(max_iterations, STAGE2_ITERATIONS))
        iterations += its
        loop.evaluations += index.evaluations
        if why == TIME_LIMIT:
            stopped = TIME_LIMIT
        if not np.array_equal(x2, x0):
            K2 = loop.gains(x2)
            cert2 = certificate_of(plant.close(K2), eta, decay)
            if cert2 is not None and (cert is None or cert2.eta > cert.eta):
                K, cert = K2, cert2
    elif (cert is None or eta is None) and not out_of_time():
        # Markov modes: the gradient above is written for i.i.d. modes; a
        # derivative-free search on the certified η itself, keeping the best
        # certified loop it meets
        K, cert = certified_search(plant, loop, K, cert, eta, decay,
                                    deadline)
    if cert is not None and cert.verified:
        if stopped != TIME_LIMIT:
            stopped = CERTIFIED
        what = ("certified" if stopped == CERTIFIED else
                "certified before the time limit stopped the refinement")
        return result(K, cert, eta_before, stopped,
                      f"refinement {what}: eta = {cert.eta:.6g}, ms_radius "
                      f"{math.exp(f0):.6g} at the start ({start}) -> "
                      f"{cert.ms_radius:.6g}")
    why = ("the time limit was reached" if stopped == TIME_LIMIT or
           out_of_time() else "no certificate was found")
    return result(K, None, eta_before,
                  TIME_LIMIT if out_of_time() else stopped,
                  f"refinement reached ms_radius {math.exp(f):.6g} but "
                  f"{why} at eta = {eta} (a local method: nothing is "
                  f"proven)")


# -- public entry ----------------------------------------------------------------
def refine_gain(P: NetworkedStateSpace | JumpPlant, eta: float | None = None,
                *, decay: float | None = None, controller: str = "static",
                actuator: str = "zero", gains: Any = None, seed: Any = 0,
                time_limit: float | None = 60.0, max_iterations: int = 200
                ) -> RefineResult:
    """Locally refine a structured gain on the exact quantities.

    Minimises the exact mean-square rate ``ms_radius`` (:ref:`theory-mss`) over
    the free entries of ``K_k`` (those a scheduled sensor and actuator leave;
    the zero pattern of the structure) until it is below
    ``TARGET_FRACTION · min(1, r²)``, then certifies the gain with the
    analysis of the closed loop (:func:`control_ncs.passivity_certificate`)
    and, where that does not reach ``eta`` (or ``eta`` is None), climbs the
    analysis LMI's optimal η over the same entries. Starts, best first: the
    given ``gains``, the unstructured mean-square LQ gain restricted to the
    structure, zero; then a continuation in the loss probability and
    seeded random restarts (see the module's notes).

    A local method: it finds and proves a gain (``verified``), or it
    proves nothing; it never proves that no gain exists.

    Parameters
    ----------
    P : NetworkedStateSpace or JumpPlant
        Plant with its network (built with ``controller``, ``actuator``),
        or the open-loop jump system a strategy built
        (:func:`control_ncs.build`).
    eta : float, optional
        Dissipation to certify; None: the largest the method reaches.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r`` (``ms_radius < r²``).
    controller : {'static', 'predictor', 'estimator'}
        As :func:`control_ncs.build` (ignored for a JumpPlant).
    actuator : {'zero', 'hold'}
        As :func:`control_ncs.build` (ignored for a JumpPlant).
    gains : array_like or PeriodicGain, optional
        A starting gain of shape ``(N, nu, nk)`` (e.g. an LMI's); entries
        outside the structure are ignored.
    seed : int, numpy.random.Generator or None, optional
        Seed of the random restarts (default 0: the same gain every call).
    time_limit : float or None, optional
        Seconds (default 60; None: no limit). The search stops at the
        limit with ``stopped == 'time_limit'`` and says so in ``message``.
    max_iterations : int, optional
        Quasi-Newton iterations per local search.

    Returns
    -------
    RefineResult
        ``verified`` only with an exact certificate.

    Raises
    ------
    ControlArgument
        ``P`` is not a plant, an unknown ``controller`` or ``actuator``.
    ControlDimension
        ``gains`` of the wrong shape; ``w`` and ``z`` of different size.
    ValueError
        ``eta`` not finite or above the feedthrough bound, ``decay`` not in
        (0, 1], ``time_limit`` or ``max_iterations`` not positive.

    Examples
    --------
    Two sensors taking turns (``N = 2``) on ``x⁺ = A x + w + u``, half the
    actuator's messages lost:

    >>> A = [[1.1, 0.3], [0.0, 0.9]]
    >>> D = np.zeros((4, 4))
    >>> D[:2, :2] = np.eye(2)
    >>> P = ncs.nss(A, np.hstack([np.eye(2), np.eye(2)]),
    ...         np.vstack([np.eye(2), np.eye(2)]), D, True, nmeas=2, ncon=2,
    ...         actuator_loss=0.5, sensor_schedule=[1, 2])
    >>> res = ncs.refine_gain(P, eta=-1.0)
    >>> res.verified, bool(res.ms_radius < 1), res.gains.shape
    (True, True, (2, 2, 2))
    >>> res.gains[0, :, 1].tolist()      # sensor 2 is silent at k = 0
    [0.0, 0.0]
    """
    from ..passivity import passivity_certificate  # noqa: F401 (import cost)
    from ..strategies import build
    from ..verify import feedthrough_bound
    if isinstance(P, NetworkedStateSpace):
        choice(controller, "controller", controllers())
        choice(actuator, "actuator", actuators())
        plant = build(P, controller, actuator)
    elif isinstance(P, JumpPlant):
        plant = P
    else:
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()) "
                              f"or a JumpPlant (see build()), got "
                              f"{type(P).__name__}")
    plant.require_noise_free("refine")
    if plant.shape["nw"] != plant.shape["nz"] or plant.shape["nw"] == 0:
        raise ControlDimension(
            f"P: passivity needs w and z of equal, nonzero size, got "
            f"{plant.shape['nw']} and {plant.shape['nz']}")
    eta = finite_real(eta, "eta", allow_none=True)
    if eta is not None:
        bound, _ = feedthrough_bound(plant.probabilities, plant.Dw)
        if not bound > eta:
            raise ValueError(f"eta: D11 + D11ᵀ ≻ 2·eta·I is necessary "
                             f"(theory: passivity), but λmin(D11 + D11ᵀ)/2 = "
                             f"{bound:.6g} ≤ eta = {eta:.6g}")
    decay = decay_bound(decay)
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    max_iterations = positive_int(max_iterations, "max_iterations")
    if gains is not None:
        gains = real_array(gains.gains if isinstance(gains, PeriodicGain)
                           else gains, "gains", ndim=(2, 3))
        if gains.ndim == 2:
            gains = np.repeat(gains[None], plant.period, axis=0)
        if gains.shape != plant.gain_shape():
            raise ControlDimension(f"gains: expected shape "
                                   f"{plant.gain_shape()} (N, nu, nk), got "
                                   f"{gains.shape}")
    if isinstance(seed, np.random.Generator):
        rng = seed
    elif seed is None or (isinstance(seed, (int, np.integer))
                          and not isinstance(seed, bool)):
        rng = np.random.default_rng(seed)
    else:
        raise ControlArgument(f"seed: expected an int, a numpy Generator or "
                              f"None, got {type(seed).__name__}")
    deadline = (None if time_limit is None
                else time.perf_counter() + time_limit)
    return _refine(plant, eta, decay, gains, rng, deadline, max_iterations)
