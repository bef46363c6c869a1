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
import scipy.linalg
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
from ._local import (CONTINUATION, ETA_STEP, EVALUATIONS, RESTART_SCALES,
                     RESTARTS, STAGE2_ITERATIONS, TARGET_FRACTION,
                     IndexObjective, Loop, bfgs, certificate_of,
                     certified_search, continued, lq_gain, projected,
                     restrict)

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
        Which starting point led to ``gains``: ``'given'``,
        ``'projected'`` or ``'full'`` (the unstructured gain projected or
        restricted), ``'delay-free'`` or ``'delay-free half'`` (over a
        delayed link, the delay-free plant's LQ gain on every age, or its
        half), ``'zero'``, ``'continuation'`` or ``'restart'``.
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
class _Search:
    """The two stages (module docstring) on checked arguments, with what
    they measured on the way."""

    def __init__(self, plant: JumpPlant, eta: float | None, decay: float,
                 rng: np.random.Generator, deadline: float | None,
                 max_iterations: int):
        self.plant, self.eta, self.decay = plant, eta, decay
        self.rng, self.deadline = rng, deadline
        self.max_iterations = max_iterations
        self.loop = Loop(plant, plant.probabilities, plant.transition)
        bound = min(1.0, decay ** 2)
        self.bound = bound
        self.target = math.log(TARGET_FRACTION * bound)
        self.edge = math.log(bound)
        self.iterations = 0
        self.tried: list[tuple] = []
        self.certified: dict = {}
        self.stopped = "converged"
        self.ends: list[tuple] = []     # (f, x, start, f at the start)
        # Markov modes: Nelder–Mead climbs only when its simplex fits
        loop = self.loop
        self.climbs = plant.is_iid or (
            loop.free.size + 1 <= SIMPLEX_SHARE * EVALUATIONS
            and loop.M * loop.n ** 2 <= PROJECTED_MAX)

    def out_of_time(self) -> bool:
        return self.deadline is not None and \
            time.perf_counter() > self.deadline

    def certificate(self, x: np.ndarray) -> Any:
        """The analysis certificate of the gain ``x`` at ``eta`` (cached)."""
        key = x.tobytes()
        if key not in self.certified:
            self.certified[key] = certificate_of(
                self.plant.close(self.loop.gains(x)), self.eta, self.decay)
        return self.certified[key]

    def settled(self, f: float, x: np.ndarray) -> bool:
        """At the target rate, or (a level given) already certified there:
        further starts are not needed."""
        if f <= self.target:
            return True
        if self.eta is None or not f < self.edge:
            return False
        return self.certificate(x) is not None

    def descend(self, rate: Any, x: np.ndarray, target: float
                ) -> tuple[np.ndarray, float]:
        x, f, its, why = bfgs(rate, x, target, self.deadline,
                              self.max_iterations)
        self.iterations += its
        if why == TIME_LIMIT:
            self.stopped = TIME_LIMIT
        return x, f

    def end(self, name: str, x: np.ndarray, f: float, f0: float) -> None:
        self.tried.append((name, math.exp(f0), math.exp(f)))
        self.ends.append((f, x, name, f0))

    def best(self) -> tuple:
        return min(self.ends, key=lambda e: e[0])

    def stage1(self, starts: list[tuple[str, np.ndarray]]) -> None:
        """Stage 1 from every start, lowest rate first, then a
        continuation in the loss and seeded restarts until one settles."""
        loop = self.loop
        scored = sorted(((loop.rate(x)[0], j, name, x)
                         for j, (name, x) in enumerate(starts)),
                        key=lambda s: (s[0], s[1]))
        for f0, _, name, x in scored:
            if self.out_of_time():
                self.stopped = TIME_LIMIT
                break
            x, f = self.descend(loop.rate, x, self.target)
            self.end(name, x, f, f0)
            if self.stopped == TIME_LIMIT or self.settled(f, x):
                break
        if not self.ends:
            f0, _, name, x = scored[0]
            self.end(name, x, f0, f0)
        if not self.climbs:
            # no climb from the ends: every stable start competes as it is
            # (the result is never worse than the best of them)
            done = {id(e[1]) for e in self.ends}
            for f0, _, name, x in scored:
                if f0 < self.edge and id(x) not in done:
                    self.end(name, x, f0, f0)
        best = self.best()
        if not self.settled(best[0], best[1]) and not self.out_of_time() \
                and self.plant.nominal is not None:
            self._continuation(dict(starts)[best[2]] if best[2] in
                               dict(starts) else best[1])
        self._restarts()

    def _continuation(self, x: np.ndarray) -> None:
        """Modes interpolated from the loss-free ones to the plant's, each
        level started from the last."""
        f0 = self.loop.rate(x)[0]
        for t in CONTINUATION:
            level = Loop(self.plant, *continued(self.plant, t))
            x, _ = self.descend(level.rate, x,
                                self.target if t == 1.0 else -np.inf)
            self.loop.evaluations += level.evaluations
            if self.stopped == TIME_LIMIT:
                break
        self.end("continuation", x, self.loop.rate(x)[0], f0)

    def _restarts(self) -> None:
        for restart in range(RESTARTS):
            best = self.best()
            if self.settled(best[0], best[1]) or self.out_of_time():
                break
            scale = max(1.0, float(np.abs(best[1]).max(initial=0.0)))
            spread = RESTART_SCALES[restart % len(RESTART_SCALES)]
            x = best[1] + spread * scale * self.rng.standard_normal(
                best[1].size)
            f0 = self.loop.rate(x)[0]
            x, f = self.descend(self.loop.rate, x, self.target)
            self.end("restart", x, f, f0)

    def stage2(self) -> tuple:
        """Certify every mean-square stable end of stage 1 (the lowest
        rate first) and climb the certified level from each; the best
        certified gain wins, and the search stops at a level asked for.
        Returns ``(K, certificate, η at its start, end)``."""
        loop, eta = self.loop, self.eta
        found: tuple | None = None
        for end in sorted(self.ends, key=lambda e: e[0]):
            f, x = end[0], end[1]
            if not f < self.edge or (found is not None and
                                     self.out_of_time()):
                continue
            cert = self.certificate(x)
            before = float(cert.eta) if cert is not None else float("nan")
            K, cert = self._climb(loop.gains(x), cert)
            if cert is not None and cert.verified and (
                    found is None or cert.eta > found[1].eta):
                found = (K, cert, before, end)
            if found is not None and (eta is not None or self.out_of_time()):
                break
        if found is None:
            best = self.best()
            cert = self.certificate(best[1]) if best[0] < self.edge else None
            return (loop.gains(best[1]), cert, float("nan") if cert is None
                    else float(cert.eta), best)
        return found

    def _climb(self, K: np.ndarray, cert: Any) -> tuple:
        """Stage 2 from one stable gain: the analysis LMI's optimum η*(K)
        by its envelope gradient (i.i.d. modes), the certified level itself
        derivative-free (Markov modes)."""
        eta, loop, plant = self.eta, self.loop, self.plant
        if not (cert is None or eta is None) or self.out_of_time() or \
                not self.climbs:
            return K, cert
        if not plant.is_iid:
            return certified_search(plant, loop, K, cert, eta, self.decay,
                                    self.deadline)
        index = IndexObjective(plant, loop, self.decay)
        x0 = K.flat[loop.free].copy()
        goal = -np.inf if eta is None else -(eta + ETA_STEP * max(
            1.0, abs(eta)))
        x2, _, its, why = bfgs(index.value, x0, goal, self.deadline,
                               min(self.max_iterations, STAGE2_ITERATIONS))
        self.iterations += its
        loop.evaluations += index.evaluations
        if why == TIME_LIMIT:
            self.stopped = TIME_LIMIT
        if not np.array_equal(x2, x0):
            K2 = loop.gains(x2)
            cert2 = certificate_of(plant.close(K2), eta, self.decay)
            if cert2 is not None and (cert is None or cert2.eta > cert.eta):
                return K2, cert2
        return K, cert


def _starts(plant: JumpPlant, loop: Loop, given: np.ndarray | None
            ) -> list[tuple[str, np.ndarray]]:
    """Stage 1's starting points: a given gain, the full-information LQ
    gain projected on what the gain reads (not for loops whose moments
    outgrow :data:`PROJECTED_MAX`: its stationary moments cost more than
    the search) and restricted to it, over a delayed link the delay-free
    plant's LQ gain on every age of the measurement and its half (a gain
    that acts on old measurements as on new ones, gentler), zero."""
    starts = []
    if given is not None:
        starts.append(("given", given.flat[loop.free].copy()))
    G = lq_gain(plant, plant.probabilities)
    size = loop.M * loop.n ** 2 if loop.T is not None else loop.n ** 2
    near = projected(plant, loop, G) if size <= PROJECTED_MAX else None
    if near is not None:
        starts.append(("projected", near))
    starts.append(("full", restrict(loop, G)))
    constant = delay_free_gain(plant, loop)
    if constant is not None:
        starts += [("delay-free", constant), ("delay-free half",
                                              0.5 * constant)]
    starts.append(("zero", np.zeros(loop.free.size)))
    return starts


#: The projected start is computed for loops whose second moments have at
#: most this many unknowns (``M n²``, ``n²`` for i.i.d. modes).
PROJECTED_MAX = 4096

#: Markov modes: the derivative-free stage 2 climbs from a gain only when
#: its simplex (one certificate per free entry) fits this share of its
#: evaluations and the loop's moments have at most PROJECTED_MAX unknowns
#: (a certificate of a larger loop takes seconds to minutes: about 20 s
#: for the predictor's 96 states and 11 modes over a buffer of 5,
#: docs/benchmarks.md); otherwise the stable starts and ends of
#: stage 1 are certified as they are and the best one wins.
SIMPLEX_SHARE = 0.25


def delay_free_gain(plant: JumpPlant, loop: Loop) -> np.ndarray | None:
    """Free entries of the constant gain over a delayed link: the LQ gain
    ``G₀`` (weights ``I``) of the plant without delays, on every age of the
    measurement (a gain per age: ``K = [G₀, G₀, …]``; the loop state is the
    plant's state and its past copies, ``[x; x₋₁; …]``, each mode reading
    one ``n``-block of it) or on the predictor's estimate (its first ``n``
    coordinates). None for other loops, or more than one phase."""
    if plant.period != 1 or not (plant.reads_per_mode
                                 or plant.controller == "predictor") \
            or plant.nominal is None:
        return None
    nominal = int(plant.nominal[0])
    reading = loop.reading()[0]                       # (nk, nx)
    E = loop.E[0, nominal]
    cols = np.flatnonzero(np.any(E != 0, axis=0))
    n = cols.size
    if n == 0 or not np.array_equal(cols, np.arange(n)) or \
            loop.n % n != 0:
        return None
    A0 = plant.A[0, nominal][:n, :n]
    B0 = plant.Bu[0, nominal][:n]
    m = B0.shape[1]
    if not np.any(B0):
        return None
    try:
        S = scipy.linalg.solve_discrete_are(A0, B0, np.eye(n), np.eye(m))
        G0 = -np.linalg.solve(B0.T @ S @ B0 + np.eye(m), B0.T @ S @ A0)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(G0)):
        return None
    K = np.zeros(loop.mask.shape)
    for j in range(reading.shape[0]):
        x = np.flatnonzero(reading[j])
        if x.size != 1:
            return None
        K[0][:, j] = G0[:, x[0] % n]
    return K.flat[loop.free].copy()


def _refine(plant: JumpPlant, eta: float | None, decay: float,
            given: np.ndarray | None, rng: np.random.Generator,
            deadline: float | None, max_iterations: int) -> RefineResult:
    """Stages 1 and 2 on checked arguments, as a :class:`RefineResult`."""
    began = time.perf_counter()
    search = _Search(plant, eta, decay, rng, deadline, max_iterations)
    search.stage1(_starts(plant, search.loop, given))
    K, cert, eta_before, (f, x, start, f0) = search.stage2()
    stopped = search.stopped

    def result(cert: Any, stopped: str, message: str) -> RefineResult:
        ok = cert is not None and cert.verified
        # a certificate of K carries the rate of its loop (certified
        # bracket, computed independently of P): not measured again
        rate = (cert.ms_radius if cert is not None else
                exact_ms_radius(plant.close(K)))
        return RefineResult(
            K, ok, cert, float(cert.eta) if ok else float("nan"),
            rate, start, math.exp(f0),
            eta_before, search.iterations, search.loop.evaluations, stopped,
            message, search.tried, time.perf_counter() - began)

    if not f < search.edge:
        why = ("the time limit was reached" if stopped == TIME_LIMIT else
               "the local search converged")
        return result(None, stopped,
                      f"refinement found no mean-square stabilising gain: "
                      f"{why} at ms_radius {math.exp(f):.6g} >= "
                      f"{search.bound:.6g} (a local method: nothing is "
                      f"proven)")
    if cert is not None and cert.verified:
        stopped = TIME_LIMIT if stopped == TIME_LIMIT else CERTIFIED
        what = ("certified" if stopped == CERTIFIED else
                "certified before the time limit stopped the refinement")
        return result(cert, stopped,
                      f"refinement {what}: eta = {cert.eta:.6g}, ms_radius "
                      f"{math.exp(f0):.6g} at the start ({start}) -> "
                      f"{cert.ms_radius:.6g}")
    out = search.out_of_time()
    why = ("the time limit was reached" if stopped == TIME_LIMIT or out
           else "no certificate was found")
    return result(None, TIME_LIMIT if out else stopped,
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
