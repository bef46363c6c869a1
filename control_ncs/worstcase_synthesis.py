"""State-feedback design certified for every allowed switching pattern.

:func:`worst_case_design` designs gains for a
:class:`~control_ncs.ConstrainedPlant` (an open loop whose modes switch along
a graph: a loss budget over the actuator link) for one of three specs
(:ref:`theory-worst-case-dissipativity`):

* ``'stability'`` -- every pattern decays at least at a rate ``r``
  (a rate may be asked of the other two as well);
* ``'gain'`` -- the worst-case ℓ2 gain ``γ`` minimised;
* ``'passivity'`` -- the worst-case passivity level ``η`` maximised.

The gain may depend on the node of the graph's memory-``M`` lift the
controller is at (it knows which messages arrived from acknowledgements):
``X_u = P_u⁻¹``, ``Y_u = K_u X_u`` make the design LMIs convex, exact for
storages of that structure; growing ``M`` is the exact route (Lee and
Dullerud 2006). One gain for every node (``gain='common'``) uses a common
slack ``G`` (``K = Y G⁻¹``) and is sufficient only. The figure returned is
never the design LMI's: the fixed loop is analysed again
(:mod:`control_ncs.worstcase`) and its decay rate checked below 1 exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import choice, positive_int, positive_real
from ._patterns import closed_walks
from ._results import Result
from .exceptions import (CERTIFIED, CERTIFIED_SHORTAGE, INFEASIBLE,
                         NOT_VERIFIED, SOLVER_FAILED, SUFFICIENT_FAILED,
                         CertificationError, SynthesisError)
from .lmi import check_options, check_solver
from .lmi.worstcase import design_model, solve_once
from .switching import ConstrainedPlant, GraphLift, SwitchingSystem
from .worstcase import (CYCLE_LENGTH, MARGIN, TOL, WorstCaseRate,
                        storage_rate, worst_case_gain, worst_case_passivity,
                        worst_case_rate)

__all__ = ["worst_case_design", "WorstCaseDesign"]

SPECS = ("stability", "gain", "passivity")


@dataclass(frozen=True, repr=False)
class WorstCaseDesign(Result):
    """Gains certified for every allowed pattern, with their loop.

    Attributes
    ----------
    K : ndarray
        ``gain='node'``: shape (V, q, n), ``K[a]`` applied at the lifted
        node ``walks[a]`` (``u = K[a] x``); ``gain='common'``: shape
        (q, n).
    gain : str
        ``'node'`` or ``'common'``.
    spec : str
        ``'stability'``, ``'gain'`` or ``'passivity'``.
    figure : float
        Certified by analysing the fixed loop for every allowed pattern:
        the decay rate, the ℓ2 gain ``γ`` or the passivity level ``η``.
    bound : float
        The other side for this loop, from its worst periodic pattern.
    exact : bool
        The loop's bracket closed within ``tol``.
    rate : float
        The loop's decay rate for every pattern, proven exactly (an upper
        bound on its joint spectral radius); below 1.
    rate_lower : float
        The fastest periodic pattern of the loop (a lower bound on it).
    cycle, cycle_edges : tuple of int
        The loop's worst periodic pattern found, as the plant's modes and
        edges.
    memory : int
    walks : tuple
        The lifted nodes (node of the plant's graph, last edges).
    loop : SwitchingSystem
        The closed loop on the lifted graph (one mode per lifted edge).
    analysis : WorstCaseResult or WorstCaseRate
        The analysis of ``loop`` that certified ``figure``.
    figure_synthesis : float
        The design LMI's own figure (never the certified one).
    report : SolveReport
        The design LMI's solve.

    Examples
    --------
    >>> P = ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 0.0,
    ...                                [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> res = ncs.worst_case_design(P, spec="gain")
    >>> res.status, round(res.figure, 6), round(res.bound, 6)
    ('certified', 2.0, 2.0)
    """

    K: np.ndarray
    gain: str
    spec: str
    figure: float
    bound: float
    exact: bool
    rate: float
    rate_lower: float
    cycle: tuple
    cycle_edges: tuple
    memory: int
    walks: tuple
    loop: SwitchingSystem
    analysis: Any
    figure_synthesis: float
    report: Any

    _repr_fields: ClassVar[tuple[str, ...]] = ("spec", "figure", "rate")

    @property
    def success(self) -> bool:
        """True: a design exists only with its figure certified."""
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
        what = {"stability": "decay rate", "gain": "l2 gain",
                "passivity": "passivity level eta"}[self.spec]
        return (f"{what} {self.figure:.6g} for every allowed pattern, "
                f"certified on the fixed loop ({self.gain} gains, memory "
                f"{self.memory}; the loop's patterns allow "
                f"{self.bound:.6g})")

    def _details(self) -> list[str]:
        return [f"certified {self.figure:.8g} (design LMI "
                f"{self.figure_synthesis:.8g}), other side {self.bound:.8g} "
                f"from the pattern {self.cycle}",
                f"decay rate {self.rate:.6g} proven for every pattern "
                f"(fastest periodic pattern {self.rate_lower:.6g})",
                f"{len(self.walks)} lifted nodes, gains "
                f"{'per node' if self.gain == 'node' else 'common'}"]


def _coerce_plant(plant: Any, graph: Any) -> ConstrainedPlant:
    if isinstance(plant, ConstrainedPlant):
        if graph is not None:
            raise ControlArgument("graph: a ConstrainedPlant carries its "
                                  "graph; give one or the other")
        return plant
    if isinstance(plant, (list, tuple)) and len(plant) == 6:
        A, Bu, Bw, Cz, Du, Dw = plant
        return ConstrainedPlant(A, Bu, Bw, Cz, Du, Dw, graph)
    raise ControlArgument(
        f"plant: expected a ConstrainedPlant or a tuple (A, Bu, Bw, Cz, Du, "
        f"Dw) of per-mode arrays, got {type(plant).__name__}")


def _uncontrolled_proof(P: ConstrainedPlant, goal: float,
                        cycle_length: int) -> None:
    """Raise ``'infeasible'`` when a periodic pattern loses every command
    and is not faster than ``goal``: no gain of any memory helps it."""
    modes = P.graph.edges[:, 2]
    dead = [not np.any(P.Bu[i]) for i in modes]
    for w in closed_walks(P.graph, cycle_length):
        if not all(dead[e] for e in w):
            continue
        T = np.eye(P.nstates)
        for e in w:
            T = P.A[modes[e]] @ T
        r = float(np.max(np.abs(np.linalg.eigvals(T)))) ** (1 / len(w))
        if r >= goal:
            seq = tuple(int(modes[e]) for e in w)
            raise SynthesisError(
                f"worst_case_design: the periodic pattern {seq} (modes in "
                f"order) applies no command and decays at {r:.6g} >= "
                f"{goal:.6g}: no gain of any memory meets the spec",
                INFEASIBLE, dict(cycle=seq, rate=r))


def _supply(P: ConstrainedPlant, spec: str) -> tuple | None:
    p, m = P.Cz.shape[-2], P.Bw.shape[-1]
    if spec == "gain":
        return (-np.eye(p), np.zeros((p, m)), np.zeros((m, m)))
    if spec == "passivity":
        if p != m:
            raise ControlDimension(f"plant: passivity needs as many outputs "
                                   f"z as inputs w, got {p} and {m}")
        return (np.zeros((m, m)), np.eye(m), np.zeros((m, m)))
    return None


def _solve_design(P: ConstrainedPlant, lift: GraphLift, spec: str,
                  common: bool, rate: float, margin: float, name: str | None,
                  options: dict) -> tuple:
    # the lifted edges carry the plant's modes
    model = design_model(P.A, P.Bu, P.Bw, P.Cz, P.Du, P.Dw,
                         lift.graph.edges, lift.graph.nodes,
                         supply=_supply(P, spec),
                         rate=rate, common=common, margin=margin)
    report = solve_once(model.problem, name, options)
    structure = ("one gain for every node (a common slack: sufficient only)"
                 if common else f"gains per node of the memory-{lift.memory} "
                                f"lift (more memory may find one)")
    if report.infeasible:
        raise SynthesisError(
            f"worst_case_design: no {structure} (solver status "
            f"{report.status!r}); nothing is proven about other gains",
            SUFFICIENT_FAILED, dict(status=report.status,
                                    memory=lift.memory))
    if report.status not in ("optimal", "optimal_inaccurate") or any(
            X.value is None for X in model.X):
        raise SynthesisError(
            f"worst_case_design: the solver gave no gain (status "
            f"{report.status!r})", SOLVER_FAILED, dict(status=report.status))
    K = model.gains()
    X = np.array([np.asarray(Xu.value, float) for Xu in model.X])
    level = None if model.level is None else float(model.level.value)
    return K, X, level, report


def _certify(loop: SwitchingSystem, spec: str, rate: float, X: np.ndarray,
             cycle_length: int, tol: float, name: str | None, margin: float,
             options: dict) -> tuple:
    """Analyse the fixed loop; the design's storages ``X⁻¹`` prove a rate
    too (whichever proves less is reported)."""
    edges = loop.graph.edges
    rate_design = storage_rate(loop.A, edges, np.linalg.inv(X))
    try:
        if spec == "stability":
            analysis: Any = worst_case_rate(
                loop, cycle_length=cycle_length, tol=tol, solver=name,
                **options)
            proven = min(analysis.rate, rate_design)
            figure, bound = proven, analysis.lower
        else:
            analyse = worst_case_gain if spec == "gain" else \
                worst_case_passivity
            analysis = analyse(loop, cycle_length=cycle_length, tol=tol,
                               solver=name, margin=margin, **options)
            proven = min(analysis.rate, rate_design)
            figure, bound = analysis.figure, analysis.bound
    except CertificationError as err:
        raise SynthesisError(
            f"worst_case_design: the designed loop could not be certified "
            f"({err})", NOT_VERIFIED, dict(err.figures)) from err
    if not proven < rate:
        raise SynthesisError(
            f"worst_case_design: the designed loop's decay rate is proven "
            f"only {proven:.6g}, not below {rate:.6g}", NOT_VERIFIED,
            dict(rate=proven))
    return analysis, figure, bound, proven


def _in_units(spec: str, level: float | None, rate: float) -> float:
    if spec == "gain" and level is not None:
        return math.sqrt(max(-level, 0.0))
    if spec == "passivity" and level is not None:
        return level / 2
    return rate


def worst_case_design(plant: Any, graph: Any = None, *, spec: str = "gain",
                      rate: float = 1.0, memory: int = 0,
                      gain: str = "node", cycle_length: int = CYCLE_LENGTH,
                      tol: float = TOL, solver: str | None = None,
                      margin: float = MARGIN,
                      **solver_options: Any) -> WorstCaseDesign:
    """Design state feedback certified for every allowed pattern.

    The gain ``K_u`` applied on the edges leaving the node ``u`` of the
    memory-``M`` lift of the plant's graph (the node the controller is at:
    the automaton state and the last ``M`` outcomes, known from
    acknowledgements) is found by the LMIs of
    :ref:`theory-worst-case-dissipativity` (``X_u = P_u⁻¹``,
    ``Y_u = K_u X_u``), then the fixed loop is analysed for every allowed
    pattern (:func:`worst_case_rate`, :func:`worst_case_gain`,
    :func:`worst_case_passivity`) and its decay rate proven below 1 (or
    ``rate``) exactly. The figure returned is that analysis's.

    Parameters
    ----------
    plant : ConstrainedPlant or tuple (A, Bu, Bw, Cz, Du, Dw)
        The open loop per mode (a single matrix stands for every mode).
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed patterns (default: arbitrary switching; not with a
        ConstrainedPlant, which has its graph).
    spec : {'gain', 'passivity', 'stability'}, optional
        Minimise the worst-case ℓ2 gain from ``w`` to ``z``, maximise the
        passivity level, or stabilise every pattern with decay ``rate``.
    rate : float, optional
        A decay rate every pattern must beat (default 1: stable); for
        ``'gain'`` and ``'passivity'`` the design's storages decay at it.
    memory : int, optional
        Gains and storages on the memory-``M`` lift (0: per node).
    gain : {'node', 'common'}, optional
        A gain per lifted node, or one gain for every node (sufficient
        only).
    cycle_length : int, optional
        Longest periodic pattern examined by the analysis.
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
    WorstCaseDesign

    Raises
    ------
    SynthesisError
        ``'infeasible'`` when a periodic pattern applies no command and is
        too slow on its own (proven); ``'sufficient_failed'`` when the LMI
        of this structure has no solution (not a proof); ``'solver_failed'``;
        ``'not_verified'`` when the fixed loop fails its analysis.
    ControlDimension
        Shapes that do not fit.

    Examples
    --------
    ``x⁺ = 2x + θu + w``, ``z = x``, at most two commands lost in a row:
    gains per node, certified on the fixed loop.

    >>> G = [(0, 0, 1), (0, 1, 0), (1, 0, 1), (1, 2, 0), (2, 0, 1)]
    >>> P = ncs.ConstrainedPlant.lossy(2.0, 1.0, 1.0, 1.0, 0.0, 0.0, G)
    >>> res = ncs.worst_case_design(P, spec="stability")
    >>> res.status, res.rate < 1, res.K.shape
    ('certified', True, (3, 1, 1))
    """
    spec = choice(spec, "spec", SPECS)
    choice(gain, "gain", ("node", "common"))
    if isinstance(memory, (bool, np.bool_)) or not isinstance(
            memory, (int, np.integer)) or memory < 0:
        raise ValueError(f"memory: expected an int >= 0, got {memory!r}")
    rate = positive_real(rate, "rate")
    cycle_length = positive_int(cycle_length, "cycle_length")
    tol = positive_real(tol, "tol")
    margin = positive_real(margin, "margin")
    check_options(check_solver(solver), solver_options)
    name = solver
    P = _coerce_plant(plant, graph)
    _supply(P, spec)                                   # checks the shapes
    _uncontrolled_proof(P, rate, cycle_length)
    lift = P.graph.lift(int(memory))
    K, X, level, report = _solve_design(P, lift, spec, gain == "common",
                                        rate, margin, name, solver_options)
    loop = P.close(K, lift)
    analysis, figure, bound, proven = _certify(
        loop, spec, rate, X, cycle_length, tol, name, margin, solver_options)
    origin = lift.origin
    loop_edges = analysis.cycle_edges
    cycle_edges = tuple(int(origin[e]) for e in loop_edges)
    cycle = tuple(int(P.graph.edges[e, 2]) for e in cycle_edges)
    rate_lower = (analysis.lower if isinstance(analysis, WorstCaseRate)
                  else analysis.rate_lower)
    exact = bool(abs(figure - bound) <= tol * max(abs(figure), abs(bound),
                                                  1e-300))
    return WorstCaseDesign(
        K, gain, spec, figure, bound, exact, proven, rate_lower, cycle,
        cycle_edges, int(memory), lift.walks, loop, analysis,
        _in_units(spec, level, rate), report)

