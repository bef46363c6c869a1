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
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from control.exception import ControlArgument, ControlDimension

from .._checks import choice, positive_real
from ._h2 import H2Objective, local_h2
from ._hinf import GainObjective
from ._local import bfgs
from .._results import CertifiedResult
from ..exceptions import (NOT_FOUND, NOT_MSS, SOLVER_FAILED,
                         CertificationError, SynthesisError)
from ..gain import PeriodicGain, actuators
from ..jump import JumpStateSpace
from ..lmi import (DEFAULT_MARGIN, check_options, check_solver, gain_kinds,
                  h2_model, hinf_model, solve)
from ..performance import GainResult, l2_gain, norm
from ..plant import NetworkedStateSpace
from ..stability import ms_radius
from ..strategies import build
from ._routes import _open_loop_bound

__all__ = ["h2syn", "H2Result", "hinfsyn"]

#: Quasi-Newton iterations of hinfsyn's local stage on the bounded real
#: lemma (each solves the lemma's LMI once).
HINF_ITERATIONS = 30


@dataclass(repr=False)
class H2Result(CertifiedResult):
    """What :func:`h2syn` designed and measured.

    Attributes
    ----------
    h2 : float
        The exact H2 norm of the closed loop (the certified figure).
    h2_solver : float
        ``√`` of the solver's objective (an upper bound it claims; never the
        returned number).
    ms_radius : float
        The loop's exact mean-square rate.
    report : SolveReport or None
        The solver's status and timings (None for the local search).
    route : {'program', 'local'}
        ``'program'``: the exact convex program, the global optimum over
        the gains; ``'local'``: the local search on the exact norm
        (structured gains), a local optimum.

    Examples
    --------
    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, h2 = ncs.h2syn(P)
    >>> K.result.status
    'certified'
    """

    h2: float
    h2_solver: float
    ms_radius: float
    report: Any
    route: str = "program"

    _repr_fields: ClassVar[tuple[str, ...]] = ("h2", "ms_radius", "route")

    @property
    def message(self) -> str:
        """One sentence."""
        how = ("the global optimum (exact program)" if self.route ==
               "program" else "a local optimum of the structured gain")
        return (f"the loop is mean-square stable with H2 norm "
                f"{self.h2:.6g} (exact), {how}")

    def _details(self) -> list[str]:
        bound = ("" if self.route != "program" else
                 f" (solver's bound {self.h2_solver:.8g})")
        return [f"H2 norm {self.h2:.8g} exact{bound}, ms_radius "
                f"{self.ms_radius:.6g}, route {self.route!r}"]


def _not_exact(P: NetworkedStateSpace, controller: str, actuator: str,
               who: str) -> tuple[str, str] | None:
    """Why the exact program does not cover this loop, as ``(argument,
    message)``; None when it does (static state feedback that sees the
    whole state at every step, zero actuator, no delays, a bursty link's
    state revealed at every step)."""
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
    plant = build(P, "static", actuator)
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


def _full_information(P: Any, actuator: str, solver: str | None,
                      margin: Any, solver_options: dict, who: str
                      ) -> tuple[Any, str, float]:
    """The checks of the exact full-information programs; the open loop.
    Refuses (``ControlArgument``) a loop the exact program does not cover."""
    name, margin = _checked(P, actuator, solver, margin, solver_options)
    why = _not_exact(P, "static", actuator, who)
    if why is not None:
        raise ControlArgument(why[1])
    plant = build(P, "static", actuator)
    plant.require_noise_free(who)
    return plant, name, margin


def _designed_loop(plant: Any, model: Any, name: str, solver_options: dict,
                   who: str) -> tuple[np.ndarray, JumpStateSpace, float, Any]:
    """Solve ``model``, read its gains, close the loop and require it
    mean-square stable: ``(gains, CL, ms_radius, report)``. Before the
    solve, the one proof that needs no solver: the modes no gain acts in
    (a lost command) alone make every loop mean-square unstable."""
    _open_loop_bound(plant, 1.0, who)
    report = solve(model.problem, name, **solver_options)
    if report.status not in ("optimal", "optimal_inaccurate") or \
            model.problem.value is None:
        raise SynthesisError(f"{who}: the solver gave no gain (status "
                             f"{report.status!r})", SOLVER_FAILED,
                             dict(status=report.status))
    gains = model.gains()
    CL = plant.close(gains)
    rate = ms_radius(CL)
    if not rate < 1.0:
        raise SynthesisError(
            f"{who}: the solver's gain does not make the loop mean-square "
            f"stable (ms_radius {rate:.6g})", NOT_MSS, dict(ms_radius=rate))
    return gains, CL, rate, report


def h2syn(P: NetworkedStateSpace, *, controller: str = "static",
          actuator: str = "zero", solver: str | None = None,
          margin: float = DEFAULT_MARGIN, estimator_gain: Any = None,
          initial_gain: Any = None, time_limit: float | None = 60.0,
          **solver_options: Any) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """H2-optimal periodic feedback over the lossy network.

    Like :func:`control.h2syn` with python-control's generalized-plant
    layout (inputs ``[w; u]``, outputs ``[z; y]``), for the periodic jump
    loop of the plant and its network: the periodic static gains
    ``u = K_k x`` minimising ``‖G‖₂`` (unit white ``w``; see
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
    controller : {'static', 'predictor', 'estimator'}, optional
        As for :func:`control_ncs.feedback`; over delayed links
        ``'static'`` (a gain per sensor age) or ``'predictor'``.
    actuator : {'zero', 'hold'}, optional
        What the actuator applies when a command is lost (the exact program
        needs ``'zero'``: the loop state is then the plant state).
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative lower bound on the covariance ``Q_k``.
    estimator_gain : array_like, optional
        ``controller='estimator'``: ``L_k`` (default
        :func:`control_ncs.estimator_gain` of ``P``).
    initial_gain : array_like, optional
        A first start of the local search, in the shape of ``K.gains``.
    time_limit : float or None, optional
        Seconds the local search may take (default 60; None: no limit).
    **solver_options
        Passed to the solver.

    Returns
    -------
    K : PeriodicGain
        ``K.result`` is an :class:`H2Result`; shape ``(N, m2, n)``, or
        ``(N, M, m2, n)`` (gains on the previous mode) over bursty links,
        or one gain per sensor age over delayed links.
    CL : JumpStateSpace
        The closed loop ``w → z``.
    h2 : float
        The exact H2 norm of ``CL`` (not the solver's objective).

    Raises
    ------
    ControlArgument
        ``P`` is not a NetworkedStateSpace, ``D21 ≠ 0`` with a controller
        other than the static gain or over delayed links, an unknown
        ``controller`` or ``actuator``, or options of the other route
        (``solver``, ``margin`` or solver options for the local search;
        ``initial_gain`` or ``estimator_gain`` for the exact program).
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
    local, controller, time_limit = _route(
        P, controller, actuator, solver, margin, solver_options,
        estimator_gain, initial_gain, time_limit, "h2syn")
    if local:
        return _local_h2syn(P, controller, actuator, estimator_gain,
                            initial_gain, time_limit)
    plant, name, margin = _full_information(P, actuator, solver, margin,
                                            solver_options, "h2syn")
    model = h2_model(plant, margin)
    gains, CL, rate, report = _designed_loop(plant, model, name,
                                             solver_options, "h2syn")
    h2 = norm(CL, 2)
    K = PeriodicGain(gains, "static", actuator)
    K.result = H2Result(h2, float(np.sqrt(max(model.problem.value, 0.0))),
                        rate, report)
    return K, CL, h2


def _route(P: Any, controller: str, actuator: str, solver: str | None,
           margin: Any, solver_options: dict, estimator_gain: Any,
           initial_gain: Any, time_limit: Any, who: str
           ) -> tuple[bool, str, float | None]:
    """The checks h2syn and hinfsyn make first, and their route:
    ``(local, controller, time_limit)``, ``local`` when the exact program
    does not cover the loop (each route refuses the other's options)."""
    _checked(P, actuator, solver, margin, solver_options)
    given_margin = margin != DEFAULT_MARGIN
    controller = choice(controller, "controller",
                        ("static", "predictor", "estimator"))
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    local = _not_exact(P, controller, actuator, who) is not None
    if local:
        _no_solver_options(solver, solver_options)
        if given_margin:
            raise ControlArgument(
                "margin: this loop's gain is structured and is searched "
                "locally on exact figures; margin applies to the exact "
                "program")
    else:
        _exact_takes_no_start(initial_gain, estimator_gain)
    return local, controller, time_limit


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
    """h2syn's local search (:mod:`control_ncs.synthesis._h2`) on a structured
    loop; the figure is the exact norm of the loop it returns."""
    K, CL, rate, _ = _local_design(P, controller, actuator, estimator_gain,
                                   initial_gain, time_limit, "h2syn")
    h2 = norm(CL, 2)
    K.result = H2Result(h2, math.nan, rate, None, "local")
    return K, CL, h2


def _local_design(P: NetworkedStateSpace, controller: str, actuator: str,
                  estimator_gain: Any, initial_gain: Any,
                  time_limit: float | None, who: str) -> tuple:
    """The structured loop's local search: on the exact H2 norm, and for
    ``who='hinfsyn'`` then on the bounded real lemma's optimum
    (:mod:`control_ncs.synthesis._hinf`) from there. Returns ``(K, CL,
    ms_radius, gamma_result)`` (the last for hinfsyn: the certified bound
    of the better of the two loops, else None)."""
    deadline = None if time_limit is None else \
        time.perf_counter() + time_limit
    mats, loop, shape, close, starts, L = _plant_problem(
        P, controller, actuator, estimator_gain)
    if initial_gain is not None:
        G = np.asarray(initial_gain, float)
        if G.shape != shape and G.shape != (1,) + shape[1:]:
            raise ControlDimension(f"initial_gain: expected shape {shape}, "
                                   f"got {G.shape}")
        starts.insert(0, np.broadcast_to(G, shape).reshape(
            loop.mask.shape).flat[loop.free].copy())
    x = local_h2(H2Objective(loop, *mats), starts, deadline, who)

    def closed(x: np.ndarray) -> JumpStateSpace:
        return close(loop.gains(x).reshape(shape))

    certified = None
    if who == "hinfsyn":
        candidates = [x]
        if deadline is None or time.perf_counter() < deadline:
            gain = GainObjective(loop, *mats)
            x2, _, _, _ = bfgs(gain.value, x, -math.inf, deadline,
                                HINF_ITERATIONS)
            candidates.append(x2)
        best = None
        for xc in candidates:
            try:
                result = l2_gain(closed(xc))
            except CertificationError:
                continue
            if best is None or result.gamma < best[1].gamma:
                best = (xc, result)
        if best is None:
            raise SynthesisError(
                "hinfsyn: the local search's loops have no certified l2 "
                "gain", NOT_FOUND, {})
        x, certified = best
    gains = loop.gains(x).reshape(shape)
    CL = close(gains)
    rate = ms_radius(CL)
    if not rate < 1.0:
        raise SynthesisError(
            f"{who}: the local search's gain does not make the loop "
            f"mean-square stable (ms_radius {rate:.6g})", NOT_MSS,
            dict(ms_radius=rate))
    K = PeriodicGain(gains, controller, actuator)
    if L is not None:
        K.estimator_gain = L
    return K, CL, rate, certified


def _plant_problem(P: NetworkedStateSpace, controller: str, actuator: str,
                   estimator_gain: Any) -> tuple:
    """A structured loop of the network's open loop
    (:class:`~control_ncs.openloop.JumpPlant`) for the local designs: as
    its output and noise matrices, the rate loop, the gains' shape, its
    closing and its starts: the full-information design
    restricted to what the gain sees, the mean-square LQ gain restricted,
    and zero."""
    from ..estimator import estimator_gain as default_estimator
    from ._local import Loop, lq_gain, projected, restrict
    L = None
    if controller == "estimator":
        L = estimator_gain if estimator_gain is not None else \
            default_estimator(P)
    elif estimator_gain is not None:
        raise ControlArgument("estimator_gain: only with "
                              "controller='estimator'")
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
    near = projected(plant, loop, G)
    starts = ([] if near is None else [near]) + [
        restrict(loop, G), np.zeros(loop.free.size)]
    if controller == "static" and plant.shape["nx"] == P.nstates and \
            not P.shared_channel and np.array_equal(P.C2, np.eye(P.nstates)):
        # the exact design with every sensor sending, if that is exact
        full = P.with_network(sensor_schedule=np.ones_like(
            P.sensor_schedule.pattern, dtype=int))
        if _not_exact(full, "static", "zero", "h2syn") is None:
            try:
                K0 = h2syn(full)[0].gains
                if K0.ndim == 3 and K0.shape[0] == plant.period:
                    starts.insert(0, restrict(loop, K0))
            except SynthesisError:
                pass
    return mats, loop, plant.gain_shape(), plant.close, starts, L


def hinfsyn(P: NetworkedStateSpace, *, controller: str = "static",
            actuator: str = "zero", solver: str | None = None,
            margin: float = DEFAULT_MARGIN, estimator_gain: Any = None,
            initial_gain: Any = None, time_limit: float | None = 60.0,
            **solver_options: Any) -> tuple[PeriodicGain, JumpStateSpace,
                                            float]:
    """ℓ2-gain (H∞) optimal periodic feedback over the network.

    Like :func:`control.hinfsyn` (python-control's generalized-plant
    layout), for the periodic jump loop of the plant and its network: the
    periodic static gains ``u = K_k x`` minimising the loop's ℓ2 gain from
    ``w`` to ``z`` for inputs adapted to the past, by the bounded real
    lemma in ``X_k = P_k⁻¹``, ``Y_k = K_k X_k`` (convex, and exact for
    ``y = x`` at every phase; over bursty links with gains ``K_{k,ℓ}`` on
    the previous link state and storages per previous state, exact again).
    The returned ``gamma`` is
    the certified upper bound of :func:`control_ncs.l2_gain` on the
    designed loop — its own LMI and exact check — never this program's
    objective; ``K.result`` is that :class:`GainResult` (with the lower end
    of the bracket).

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant with its network, as for :func:`h2syn`: the exact program
        needs ``y = x`` at every step; otherwise the local search runs.
    controller : {'static', 'predictor', 'estimator'}, optional
        As for :func:`h2syn`.
    actuator : {'zero', 'hold'}, optional
        What the actuator applies when a command is lost (the exact program
        needs ``'zero'``).
    solver, margin, **solver_options
        As for :func:`h2syn` (the exact program only; ``margin`` is the
        bounded real lemma's relative strictness margin).
    estimator_gain, initial_gain, time_limit
        As for :func:`h2syn` (the local search).

    Returns
    -------
    K : PeriodicGain
    CL : JumpStateSpace
    gamma : float
        The certified ℓ2-gain bound of ``CL``.

    Raises
    ------
    ControlArgument
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
    local, controller, time_limit = _route(
        P, controller, actuator, solver, margin, solver_options,
        estimator_gain, initial_gain, time_limit, "hinfsyn")
    if local:
        K, CL, _, certified = _local_design(
            P, controller, actuator, estimator_gain, initial_gain,
            time_limit, "hinfsyn")
        certified.route = "local"
        K.result = certified
        return K, CL, certified.gamma
    plant, name, margin = _full_information(P, actuator, solver, margin,
                                            solver_options, "hinfsyn")
    model = hinf_model(plant, margin)
    gains, CL, rate, report = _designed_loop(plant, model, name,
                                             solver_options, "hinfsyn")
    result: GainResult = l2_gain(CL, solver=solver)
    K = PeriodicGain(gains, "static", actuator)
    result.route = "program"
    K.result = result
    return K, CL, result.gamma
