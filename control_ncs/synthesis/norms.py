"""H2- and H∞-optimal state feedback over the network
(:ref:`theory-performance`).

Convex programs design periodic gains ``K_k`` (over bursty links ``K_{k,ℓ}``,
also on the previous link state) when the controller sees the whole loop
state: Costa, do Val and Geromel's for the H2 norm
(``lmi.h2_model``), the bounded real lemma in ``X = P⁻¹, Y = K X`` for the
ℓ2 gain (``lmi.hinf_model``). The number returned is always an analysis of
the closed loop — its exact H2 norm (:func:`control_ncs.norm`), or its
certified ℓ2-gain bound (:func:`control_ncs.l2_gain`) — never the solver's
objective. Over a lossy actuator link with the state measured the H2 problem
is TCP-like LQ, whose optimum is the modified Riccati equation's
(:func:`control_ncs.dlqr`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any, Mapping

import numpy as np
from control.exception import ControlArgument, ControlDimension

from .._blas import serial_blas
from .._checks import choice, decay_bound, positive_real
from ._h2 import H2Objective, local_h2
from ._hinf import GainObjective
from ._budget import budget_design
from ._options import COMMON_DEFAULTS, resolved_options
from ._result import Design
from ._local import bfgs
from ..exceptions import (NOT_FOUND, NOT_MSS, SOLVER_FAILED,
                         CertificationError, SynthesisError)
from ..gain import PeriodicGain, actuators
from ..jump import JumpStateSpace
from ..openloop import JumpPlant
from ..lmi import (DEFAULT_MARGIN, check_options, check_solver, gain_kinds,
                  h2_model, hinf_model, solve)
from ..intersample import cost, cost_open_loop
from ..performance import GainResult, l2_gain, norm
from ..plant import NetworkedStateSpace
from ..stability import ms_radius
from ..strategies import build
from ._routes import _open_loop_bound

__all__ = ["h2syn", "hinfsyn"]

#: The keys of ``h2syn(options=...)`` and ``hinfsyn(options=...)`` and
#: their defaults.
DEFAULTS: dict[str, Any] = dict(COMMON_DEFAULTS)

#: Quasi-Newton iterations of hinfsyn's local stage on the bounded real
#: lemma (each solves the lemma's LMI once).
HINF_ITERATIONS = 30


def _not_exact(P: NetworkedStateSpace, plant: JumpPlant, controller: str,
               actuator: str, who: str) -> tuple[str, str] | None:
    """Why the exact program does not cover this loop (``plant``, the open
    loop of ``P`` already built), as ``(argument, message)``; None when it
    does: static state feedback that sees the whole loop state at every
    step (so no held command, no buffered link), a bursty link's state
    revealed at every step."""
    n = P.nstates
    if np.any(np.asarray(P.D21) != 0):
        return ("P", f"P: {who}'s exact program needs a gain on the state "
                     f"alone; with D21 ≠ 0 it also reads the noise")
    if controller != "static":
        return ("controller", f"controller: {who}'s exact program is for the "
                              f"static gain on the state, got {controller!r}")
    if actuator != "zero":
        return ("actuator", f"actuator: {who} designs with actuator='zero' "
                            f"(a held command is extra state the static gain "
                            f"does not see), got {actuator!r}")
    if P.C2.shape != (n, n) or not np.array_equal(P.C2, np.eye(n)):
        return ("P", f"P: {who} needs the state measured, y = x (C2 = I, "
                     f"{n}x{n}), got C2 of shape {P.C2.shape}")
    if not plant.is_iid and "phase" in gain_kinds(plant, "mode"):
        return ("P", f"P: {who}'s exact program over a bursty link uses "
                     f"gains on the previous link state, known from "
                     f"acknowledgements; under this schedule a link idle the "
                     f"step before hides its state, and the program with one "
                     f"gain for the hidden states is not written")
    if plant.reads_per_mode or not all(np.array_equal(Ek, np.eye(n))
                                       for Ek in plant.E):
        return ("P", f"P: the static gain does not see the whole loop state "
                     f"at every phase (a sensor schedule, or measurements or "
                     f"commands a delayed link still holds); {who}'s exact "
                     f"program needs y = x and nothing else at every step")
    return None


def _checked(P: Any, actuator: str, solver: str | None, margin: Any,
             solver_options: dict) -> tuple[str, float]:
    """The argument checks every H2/H∞ design makes first."""
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    choice(actuator, "actuator", actuators())
    name = check_solver(solver)
    check_options(name, solver_options)
    return name, positive_real(margin, "margin")


def _designed_loop(plant: Any, model: Any, name: str, solver_options: dict,
                   who: str, decay: float = 1.0
                   ) -> tuple[np.ndarray, JumpStateSpace, float, Any]:
    """Solve ``model``, read its gains, close ``plant``'s loop with them
    and require it mean-square stable: ``(gains, CL, ms_radius, report)``.
    Before the solve, the one proof that needs no solver: the modes no gain
    acts in (a lost command) alone make every loop mean-square unstable."""
    _open_loop_bound(plant, decay, who)
    report = solve(model.problem, name, **solver_options)
    if report.status not in ("optimal", "optimal_inaccurate") or \
            model.problem.value is None:
        raise SynthesisError(f"{who}: the solver gave no gain (status "
                             f"{report.status!r})", SOLVER_FAILED,
                             dict(status=report.status))
    gains = model.gains()
    CL = plant.close(gains)
    rate = _rate_within(CL, decay, f"{who}: the solver's gain")
    return gains, CL, rate, report


def _decayed(plant: JumpPlant, decay: float) -> JumpPlant:
    """The plant whose loops decay ``1/r`` times slower: a program that
    makes its loop mean-square stable makes the plant's decay like
    ``r^k`` (``ms_radius < r²``), and its objective bounds the plant's
    (sufficient for ``r < 1``)."""
    if decay == 1.0:
        return plant
    return replace(plant, A=plant.A / decay, Bu=plant.Bu / decay)


def _rate_within(CL: JumpStateSpace, decay: float, what: str) -> float:
    """The loop's ``ms_radius``, required below ``r²`` by its certified
    bracket (``SynthesisError('not_mss')`` otherwise)."""
    bracket = ms_radius(CL, bracket=True)
    bound = decay ** 2
    if not bracket.upper < bound:
        within = "" if decay == 1.0 else f" within the decay bound {bound:g}"
        raise SynthesisError(
            f"{what} does not make the loop mean-square stable{within} "
            f"(ms_radius in [{bracket.lower:.6g}, {bracket.upper:.6g}])",
            NOT_MSS, dict(ms_radius=bracket.radius, bound=bound))
    return float(bracket.radius)


def h2syn(P: NetworkedStateSpace, *, decay: float | None = None,
          controller: str = "static", actuator: str = "zero",
          estimator_gain: Any = None, initial_gain: Any = None,
          options: Mapping[str, Any] | None = None, **kwargs: Any
          ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """H2-optimal periodic feedback over the lossy network.

    Like :func:`control.h2syn` with python-control's generalized-plant
    layout (inputs ``[w; u]``, outputs ``[z; y]``), for the periodic jump
    loop of the plant and its network: the periodic static gains
    ``u = K_k x`` (positive feedback, :ref:`guide-sign`) minimising
    ``‖G‖₂`` (unit white ``w``; see
    :func:`control_ncs.norm`), by the convex program of Costa, do Val and
    Geromel. Exact (the global optimum over periodic static gains) when the
    controller sees the whole state, ``y = x`` at every phase; over a
    bursty (Gilbert–Elliott) link the gains also use the link's previous
    state, known from acknowledgements, ``K_{k,ℓ}`` (:ref:`theory-markov`),
    and the program, written per class of previous states, is exact again
    (it solves the coupled Riccati equations of LQ over the link). ``z``
    counts the applied control (``D12`` acts on what arrives).

    Where the gain is structured — a sensor schedule, ``y ≠ x`` (static
    output feedback), the predictor or the estimator, a held command,
    delayed links (a gain per sensor age, or the predictor's) — no convex
    program is exact, and the gain is searched locally on the exact norm:
    quasi-Newton steps on the mean-square rate until the loop is stable,
    then on ``log ‖G‖₂²`` with its exact gradient (one adjoint fixed
    point), from the full-information design restricted to the structure,
    the mean-square LQ gain and zero. The figure is still the exact norm of
    the returned loop; the gain is a local optimum
    (``K.result.route == 'local'``).

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant with its network. The exact program needs ``y = x`` at
        every step (a bursty link's state revealed at every step) and
        ``D21 = 0``; otherwise the local search runs (with ``D21 ≠ 0`` for
        the static gain only, which reads the noise at once).
    decay : float in (0, 1], optional
        Mean-square decay bound ``r``: the returned loop has ``ms_radius <
        r²`` (by its certified bracket), away from the edge of stability an
        optimal design may otherwise sit on (an unobserved integrator). The
        exact program is then solved for the plant with its dynamics divided
        by ``r`` (sufficient: the returned figure is still the loop's own);
        the local search keeps to the bound.
    controller : {'static', 'predictor', 'estimator'}, optional
        As for :func:`control_ncs.feedback`; over delayed links
        ``'static'`` (a gain per sensor age) or ``'predictor'``.
    actuator : {'zero', 'hold'}, optional
        What the actuator applies when a command is lost (the exact program
        needs ``'zero'``: the loop state is then the plant state).
    estimator_gain : array_like, optional
        ``controller='estimator'``: ``L_k`` (default
        :func:`control_ncs.estimator_gain` of ``P``).
    initial_gain : array_like, optional
        A first start of the local search, in the shape of ``K.gains``.
    options : dict, optional
        The solver's knobs, as :func:`scipy.optimize.minimize` takes
        them; every key is optional:

        solver : str or None
            Any installed cvxpy solver for the exact program (default
            None: Clarabel).
        margin : float
            Relative lower bound on the covariance ``Q_k`` of the exact
            program (default ``lmi.DEFAULT_MARGIN``, 1e-7).
        time_limit : float or None
            Seconds the local search may take (default 60; None: no
            limit).
        solver_options : dict
            Passed to the solver of the exact program (checked first: an
            option Clarabel, SCS or CVXOPT does not know raises
            ``TypeError``).

        ``solver``, ``margin`` and ``solver_options`` apply to the exact
        program, ``time_limit`` to the local search; an unknown key raises
        ``TypeError``. ``K.result.options`` holds the options used.
    **kwargs
        Deprecated: ``solver``, ``margin``, ``time_limit`` and solver
        options given as keywords still work, with a
        ``DeprecationWarning``; pass them in ``options``.

    Returns
    -------
    K : PeriodicGain
        ``K.result`` is a :class:`DesignResult`; shape ``(N, m2, n)``, or
        ``(N, M, m2, n)`` (gains on the previous mode) over bursty links,
        or one gain per sensor age over delayed links.
    CL : JumpStateSpace
        The closed loop ``w → z``.
    h2 : float
        The exact H2 norm of ``CL`` (not the solver's objective); for a
        plant sampled from a continuous one (``nss(sys_c, ..., dt=h)``),
        ``sqrt(J)``, ``J`` the continuous-time cost between the samples
        (:func:`control_ncs.cost`), which is what the design minimises,
        not ``norm(CL, 2)`` at the sampling instants.

    Raises
    ------
    ControlArgument
        ``P`` is not a NetworkedStateSpace, ``D21 ≠ 0`` with a controller
        other than the static gain or over delayed links, an unknown
        ``controller`` or ``actuator``, or options of the other route
        (``solver``, ``margin`` or ``solver_options`` for the local search;
        ``initial_gain`` or ``estimator_gain`` for the exact program).
    TypeError
        An unknown key of ``options``, a knob given both in ``options``
        and as a keyword, or a solver option the solver does not know.
    SynthesisError
        Exact program: ``'infeasible'`` (a proof: the modes in which every
        command is lost alone make every loop mean-square unstable, e.g.
        bursts too long for the plant), the solver gave no gain
        (``'solver_failed'``), or the gain does not make the loop
        mean-square stable (``'not_mss'``). Local search: no stabilising
        gain found (``'not_found'``, ``'time_limit'``: not a proof).

    References
    ----------
    .. [1] O. L. V. Costa, J. B. R. do Val and J. C. Geromel, "A convex
           programming approach to H2 control of discrete-time Markovian
           jump linear systems", *Int. J. Control* 66(4), 1997.

    Examples
    --------
    ``x⁺ = 1.2 x + θ u + w``, ``z = [x; θu]``, half the commands lost: the
    optimal cost is the modified Riccati solution ``S = 5.7626``
    (:func:`control_ncs.dlqr`).

    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, h2 = ncs.h2syn(P)
    >>> round(h2 ** 2, 5)
    5.76262

    The same plant with the command held when lost: the loop state now
    includes the held command, the gain is searched locally, and holding a
    stale command costs more here:

    >>> K, CL, h2 = ncs.h2syn(P, actuator='hold')
    >>> K.result.route, round(h2 ** 2, 3)
    ('local', 9.281)
    """
    opts = resolved_options("h2syn", options, kwargs, DEFAULTS)
    solver_options = opts["solver_options"]
    plan = _plan(P, controller, actuator, opts["solver"], opts["margin"],
                 solver_options, estimator_gain, initial_gain,
                 opts["time_limit"], "h2syn", decay)
    if plan.local:
        return _local_design(P, plan, initial_gain, "h2syn").with_fields(
            options=opts).finish()
    model = h2_model(_decayed(plan.design, plan.decay), plan.margin)
    gains, CL, rate, report = _designed_loop(plan.plant, model, plan.solver,
                                             solver_options, "h2syn",
                                             plan.decay)
    return norm_design("h2", gains, CL, rate, "program", "static", actuator,
                       report=report, decay=plan.decay,
                       solver_value=float(np.sqrt(max(
                           model.problem.value, 0.0)))).with_fields(
        options=opts).finish()


@dataclass(frozen=True)
class Plan:
    """An H2 or H∞ design, validated: the open loop (built once), the route
    and the checked options."""

    plant: JumpPlant         # the loop's open loop (its gain is returned)
    design: JumpPlant        # what the figure is the H2 norm of (the cost
    #                          between the samples, for a continuous plant)
    local: bool
    controller: str
    actuator: str
    time_limit: float | None
    solver: str
    margin: float
    estimator_gain: Any
    decay: float = 1.0
    budget: bool = False     # a loss budget: the worst-case route


def _plan(P: Any, controller: str, actuator: str, solver: str | None,
          margin: Any, solver_options: dict, estimator_gain: Any,
          initial_gain: Any, time_limit: Any, who: str,
          decay: Any = None) -> Plan:
    """The checks h2syn and hinfsyn make first, the open loop (the one
    build of the design) and the route: local when the exact program does
    not cover the loop (each route refuses the other's options)."""
    from ..estimator import estimator_gain as default_estimator
    name, checked_margin = _checked(P, actuator, solver, margin,
                                    solver_options)
    controller = choice(controller, "controller",
                        ("static", "predictor", "estimator"))
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    r = decay_bound(decay)
    L = None
    if controller == "estimator":
        L = estimator_gain if estimator_gain is not None else \
            default_estimator(P)
    elif estimator_gain is not None:
        raise ControlArgument("estimator_gain: only with "
                              "controller='estimator'")
    plant = build(P, controller, actuator, estimator_gain=L)
    if plant.constraint is not None:
        if who == "h2syn":
            raise ControlArgument(
                "P: a link is a loss budget (an automaton of allowed "
                "patterns, no probabilities): an H2 norm averages over the "
                "patterns and has no worst case; design for every allowed "
                "pattern with hinfsyn or passivesyn, or analyse with "
                "ncs.jsr")
        return Plan(plant, plant, False, controller, actuator, time_limit,
                    name, checked_margin, L, r, budget=True)
    # a plant sampled from a continuous one: h2syn minimises the cost
    # between the samples (theory: intersample cost); hinfsyn the l2 gain
    # at the samples
    design = (cost_open_loop(plant) if who == "h2syn"
              and plant.sampling is not None else plant)
    local = _not_exact(P, design, controller, actuator, who) is not None
    if local:
        _no_solver_options(solver, solver_options)
        if margin != DEFAULT_MARGIN:
            raise ControlArgument(
                "margin: this loop's gain is structured and is searched "
                "locally on exact figures; margin applies to the exact "
                "program")
    else:
        _exact_takes_no_start(initial_gain, estimator_gain)
        design.require_noise_free(who)
    return Plan(plant, design, local, controller, actuator, time_limit,
                name, checked_margin, L, r)


def _no_solver_options(solver: str | None, solver_options: dict) -> None:
    """The local search takes no solver options: refuse them by name."""
    given = [k for k, v in (("solver", solver),) if v is not None] + \
        sorted(solver_options)
    if given:
        raise ControlArgument(
            f"{given[0]}: this loop's gain is structured and is searched "
            f"locally on exact figures; solver options apply to the exact "
            f"program (y = x at every step, no delays)")


def _exact_takes_no_start(initial_gain: Any, estimator_gain: Any) -> None:
    """The exact program takes no start and no estimator gain."""
    if initial_gain is not None or estimator_gain is not None:
        name = "initial_gain" if initial_gain is not None else \
            "estimator_gain"
        raise ControlArgument(
            f"{name}: the exact program of this loop needs no start and no "
            f"estimator (they apply to the local search of structured "
            f"gains)")


def _local_h2syn(P: NetworkedStateSpace, controller: str, actuator: str,
                 estimator_gain: Any, initial_gain: Any,
                 time_limit: float | None
                 ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """h2syn's local search (:mod:`control_ncs.synthesis._h2`) run on any
    loop, also one the exact program covers (to compare the two); the
    figure is the exact norm of the loop it returns."""
    plan = _plan(P, controller, actuator, None, DEFAULT_MARGIN, {},
                 estimator_gain, None, time_limit, "h2syn")
    return _local_design(P, plan, initial_gain, "h2syn").finish()


def _local_design(P: NetworkedStateSpace, plan: Plan, initial_gain: Any,
                  who: str) -> Design:
    """The structured loop's local search: on the exact H2 norm, and for
    ``who='hinfsyn'`` then on the bounded real lemma's optimum
    (:mod:`control_ncs.synthesis._hinf`) from there. Returns the
    :class:`Design`: its figure is the exact norm of the loop (h2syn) or
    the certified bound of the better of the two loops (hinfsyn)."""
    # the search's kernels are products of the second-moment map's
    # matrices (n² × n² when dense): on one BLAS thread (see _blas)
    with serial_blas(P.nstates ** 2):
        return _local_search(P, plan, initial_gain, who)


def _local_search(P: NetworkedStateSpace, plan: Plan, initial_gain: Any,
                  who: str) -> Design:
    """:func:`_local_design`'s body."""
    deadline = None if plan.time_limit is None else \
        time.perf_counter() + plan.time_limit
    mats, loop, shape, close, starts, L = _plant_problem(
        P, plan.controller, plan.actuator, plan.estimator_gain, plan.design)
    if initial_gain is not None:
        G = np.asarray(initial_gain, float)
        if G.shape != shape and G.shape != (1,) + shape[1:]:
            raise ControlDimension(f"initial_gain: expected shape {shape}, "
                                   f"got {G.shape}")
        starts.insert(0, np.broadcast_to(G, shape).reshape(
            loop.mask.shape).flat[loop.free].copy())
    Cz, Du, Bw, Dw, pi, Ew = mats
    # hinfsyn: the H2 stage takes at most H2_SHARE of the time left, the
    # rest is the l2 stage's and its certificates'
    h2_deadline = deadline if deadline is None or who == "h2syn" else \
        time.perf_counter() + H2_SHARE * (deadline - time.perf_counter())
    x = local_h2(H2Objective(loop, Cz, Du, Bw, Dw, pi, Ew, plan.decay),
                 starts, h2_deadline, who)

    def closed(x: np.ndarray) -> JumpStateSpace:
        return close(loop.gains(x).reshape(shape))

    certified = None
    if who == "hinfsyn":
        gain = GainObjective(loop, Cz, Du, Bw, Dw, pi, Ew, plan.decay)
        x, certified = _hinf_stage(gain, x, closed, deadline)
    gains = loop.gains(x).reshape(shape)
    CL = plan.plant.close(gains)          # the loop itself, not the figure's
    rate = _rate_within(CL, plan.decay, f"{who}: the local search's gain")
    return norm_design("h2" if who == "h2syn" else "hinf", gains, CL, rate,
                       "local", plan.controller, plan.actuator,
                       estimator_gain=L, certified=certified,
                       decay=plan.decay)


#: hinfsyn's local design: the share of ``time_limit`` its H2 stage may
#: take, and the certificates' time reserved for the end of the l2 stage
#: (as a multiple of what the first certificate took).
H2_SHARE = 0.5
CERTIFICATE_RESERVE = 1.5


def _certified_gain(CL: JumpStateSpace) -> GainResult | None:
    """:func:`l2_gain` of a loop, None when it certifies nothing."""
    try:
        return l2_gain(CL)
    except CertificationError:
        return None


def _hinf_stage(gain: GainObjective, x: np.ndarray, closed: Any,
                deadline: float | None) -> tuple[np.ndarray, GainResult]:
    """hinfsyn's l2 stage from the H2 stage's gain ``x``: certify ``x``
    (:func:`l2_gain`), search on the bounded real lemma's optimum until
    ``HINF_ITERATIONS`` or the deadline less the time to certify where it
    stops, certify that; returns the better certified gain. The time limit
    covers the certificates: the search stops early enough for them (one
    certificate started before the deadline runs to its end)."""
    began = time.perf_counter()
    candidates = [(x, _certified_gain(closed(x)))]
    cost = time.perf_counter() - began
    stop = None if deadline is None else \
        deadline - CERTIFICATE_RESERVE * cost
    if stop is None or time.perf_counter() < stop:
        x2, _, _, _ = bfgs(gain.value, x, -math.inf, stop, HINF_ITERATIONS)
        if not np.array_equal(x2, x):
            candidates.append((x2, _certified_gain(closed(x2))))
    found = [(xc, res) for xc, res in candidates if res is not None]
    if not found:
        raise SynthesisError(
            "hinfsyn: the local search's loops have no certified l2 gain",
            NOT_FOUND, {})
    return min(found, key=lambda c: c[1].gamma)


def _plant_problem(P: NetworkedStateSpace, controller: str, actuator: str,
                   estimator_gain: Any, plant: JumpPlant | None = None
                   ) -> tuple:
    """A structured loop of the network's open loop ``plant`` (built here
    when not given) for the local designs: its output and noise matrices,
    the rate loop, the gains' shape, its closing and its starts: the
    full-information optimum of the same open loop (the exact H2 program
    with the gain seeing the whole loop state) and the mean-square LQ gain,
    each projected on what the gain reads, that LQ gain restricted, and
    zero."""
    from ..estimator import estimator_gain as default_estimator
    from ._local import Loop, lq_gain, projected, restrict
    L = estimator_gain
    if plant is None:
        if controller == "estimator" and L is None:
            L = default_estimator(P)
        plant = build(P, controller, actuator, estimator_gain=L)
    if plant.Gw is not None:
        raise ControlArgument(
            f"P: design with measurement noise (D21 ≠ 0) is written for the "
            f"static gain, which reads the noise at once; with "
            f"controller={controller!r} the noise arrives with the next "
            f"step: design for D21 = 0 and analyse the loop with the noise, "
            f"feedback(P, K, controller={controller!r})")
    loop = Loop(plant, plant.probabilities, plant.transition)
    mats = (plant.Cz, plant.Du, plant.Bw, plant.Dw, plant.probabilities,
            plant.readings()[1])
    G = lq_gain(plant, plant.probabilities)
    starts = [x for x in (projected(plant, loop, _full_information(plant)),
                          projected(plant, loop, G)) if x is not None]
    starts += [restrict(loop, G), np.zeros(loop.free.size)]
    return mats, loop, plant.gain_shape(), plant.close, starts, L


#: Up to this many loop states the local searches start from the exact H2
#: program of the full-information relaxation (one SDP) when its Riccati
#: recursion does not converge.
FULL_INFORMATION_MAX_STATES = 40

#: Sweeps over the period of the full-information Riccati recursion.
RICCATI_SWEEPS = 2000


def _full_information(plant: JumpPlant) -> np.ndarray:
    """The H2-optimal gain on the whole loop state of ``plant`` (its
    reading replaced by the identity: the full-information relaxation of
    the same open loop), per phase; zero gains when none is found (Markov
    modes, a solver failure, a large loop): a start, not a figure.

    For i.i.d. modes the optimum is the periodic Riccati recursion's of LQ
    with multiplicative noise (:func:`_riccati_h2_gain`); the exact H2
    program (one SDP) only where that recursion does not converge."""
    s = plant.shape
    zero = np.zeros((plant.period, s["nu"], s["nx"]))
    if plant.transition is not None:
        return zero
    gains = _riccati_h2_gain(plant)
    if gains is not None:
        return gains
    if s["nx"] > FULL_INFORMATION_MAX_STATES:
        return zero
    full = replace(plant, E=np.broadcast_to(np.eye(s["nx"]), (
        plant.period, s["nx"], s["nx"])), Ew=None, Gw=None)
    try:
        model = h2_model(full, DEFAULT_MARGIN)
        report = solve(model.problem)
        if report.status not in ("optimal", "optimal_inaccurate"):
            return zero
        gains = model.gains()
    except (ValueError, np.linalg.LinAlgError, ArithmeticError):
        return zero
    return gains if np.all(np.isfinite(gains)) else zero


def _riccati_h2_gain(plant: JumpPlant) -> np.ndarray | None:
    """The full-information H2-optimal periodic gains of i.i.d. modes by
    the Riccati recursion of the cost-to-go ``ξᵀ S_k ξ`` (value iteration
    from ``S = 0`` over the period, backwards):

    ``H_k = Σ_i p_ki (Bu_kiᵀ S_{k+1} Bu_ki + Du_kiᵀ Du_ki)``,
    ``g_k = Σ_i p_ki (Bu_kiᵀ S_{k+1} A_ki + Du_kiᵀ Cz_ki)``,
    ``K_k = -H_k⁻¹ g_k``, ``S_k = Σ_i p_ki (A_kiᵀ S_{k+1} A_ki + Cz_kiᵀ
    Cz_ki) + g_kᵀ K_k``:

    the gain does not depend on the mode drawn at the step (the controller
    does not know it), and additive noise does not change the optimal
    gain of LQ with multiplicative noise, so these gains minimise the
    loop's H2 norm among gains that see the whole state (the H2 program's
    optimum). Inputs no mode acts with at a phase (``H``'s zero rows) get
    zero gains. None when the recursion does not converge (to ``1e-12``
    relative) in ``RICCATI_SWEEPS`` sweeps: no stabilising gain, or a slow
    approach to the critical loss."""
    N, nx, nu = plant.period, plant.shape["nx"], plant.shape["nu"]
    A, Bu, Cz, Du, p = plant.A, plant.Bu, plant.Cz, plant.Du, \
        plant.probabilities
    CC = np.einsum("km,kmza,kmzb->kab", p, Cz, Cz)
    DD = np.einsum("km,kmza,kmzb->kab", p, Du, Du)
    DC = np.einsum("km,kmza,kmzb->kab", p, Du, Cz)
    S = np.zeros((nx, nx))
    K = np.zeros((N, nu, nx))
    pw = p[:, :, None, None]
    for _ in range(RICCATI_SWEEPS):
        S_end = S
        for k in reversed(range(N)):
            SA = S @ A[k]                              # (M, nx, nx)
            SB = S @ Bu[k]                             # (M, nx, nu)
            AtSA = np.sum(pw[k] * (A[k].transpose(0, 2, 1) @ SA), axis=0)
            H = np.sum(pw[k] * (Bu[k].transpose(0, 2, 1) @ SB), axis=0) \
                + DD[k]
            g = np.sum(pw[k] * (Bu[k].transpose(0, 2, 1) @ SA), axis=0) \
                + DC[k]
            live = np.flatnonzero(np.diag(H) > 0)
            K[k] = 0.0
            if live.size:
                try:
                    K[k][live] = -np.linalg.solve(H[np.ix_(live, live)],
                                                  g[live])
                except np.linalg.LinAlgError:
                    return None
            S = AtSA + CC[k] + g.T @ K[k]
            S = 0.5 * (S + S.T)
        if not np.all(np.isfinite(S)):
            return None
        size = float(np.linalg.norm(S))
        if float(np.linalg.norm(S - S_end)) <= 1e-12 * max(size, 1e-300):
            return K.copy()
    return None


def hinfsyn(P: NetworkedStateSpace, *, decay: float | None = None,
            controller: str = "static", actuator: str = "zero",
            estimator_gain: Any = None, initial_gain: Any = None,
            options: Mapping[str, Any] | None = None, **kwargs: Any
            ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """ℓ2-gain (H∞) optimal periodic feedback over the network.

    Like :func:`control.hinfsyn` (python-control's generalized-plant
    layout), for the periodic jump loop of the plant and its network: the
    periodic static gains ``u = K_k x`` (positive feedback,
    :ref:`guide-sign`) minimising the loop's ℓ2 gain from
    ``w`` to ``z`` for inputs adapted to the past, by the bounded real
    lemma in ``X_k = P_k⁻¹``, ``Y_k = K_k X_k`` (convex, and exact for
    ``y = x`` at every phase; over bursty links with gains ``K_{k,ℓ}`` on
    the previous link state and storages per previous state, exact again).
    The returned ``gamma`` is
    the certified upper bound of :func:`control_ncs.l2_gain` on the
    designed loop — its own LMI and exact check — never this program's
    objective; ``K.result`` is a :class:`DesignResult` whose ``certificate``
    is that :class:`GainResult` (with the lower end
    of the bracket).

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant with its network, as for :func:`h2syn`: the exact program
        needs ``y = x`` at every step; otherwise the local search runs.
    decay : float in (0, 1], optional
        As for :func:`h2syn`.
    controller : {'static', 'predictor', 'estimator'}, optional
        As for :func:`h2syn`.
    actuator : {'zero', 'hold'}, optional
        What the actuator applies when a command is lost (the exact program
        needs ``'zero'``).
    estimator_gain, initial_gain : optional
        As for :func:`h2syn` (the local search).
    options : dict, optional
        The solver's knobs, keys as for :func:`h2syn`: ``solver``,
        ``margin`` (here the bounded real lemma's relative strictness
        margin) and ``solver_options`` for the exact program, and
        ``time_limit`` (default 60 s) for the local search, which covers
        its certificates. An unknown key raises ``TypeError``.
    **kwargs
        Deprecated: ``solver``, ``margin``, ``time_limit`` and solver
        options given as keywords still work, with a
        ``DeprecationWarning``; pass them in ``options``.

    Returns
    -------
    K : PeriodicGain
    CL : JumpStateSpace
    gamma : float
        The certified ℓ2-gain bound of ``CL``.

    Raises
    ------
    ControlArgument, TypeError
        As :func:`h2syn`.
    SynthesisError
        As :func:`h2syn`: exact program ``'infeasible'`` (a proof),
        ``'solver_failed'``, ``'not_mss'``; local search ``'not_found'`` or
        ``'time_limit'`` (no stabilising gain, or no certified bound of its
        loops: not a proof).
    CertificationError
        The designed loop's gain could not be certified (see
        :func:`control_ncs.l2_gain`).

    Examples
    --------
    ``x⁺ = 1.2 x + w + θ u``, ``z = [x; θu]``, half the commands lost:

    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, gamma = ncs.hinfsyn(P)
    >>> bool(K.result.lower <= gamma), K.result.status
    (True, 'certified')

    With the command held when lost the gain is structured and searched
    locally; the bound is still certified on the returned loop:

    >>> K, CL, gamma = ncs.hinfsyn(P, actuator='hold')
    >>> K.result.route, K.result.status
    ('local', 'certified')
    """
    opts = resolved_options("hinfsyn", options, kwargs, DEFAULTS)
    solver, solver_options = opts["solver"], opts["solver_options"]
    plan = _plan(P, controller, actuator, solver, opts["margin"],
                 solver_options, estimator_gain, initial_gain,
                 opts["time_limit"], "hinfsyn", decay)
    if plan.budget:
        design = budget_design(plan.plant, "hinf", decay=plan.decay,
                               solver=solver, solver_options=solver_options)
    elif plan.local:
        design = _local_design(P, plan, initial_gain, "hinfsyn")
    else:
        model = hinf_model(_decayed(plan.plant, plan.decay), plan.margin)
        gains, CL, rate, report = _designed_loop(
            plan.plant, model, plan.solver, solver_options, "hinfsyn",
            plan.decay)
        design = norm_design("hinf", gains, CL, rate, "program", "static",
                             actuator, report=report, decay=plan.decay,
                             certified=l2_gain(CL, solver=solver))
    return design.with_fields(options=opts).finish()


def norm_design(spec: str, gains: np.ndarray, CL: JumpStateSpace,
                rate: float, route: str, controller: str, actuator: str, *,
                report: Any = None, solver_value: float = math.nan,
                estimator_gain: Any = None,
                certified: GainResult | None = None,
                decay: float = 1.0) -> Design:
    """An H2 or H∞ design's answer: the figure measured on its loop (the
    exact norm, or the ℓ2 gain's certified bound with its lower end), how
    it was found and whether that route is exact."""
    note = ""
    if spec == "h2" and "sampling" in CL.info:
        # the figure of a loop sampled from a continuous plant: √J, the
        # cost between the samples measured on the loop by cost()
        value, lower, cert = math.sqrt(cost(CL).cost), math.nan, None
        note = ("a sampled continuous plant: the figure is sqrt(J), J the "
                "continuous-time cost between the samples (ncs.cost)")
    elif spec == "h2":
        value, lower, cert = norm(CL, 2), math.nan, None
    else:
        assert certified is not None
        value, lower, cert = certified.gamma, certified.lower, certified
        solver_value = certified.gamma_solver
    program = route == "program"
    if program and decay < 1.0:
        note = "; ".join(filter(None, [note, (
            f"decay {decay:g}: the program bounds the loop whose dynamics "
            f"are divided by the decay (sufficient, not exact)")]))
    return Design(gains, CL, dict(
        spec=spec, value=float(value), route=route,
        method="lmi" if program else "refine",
        exact=program and decay == 1.0, decay=float(decay),
        ms_radius=float(rate), controller=controller, actuator=actuator,
        period=int(gains.shape[0]),
        gain_kind="mode" if gains.ndim == 4 else "phase",
        structure="full" if program else "structured", certificate=cert,
        lower=float(lower), solver_value=float(solver_value),
        report=report, note=note), estimator_gain)
