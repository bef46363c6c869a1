"""Design for every pattern a loss budget allows, from the built open loop.

(:ref:`theory-worst-case`, :ref:`theory-worst-case-dissipativity`.)
:func:`worst_case_route` takes the open loop :func:`~control_ncs.build`
makes for a plant with a loss-budget link (a
:class:`~control_ncs.JumpPlant` with a
:attr:`~control_ncs.JumpPlant.constraint`), writes it as a
:class:`~control_ncs.ConstrainedPlant` on the graph of budget states, runs
:func:`~control_ncs.worst_case_design` (gains per phase and previous budget
state: the automaton state and the last outcome, which the controller
knows from what arrived and the acknowledgements), returns the gains in the
layout :meth:`JumpPlant.close <control_ncs.JumpPlant.close>` takes, and
certifies them again on the loop that ``close`` builds: its joint spectral
radius below the rate (:func:`~control_ncs.jsr`) and its worst-case ℓ2 gain
or passivity level (:func:`~control_ncs.worst_case_gain`,
:func:`~control_ncs.worst_case_passivity`). :func:`budget_plant` is the
first step on its own (the graph and the way back to the gains), for a
design by hand with :func:`~control_ncs.worst_case_design`. The design maps
over (misses, window) run one route per cell (:func:`budget_cell`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from control.exception import ControlArgument

from ._checks import choice, positive_int, positive_real
from ._results import Result
from .constrained import ConstrainedLoop
from .exceptions import (CERTIFIED, CERTIFIED_SHORTAGE, NOT_VERIFIED,
                         SUFFICIENT_FAILED, CertificationError,
                         SynthesisError)
from .joint_spectral import JSRResult, jsr
from .lmi import check_options, check_solver
from .openloop import JumpPlant
from .strategies import build
from .switching import ConstrainedPlant, SwitchingGraph
from .worstcase import (CYCLE_LENGTH, MARGIN, TOL, worst_case_gain,
                        worst_case_passivity)
from .worstcase_synthesis import WorstCaseDesign, worst_case_design

__all__ = ["worst_case_route", "BudgetDesign", "budget_plant",
           "BudgetPlant"]

#: The specifications of the route, in the dispatchers' words, and the
#: one :func:`worst_case_design` calls them.
SPECS = {"passivity": "passivity", "hinf": "gain", "stability": "stability"}

#: The name of the node a pattern starts from (the loop at rest, before
#: step 0; no budget state yet).
REST = "rest"


@dataclass(frozen=True, repr=False)
class BudgetDesign(Result):
    """A gain certified for every pattern a loss budget allows.

    Attributes
    ----------
    gains : ndarray, shape (N, M, nu, nk)
        ``K_{k,ℓ}`` per phase and previous mode, the layout
        :meth:`JumpPlant.close` and :func:`control_ncs.feedback` take: the
        gain of the budget state of the previous mode (every mode with
        that budget state has the same gain).
    spec : {'passivity', 'hinf', 'stability'}
    figure : float
        Certified on :attr:`loop` (the loop ``plant.close(gains)``
        builds, analysed afresh): the passivity level ``η``, the ℓ2 gain
        ``γ``, or, for ``'stability'``, the decay rate (``jsr.upper``).
    bound : float
        The other side for this loop, from its worst periodic pattern.
    exact : bool
        ``figure`` and ``bound`` agree within ``tol``.
    rate : float
        ``jsr(loop).upper``: every allowed pattern decays at least this
        fast (below the rate asked).
    rate_lower : float
        ``jsr(loop).lower``, the rate of the loop's worst periodic pattern.
    cycle : tuple
        That pattern: ``(phase, budget state)`` per step, in order
        (:attr:`JSRResult.cycle`).
    jsr : JSRResult
        The bracket on the loop's joint spectral radius and its
        certificate.
    analysis : WorstCaseResult or None
        The worst-case gain or passivity analysis of :attr:`loop` that
        certifies ``figure`` (None for ``'stability'``, certified by
        :attr:`jsr`).
    loop : ConstrainedLoop
        The closed loop.
    design : WorstCaseDesign
        :func:`worst_case_design`'s answer on the graph of budget states
        (its own certified figure is ``design.figure``).
    nodes : tuple
        The design graph's nodes: ``'rest'`` (before step 0), then
        ``(phase k, budget state at k - 1)``; ``design.K[j]`` is the gain of
        node ``j``.
    tol : float

    Examples
    --------
    >>> P = ncs.nss([[1.5]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=ncs.max_consecutive_losses(1))
    >>> res = ncs.worst_case_route(ncs.build(P), "hinf")
    >>> res.status, round(res.figure, 6), round(res.bound, 6), res.rate < 1
    ('certified', 2.0, 2.0, True)
    """

    gains: np.ndarray
    spec: str
    figure: float
    bound: float
    exact: bool
    rate: float
    rate_lower: float
    cycle: tuple
    jsr: JSRResult
    analysis: Any
    loop: ConstrainedLoop
    design: WorstCaseDesign
    nodes: tuple
    tol: float

    _repr_fields: ClassVar[tuple[str, ...]] = ("spec", "figure", "rate")

    @property
    def success(self) -> bool:
        """True: the route returns only certified gains (else it raises)."""
        return True

    @property
    def status(self) -> str:
        """``'certified'`` (``'certified_shortage'`` for ``η < 0``)."""
        if self.spec == "passivity" and self.figure < 0:
            return CERTIFIED_SHORTAGE
        return CERTIFIED

    @property
    def message(self) -> str:
        """The certified figure in words."""
        what = {"stability": "decay rate", "hinf": "l2 gain",
                "passivity": "passivity level eta"}[self.spec]
        return (f"{what} {self.figure:.6g} for every pattern the budget "
                f"allows, certified on the closed loop (joint spectral "
                f"radius at most {self.rate:.6g}; the worst periodic "
                f"pattern gives {self.bound:.6g})")

    def _details(self) -> list[str]:
        return [f"certified {self.figure:.8g} on the loop, design's own "
                f"{self.design.figure:.8g}, other side {self.bound:.8g}",
                f"jsr(loop) in [{self.rate_lower:.8g}, {self.rate:.8g}] "
                f"({self.jsr.route}); worst pattern {list(self.cycle)}",
                f"gains per phase and previous budget state: "
                f"{len(self.nodes) - 1} nodes"]


# -- validate ---------------------------------------------------------------------
def _check_plant(plant: Any) -> JumpPlant:
    """The open loops the route designs for; every other is refused by
    name."""
    if not isinstance(plant, JumpPlant):
        raise ControlArgument(f"plant: expected the JumpPlant of a plant with "
                              f"a loss-budget link (ncs.build(P)), got "
                              f"{type(plant).__name__}")
    con = plant.constraint
    if con is None:
        raise ControlArgument(
            "plant: its network has no loss budget; design for the "
            "probabilities with passivesyn, h2syn or hinfsyn")
    if (plant.controller or "static") != "static":
        raise ControlArgument(
            f"plant: the route designs a static state-feedback gain; "
            f"controller={plant.controller!r} over a budget can be analysed "
            f"for every pattern (feedback, then ncs.jsr), not designed here")
    if (plant.actuator or "zero") != "zero":
        raise ControlArgument(
            f"plant: the route designs for actuators that apply zero when a "
            f"command is lost; actuator={plant.actuator!r} keeps the last "
            f"input in the loop state, which a state-feedback gain on x "
            f"does not read")
    if con.random:
        raise ControlArgument(
            "plant: part of the network is random besides the budget (a "
            "lossy link, a delay, a sub-sample delay); the route designs for "
            "a network the budgets alone decide. Analyse a given gain with "
            "feedback(P, K) and ncs.jsr (worst case over the budget, mean "
            "square over the rest)")
    if not con.known:
        raise ControlArgument(
            "plant: the budget's automaton is not deterministic (an outcome "
            "may lead to several states), so the controller cannot know its "
            "state; give an automaton with one successor per state and "
            "outcome (the same patterns, e.g. after subset construction)")
    plant.require_noise_free("worst_case_route")
    if plant.reads_per_mode:
        raise ControlArgument("plant: the gain reads another measurement in "
                              "each mode (a delayed link); the route reads "
                              "the state")
    nx, nk = plant.shape["nx"], plant.shape["nk"]
    for k, Ek in enumerate(plant.E):
        if np.any(Ek) and (nk != nx or not np.array_equal(Ek, np.eye(nx))):
            raise ControlArgument(
                f"plant: at phase {k} the controller reads {int(np.sum(Ek))} "
                f"of the {nx} loop states; the route designs u = K x with the "
                f"whole state measured (C2 = I, every sensor scheduled "
                f"together, no buffers)")
    return plant


# -- plan: the graph of budget states ----------------------------------------------
def _mode(plant: JumpPlant, k: int, c: int) -> int:
    """The one mode of budget state ``c`` at phase ``k`` (nothing random)."""
    con = plant.constraint
    assert con is not None
    modes = np.flatnonzero((con.state == c) & (con.weights(k) > 0))
    return int(modes[0])


def _design_graph(plant: JumpPlant) -> tuple[list, list, list]:
    """Nodes ``'rest'`` and ``(k, c_prev)``, edges ``(u, v, (k, c))``: from
    the budget state ``c_prev`` of step ``k - 1`` to ``c`` at step ``k``
    (allowed), applying the plant of phase ``k`` in state ``c``. The
    controller at a node knows it (acknowledgements): its gain."""
    con = plant.constraint
    assert con is not None
    N = con.period
    nodes: list = [REST]
    index: dict = {REST: 0}
    edges: list = []
    todo: deque = deque()

    def visit(key: tuple) -> int:
        if key not in index:
            index[key] = len(nodes)
            nodes.append(key)
            todo.append(key)
        return index[key]

    for c in np.flatnonzero(con.start):
        edges.append((0, visit((1 % N, int(c))), (0, int(c))))
    while todo:
        k, prev = todo.popleft()
        for c in np.flatnonzero(con.allowed[(k - 1) % N, prev]):
            v = visit(((k + 1) % N, int(c)))
            edges.append((index[(k, prev)], v, (k, int(c))))
    return nodes, edges, sorted({e[2] for e in edges})


def _constrained_plant(plant: JumpPlant, edges: list, modes: list
                       ) -> ConstrainedPlant:
    where = {m: j for j, m in enumerate(modes)}
    ks = np.array([k for k, _ in modes])
    idx = np.array([_mode(plant, k, c) for k, c in modes])
    reads = np.array([bool(np.any(plant.E[k])) for k in ks])
    on = reads[:, None, None].astype(float)
    A, Bw, Cz, Dw = (getattr(plant, f)[ks, idx] for f in
                     ("A", "Bw", "Cz", "Dw"))
    # a phase whose controller reads nothing applies no feedback
    Bu = plant.Bu[ks, idx] * on
    Du = plant.Du[ks, idx] * on
    graph = SwitchingGraph([(u, v, where[m]) for u, v, m in edges],
                           nodes=1 + max(max(u, v) for u, v, _ in edges),
                           start=[0])
    return ConstrainedPlant(A, Bu, Bw, Cz, Du, Dw, graph)


def _layout(plant: JumpPlant, nodes: list, K: np.ndarray) -> np.ndarray:
    """Node gains as ``K_{k,ℓ}``: every previous mode ``ℓ`` of budget
    state ``c_prev`` takes the gain of the node ``(k, c_prev)``; previous
    modes no pattern reaches get 0."""
    con = plant.constraint
    assert con is not None
    N, M = plant.probabilities.shape
    nu, nk = plant.gain_shape()[1:]
    out = np.zeros((N, M, nu, nk))
    for j, node in enumerate(nodes):
        if node == REST:
            continue
        k, prev = node
        if np.any(plant.E[k]):
            out[k, con.state == prev] = K[j]
    return out


@dataclass(frozen=True, eq=False)
class BudgetPlant:
    """An open loop over a loss budget on its graph of budget states.

    The :class:`~control_ncs.ConstrainedPlant` that
    :func:`~control_ncs.worst_case_design` reads, and the way back from
    its gains per node to the gains :meth:`JumpPlant.close` and
    :func:`control_ncs.feedback` take. Made by :func:`budget_plant`.

    Parameters
    ----------
    plant : ConstrainedPlant
        One mode per (phase, budget state) a pattern reaches; node ``j`` of
        its graph is ``nodes[j]``; patterns start at node 0 (``'rest'``).
    nodes : tuple
        ``'rest'`` (before step 0), then ``(phase k, budget state of step
        k - 1)``: what the controller knows at step ``k``, by name
        (:attr:`Constraint.names`).
    source : JumpPlant
        The open loop it was made from.

    Attributes
    ----------
    plant, nodes, source
        As given.

    Examples
    --------
    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=ncs.max_consecutive_losses(1))
    >>> bp = ncs.budget_plant(ncs.build(P))
    >>> bp.nodes
    ('rest', (0, (0, 1)), (0, (1, 0)))
    >>> bp.plant.graph.edges.tolist()
    [[0, 1, 0], [0, 2, 1], [1, 1, 0], [1, 2, 1], [2, 1, 0]]
    """

    plant: ConstrainedPlant
    nodes: tuple
    source: JumpPlant

    def gains(self, K: Any) -> np.ndarray:
        """Gains per node as ``K_{k,ℓ}`` per phase and previous mode.

        Every previous mode ``ℓ`` of budget state ``c`` takes the gain of
        the node ``(k, c)``; previous modes no pattern reaches, and phases
        whose controller reads nothing, get 0.

        Parameters
        ----------
        K : array_like, shape (V, nu, nx)
            A gain per node of :attr:`plant`'s graph (as
            ``worst_case_design(...).K``).

        Returns
        -------
        ndarray, shape (N, M, nu, nk)
        """
        con = self.source.constraint
        assert con is not None
        index = [node if node == REST else (node[0],
                                            con.names.index(node[1]))
                 for node in self.nodes]
        return _layout(self.source, index, np.asarray(K, float))


def budget_plant(plant: JumpPlant) -> BudgetPlant:
    """The open loop over a loss budget as a ConstrainedPlant.

    A node of its graph is the phase ``k`` with the budget state of step
    ``k - 1`` (the automaton state and the last outcome, which the
    controller knows from what arrived and the acknowledgements); an edge
    to an allowed next state applies the plant of that phase and budget
    state (a lost command or an unread measurement: no input). Patterns
    start from rest at node 0. :func:`~control_ncs.worst_case_design` on
    it gives a gain per node; :meth:`BudgetPlant.gains` turns them into
    the gains the plant is closed with.

    Parameters
    ----------
    plant : JumpPlant
        From :func:`control_ncs.build` (static controller, zero actuator,
        the state measured, nothing random besides the budgets).

    Returns
    -------
    BudgetPlant

    Raises
    ------
    ControlArgument
        A plant the graph does not describe, named (as
        :func:`worst_case_route`).

    Examples
    --------
    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=ncs.weakly_hard(1, 3))
    >>> bp = ncs.budget_plant(ncs.build(P))
    >>> design = ncs.worst_case_design(bp.plant, spec="stability")
    >>> CL = ncs.feedback(P, bp.gains(design.K))
    >>> bool(ncs.jsr(CL).upper < 1)
    True
    """
    plant = _check_plant(plant)
    nodes, edges, modes = _design_graph(plant)
    names = plant.constraint.names if plant.constraint is not None else ()
    shown = tuple(node if node == REST else (node[0], names[node[1]])
                  for node in nodes)
    return BudgetPlant(_constrained_plant(plant, edges, modes), shown,
                       plant)


# -- run ----------------------------------------------------------------------------
def _certify(plant: JumpPlant, gains: np.ndarray, spec: str, rate: float,
             cycle_length: int, tol: float, solver: str | None,
             margin: float, options: dict) -> tuple:
    """The loop ``plant.close(gains)`` analysed afresh: its joint spectral
    radius below ``rate`` and its figure."""
    loop = plant.close(gains)
    assert isinstance(loop, ConstrainedLoop)
    bracket = jsr(loop, tol=tol)
    if not bracket.upper < rate:
        raise SynthesisError(
            f"worst_case_route: the closed loop's joint spectral radius is "
            f"proven only below {bracket.upper:.6g}, not {rate:.6g}",
            NOT_VERIFIED, dict(rate=bracket.upper, lower=bracket.lower))
    if spec == "stability":
        return loop, bracket, None, bracket.upper, bracket.lower
    analyse = worst_case_gain if spec == "hinf" else worst_case_passivity
    try:
        analysis = analyse(loop.switching(), cycle_length=cycle_length,
                           tol=tol, solver=solver, margin=margin, **options)
    except CertificationError as err:
        raise SynthesisError(
            f"worst_case_route: the closed loop could not be certified "
            f"again ({err})", NOT_VERIFIED, dict(err.figures)) from err
    return loop, bracket, analysis, analysis.figure, analysis.bound


def worst_case_route(plant: JumpPlant, spec: str = "hinf", *,
                     eta: float | None = None, rate: float = 1.0,
                     cycle_length: int = CYCLE_LENGTH, tol: float = TOL,
                     solver: str | None = None, margin: float = MARGIN,
                     **solver_options: Any) -> BudgetDesign:
    """Design a gain certified for every pattern a loss budget allows.

    The open loop of a plant whose link is a loss budget
    (``ncs.build(P)`` for ``nss(..., actuator_loss=ncs.weakly_hard(m, K))``,
    say) becomes a :class:`~control_ncs.ConstrainedPlant` on the graph of
    its budget states: a node is the phase ``k`` and the budget state of
    step ``k - 1`` (the automaton state and the last outcome, which the
    controller knows from what arrived and the acknowledgements), an edge
    the next allowed state with the plant of that mode. A gain per node
    (:func:`~control_ncs.worst_case_design`, the LMIs of
    :ref:`theory-worst-case-dissipativity`: exact for a storage per node,
    sufficient over gains that remember more -- give an automaton whose
    states remember more, such as ``weakly_hard`` with a longer window of
    the same budget, to search those) is returned as ``K_{k,ℓ}`` per phase
    and previous mode, and the loop :meth:`JumpPlant.close` builds with it
    is certified afresh: ``jsr(loop).upper < rate`` and its worst-case ℓ2
    gain or passivity level (:func:`~control_ncs.worst_case_gain`,
    :func:`~control_ncs.worst_case_passivity` on ``loop.switching()``).

    Parameters
    ----------
    plant : JumpPlant
        From :func:`control_ncs.build` with ``controller='static'``,
        ``actuator='zero'``, the state measured (``C2 = I``, the sensors
        scheduled together), and nothing random besides the budgets (the
        other link perfect or a budget too).
    spec : {'hinf', 'passivity', 'stability'}, optional
        Minimise the worst-case ℓ2 gain from ``w`` to ``z``, maximise the
        worst-case passivity level ``η``, or stabilise every pattern.
    eta : float, optional
        ``'passivity'``: the level to reach (the design maximises; a
        certified level below ``eta`` raises).
    rate : float, optional
        A decay rate every pattern must beat (``jsr(loop).upper < rate``);
        default 1.
    cycle_length : int, optional
        Longest periodic pattern the analyses examine.
    tol : float, optional
        Relative width of a bracket called exact.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMIs.
    **solver_options
        Passed to the solver.

    Returns
    -------
    BudgetDesign
        ``gains`` for ``plant.close`` (or ``feedback(P, gains)``), the
        certified ``figure``, ``rate`` and their certificates.

    Raises
    ------
    ControlArgument
        A plant the route does not cover, named: no budget, another
        controller or actuator, a random part beside the budget, a
        nondeterministic automaton, a partly measured state.
    SynthesisError
        ``'infeasible'`` when a periodic pattern applies no command and is
        too slow on its own (proven); ``'sufficient_failed'`` when the LMI
        has no solution, or certifies a level below ``eta`` (nothing is
        proven about gains with more memory); ``'solver_failed'``;
        ``'not_verified'`` when the closed loop fails its analysis.

    Examples
    --------
    ``x⁺ = 2x + w + θu``, ``z = x``, at most one command lost in any
    three: a gain per budget state, stable for every allowed pattern.

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=ncs.weakly_hard(1, 3))
    >>> res = ncs.worst_case_route(ncs.build(P), "stability")
    >>> res.gains.shape, bool(res.rate < 1), res.jsr.scale
    ((1, 6, 1, 1), True, 'matrices')
    >>> bool(ncs.jsr(ncs.feedback(P, res.gains)).upper < 1)
    True
    """
    spec = choice(spec, "spec", tuple(SPECS))
    check_options(check_solver(solver), solver_options)
    plant = _check_plant(plant)
    if eta is not None and spec != "passivity":
        raise ControlArgument(f"eta: only spec='passivity' takes a level, "
                              f"got spec={spec!r}")
    rate = positive_real(rate, "rate")
    cycle_length = positive_int(cycle_length, "cycle_length")
    tol = positive_real(tol, "tol")
    margin = positive_real(margin, "margin")
    graph = budget_plant(plant)
    design = worst_case_design(graph.plant, spec=SPECS[spec], rate=rate,
                               cycle_length=cycle_length, tol=tol,
                               solver=solver, margin=margin,
                               **solver_options)
    gains = graph.gains(design.K)
    loop, bracket, analysis, figure, bound = _certify(
        plant, gains, spec, rate, cycle_length, tol, solver, margin,
        solver_options)
    if eta is not None and not figure >= eta:
        raise SynthesisError(
            f"worst_case_route: the certified level {figure:.6g} is below "
            f"eta = {eta:.6g} (gains per budget state; nothing is proven "
            f"about gains that remember more)", SUFFICIENT_FAILED,
            dict(eta=figure))
    exact = bool(abs(figure - bound) <= tol * max(abs(figure), abs(bound),
                                                  1e-300))
    return BudgetDesign(gains, spec, float(figure), float(bound), exact,
                        float(bracket.upper), float(bracket.lower),
                        bracket.cycle, bracket, analysis, loop, design,
                        graph.nodes, tol)


# -- one cell of a design map ---------------------------------------------------------
def budget_cell(P: Any, objective: str, eta: float | None,
                rate: float) -> tuple:
    """One cell of a design map over a loss budget: ``(value, rate²,
    feasible, reason)`` from :func:`worst_case_route` on ``build(P)``
    (``value`` the certified ``η`` or ``γ``; ``rate²`` the squared
    certified decay rate, the scale of ``ms_radius``). Module level, so
    that a process pool can run it."""
    spec = "passivity" if objective == "eta" else "hinf"
    try:
        res = worst_case_route(build(P), spec,
                               eta=eta if spec == "passivity" else None,
                               rate=rate)
    except SynthesisError as err:
        return math.nan, math.nan, False, err.reason
    return res.figure, res.rate ** 2, True, CERTIFIED
