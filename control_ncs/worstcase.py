"""Worst-case ℓ2 gain, passivity and decay rate over every allowed pattern.

A loop whose modes switch along a graph (:class:`~control_ncs.SwitchingSystem`:
a loss budget, arbitrary switching) is certified for **every** allowed
pattern, not on average (:ref:`theory-worst-case-dissipativity`):

* :func:`worst_case_dissipativity` -- any quadratic supply
  ``s = zᵀQz + 2zᵀSw + wᵀRw`` (``Q ⪯ 0``): a storage per node of the
  graph's memory-``M`` lift, found by an LMI, then checked exactly; the
  certified level ``t`` (``Σ s ≥ t Σ wᵀw`` from rest) is computed from the
  storage by Schur complements, never taken from the solver. The other
  side of the bracket comes from the periodic patterns: each, lifted over
  its period, is an LTI system whose frequency response bounds ``t``.
  :func:`worst_case_gain` (``γ² = -t`` for ``Q = -I``) and
  :func:`worst_case_passivity` (``η = t/2`` for ``S = I``) are its cases.
* :func:`worst_case_rate` -- a decay rate ``r`` for every pattern
  (``‖x_k‖ ≤ c rᵏ``) from node storages ``A_eᵀP_vA_e ≼ r²P_u``, bisected
  and checked exactly; below it, the fastest-growing periodic pattern.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ._checks import positive_int, positive_real
from ._patterns import PatternBound, pattern_bound
from ._results import Result
from .exceptions import (CERTIFIED, CERTIFIED_SHORTAGE, INFEASIBLE, MESSAGES,
                         NOT_MSS, NOT_VERIFIED, SOLVER_FAILED,
                         SUFFICIENT_FAILED, CertificationError)
from .lmi import check_options, check_solver
from .lmi.worstcase import rate_model, solve_once, storage_model
from .performance import _supply_weights
from .switching import GraphLift, SwitchingSystem
from .verify import _float_margin

__all__ = ["worst_case_dissipativity", "worst_case_gain",
           "worst_case_passivity", "WorstCaseResult", "worst_case_rate",
           "WorstCaseRate"]

#: Periodic patterns examined by default: closed walks of up to this many
#: steps.
CYCLE_LENGTH = 8

#: Relative width of a bracket called exact.
TOL = 1e-6

#: Default relative margin of the storage LMIs. The best storage often sits
#: on the boundary of ``M11 ≺ 0`` (in the example of the theory page the
#: storage after a delivery makes ``M11`` singular), so the margin is paid
#: in full in the certified level: 1e-8 costs that much, still well above
#: the solver's accuracy and the rounding of the exact check.
MARGIN = 1e-8

#: Margins tried in turn, as multiples of the given one, until a storage
#: passes the exact check.
RETRIES = (1.0, 1e2, 1e4)


# -- exact checks -------------------------------------------------------------
def supply_levels(sys: SwitchingSystem, P: np.ndarray, Q: np.ndarray,
                  S: np.ndarray, R: np.ndarray) -> tuple:
    """The level each edge certifies with storages ``P``, checked exactly.

    Per edge ``(u, v, i)`` the dissipation matrix at ``t = 0``
    (:func:`control_ncs.lmi.worstcase.storage_model`) has blocks ``M11``,
    ``M12``, ``M22``; with ``M11 ≺ 0`` (beyond rounding) every
    ``t < -λmax(M22 − M12ᵀM11⁻¹M12)`` makes it negative definite. Returns
    ``(levels, m11_max, P_min)``: per edge the supremum (``-inf`` where
    ``M11`` is not negative definite), lowered by the rounding bound of the
    eigenvalue; per edge ``λmax(M11)``; per node ``λmin(P_u)``.
    """
    n, m = sys.nstates, sys.ninputs
    E_w = np.vstack([np.zeros((n, m)), np.eye(m)])
    levels, m11_max = [], []
    for u, v, i in sys.graph.edges:
        F = np.hstack([sys.A[i], sys.B[i]])
        H = np.hstack([sys.C[i], sys.D[i]])
        M = (F.T @ P[v] @ F - H.T @ Q @ H - H.T @ S @ E_w.T
             - E_w @ S.T @ H - E_w @ R @ E_w.T)
        M[:n, :n] -= P[u]
        M = 0.5 * (M + M.T)
        M11, M12, M22 = M[:n, :n], M[:n, n:], M[n:, n:]
        top = float(np.linalg.eigvalsh(M11).max())
        m11_max.append(top)
        if top >= -_float_margin(M11):
            levels.append(-np.inf)
            continue
        Sc = M22 - M12.T @ np.linalg.solve(M11, M12)
        Sc = 0.5 * (Sc + Sc.T)
        levels.append(-float(np.linalg.eigvalsh(Sc).max())
                      - _float_margin(Sc))
    P_min = np.array([np.linalg.eigvalsh(X).min() for X in P])
    return np.array(levels), np.array(m11_max), P_min


def storage_rate(A: np.ndarray, edges: np.ndarray, P: np.ndarray) -> float:
    """The rate that storages ``P_u`` prove, exactly: ``inf`` unless every
    ``P_u ≻ 0``, else ``max_e λmax(L_u⁻¹ A_eᵀ P_v A_e L_u⁻ᵀ)^½`` (``P_u =
    L_u L_uᵀ``), raised by the eigenvalue's rounding bound.

    ``‖x‖_u = ‖L_uᵀ x‖`` is then a norm per node in which every edge
    contracts by that rate, so every allowed product of ``k`` steps has
    norm at most ``κ rᵏ`` (:ref:`theory-worst-case-dissipativity`).
    """
    chol = []
    for X in P:
        if np.linalg.eigvalsh(X).min() <= _float_margin(X):
            return math.inf
        chol.append(np.linalg.cholesky(X))
    worst = 0.0
    for u, v, i in edges:
        Z = np.linalg.solve(chol[u], A[i].T)        # L_u⁻¹ A_eᵀ
        N = Z @ P[v] @ Z.T
        N = 0.5 * (N + N.T)
        worst = max(worst, float(np.linalg.eigvalsh(N).max())
                    + _float_margin(N))
    return math.sqrt(max(worst, 0.0))


# -- results --------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class WorstCaseResult(Result):
    """A supply level certified for every allowed pattern, bracketed.

    Attributes
    ----------
    spec : str
        ``'gain'``, ``'passivity'`` or ``'supply'``.
    figure : float
        The certified figure: for ``'gain'`` an upper bound ``γ`` on the
        ℓ2 gain over every pattern; for ``'passivity'`` a level ``η`` with
        ``Σ 2wᵀz ≥ 2η Σ wᵀw``; for ``'supply'`` a level ``t`` with
        ``Σ s(w, z) ≥ t Σ wᵀw`` (all from rest, every allowed pattern).
    bound : float
        The other side, from the worst periodic pattern found: a lower
        bound on the worst-case gain, an upper bound on every certifiable
        ``η`` or ``t`` (``0``/``inf`` when no pattern was examined).
    level, level_bound : float
        ``figure`` and ``bound`` as supply levels ``t``.
    exact : bool
        ``|figure − bound| ≤ tol·max(|figure|, |bound|)``.
    cycle : tuple of int
        The worst periodic pattern found: its modes, in order of
        application.
    cycle_edges : tuple of int
        The same pattern as edges of the graph.
    omega : float
        The frequency (of the pattern's lifted system) attaining ``bound``.
    memory : int
        The memory of the storages' lift.
    storages : ndarray, shape (V, n, n)
        ``P`` per lifted node, as checked.
    walks : tuple
        The lifted nodes (:attr:`GraphLift.walks`).
    rate : float
        The decay rate the storages prove for every pattern (exact); below
        1.
    rate_lower : float
        ``ρ(Φ)^(1/L)`` of the fastest periodic pattern examined.
    m11_max, P_min : ndarray
        ``λmax(M11)`` per lifted edge and ``λmin(P)`` per lifted node.
    level_solver : float
        The solver's level (never the certified one).
    patterns : int
        Periodic patterns examined.
    tol : float
    report : SolveReport

    Examples
    --------
    >>> sys = ncs.SwitchingSystem([[[1.5]], [[0.0]]], [[1.0]], [[1.0]],
    ...                           [[0.0]], [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> res = ncs.worst_case_gain(sys)
    >>> res.status, res.cycle, round(res.bound, 6), res.exact
    ('certified', (0, 1), 2.0, True)
    """

    spec: str
    figure: float
    bound: float
    level: float
    level_bound: float
    exact: bool
    cycle: tuple
    cycle_edges: tuple
    omega: float
    memory: int
    storages: np.ndarray
    walks: tuple
    rate: float
    rate_lower: float
    m11_max: np.ndarray
    P_min: np.ndarray
    level_solver: float
    patterns: int
    tol: float
    report: Any

    _repr_fields: ClassVar[tuple[str, ...]] = ("figure", "bound", "exact")

    @property
    def success(self) -> bool:
        """True when the figure certifies the spec.

        A ``'supply'`` level ``t > 0``; any gain; any passivity level,
        shortage included.
        """
        return self.status in (CERTIFIED, CERTIFIED_SHORTAGE)

    @property
    def status(self) -> str:
        """One word of :mod:`control_ncs.exceptions`' registry.

        ``'certified'``; ``'certified_shortage'`` for ``η < 0``; for a
        supply with ``t ≤ 0``: ``'infeasible'`` when a pattern proves the
        supply fails, else ``'sufficient_failed'``.
        """
        if self.spec == "passivity" and self.figure < 0:
            return CERTIFIED_SHORTAGE
        if self.spec == "supply" and not self.level > 0:
            return INFEASIBLE if self.level_bound < 0 else SUFFICIENT_FAILED
        return CERTIFIED

    @property
    def message(self) -> str:
        """The bracket in words."""
        lo, hi = sorted((self.figure, self.bound))
        what = {"gain": "the worst-case l2 gain",
                "passivity": "the worst-case passivity level eta",
                "supply": "the worst-case supply level t"}[self.spec]
        return (f"{what} lies in [{lo:.6g}, {hi:.6g}] (the "
                f"{'upper' if self.spec == 'gain' else 'lower'} end "
                f"certified for every allowed pattern; "
                f"{'exact' if self.exact else 'not closed'})")

    def _details(self) -> list[str]:
        return [f"certified {self.figure:.8g}, other side {self.bound:.8g} "
                f"from the periodic pattern {self.cycle} (of "
                f"{self.patterns} examined)",
                f"memory {self.memory}: {len(self.walks)} storages; max "
                f"λmax(M11) = {self.m11_max.max():.3e}, min λmin(P) = "
                f"{self.P_min.min():.3e}",
                f"decay rate proven {self.rate:.6g} (fastest periodic "
                f"pattern {self.rate_lower:.6g})"]


@dataclass(frozen=True, repr=False)
class WorstCaseRate(Result):
    """A decay rate for every allowed pattern, bracketed.

    Attributes
    ----------
    rate : float
        Certified: every allowed product of ``k`` steps has norm at most
        ``κ rateᵏ`` (node norms from ``storages``, checked exactly). An
        upper bound on the joint spectral radius.
    lower : float
        ``ρ(Φ)^(1/L)`` of the fastest periodic pattern examined: a lower
        bound on the joint spectral radius.
    exact : bool
        ``rate − lower ≤ tol·rate``.
    cycle, cycle_edges : tuple of int
        The fastest periodic pattern: modes and edges.
    memory : int
    storages : ndarray, shape (V, n, n)
    walks : tuple
    requested : float or None
        The rate asked for, or None (bisected).
    iterations : int
        LMIs solved.
    patterns : int
    tol : float

    Examples
    --------
    Losses ``a = 3``, deliveries ``b = 0.2``, at most one loss in a row:
    the worst pattern alternates, ``√(3·0.2)``.

    >>> sys = ncs.SwitchingSystem([[[3.0]], [[0.2]]], [[1.0]], [[1.0]],
    ...                           [[0.0]], [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> res = ncs.worst_case_rate(sys)
    >>> round(res.lower, 6), res.exact, res.status
    (0.774597, True, 'certified')
    """

    rate: float
    lower: float
    exact: bool
    cycle: tuple
    cycle_edges: tuple
    memory: int
    storages: np.ndarray
    walks: tuple
    requested: float | None
    iterations: int
    patterns: int
    tol: float

    _repr_fields: ClassVar[tuple[str, ...]] = ("rate", "lower", "exact")

    @property
    def success(self) -> bool:
        """True when the rate certified is below the goal.

        The goal is 1 (stable for every pattern), or the rate asked for.
        """
        return self.status == CERTIFIED

    @property
    def status(self) -> str:
        """One word of :mod:`control_ncs.exceptions`' registry.

        ``'certified'``, or ``'not_mss'`` when a periodic pattern grows
        (``lower ≥ 1``), else ``'sufficient_failed'``.
        """
        goal = 1.0 if self.requested is None else self.requested
        if self.rate < goal:
            return CERTIFIED
        return NOT_MSS if self.lower >= 1.0 else SUFFICIENT_FAILED

    @property
    def message(self) -> str:
        """The bracket in words."""
        return (f"the worst-case decay rate lies in [{self.lower:.6g}, "
                f"{self.rate:.6g}]: {MESSAGES[self.status]}")

    def _details(self) -> list[str]:
        return [f"rate {self.rate:.8g} proven by {len(self.walks)} storages "
                f"(memory {self.memory}, {self.iterations} LMIs)",
                f"fastest periodic pattern {self.cycle}: {self.lower:.8g} "
                f"(of {self.patterns} examined)"]


# -- the analysis -----------------------------------------------------------------
def _common_args(memory: Any, cycle_length: Any, tol: Any, solver: Any,
                 options: dict) -> tuple:
    if isinstance(memory, (bool, np.bool_)) or not isinstance(
            memory, (int, np.integer)) or memory < 0:
        raise ValueError(f"memory: expected an int >= 0, got {memory!r}")
    cycle_length = positive_int(cycle_length, "cycle_length")
    tol = positive_real(tol, "tol")
    check_options(check_solver(solver), options)
    return int(memory), cycle_length, tol, solver


def _unstable(sys: SwitchingSystem, bound: PatternBound, func: str) -> None:
    modes = tuple(int(sys.graph.edges[e, 2]) for e in bound.rate_walk)
    raise CertificationError(
        f"{func}: the periodic pattern {modes} (modes in order) is not stable "
        f"(rho(Phi)^(1/L) = {bound.rate:.6g} >= 1): no storage of any memory "
        f"certifies a level, and the loop is not stable for every allowed "
        f"pattern", NOT_MSS, dict(cycle=modes, rate=bound.rate))


def _lifted_system(sys: SwitchingSystem, lift: GraphLift) -> SwitchingSystem:
    return SwitchingSystem(sys.A, sys.B, sys.C, sys.D, lift.graph)


def _solve_storages(sys: SwitchingSystem, lift: GraphLift, weights: tuple,
                    margin: float, name: str | None, options: dict,
                    func: str) -> tuple:
    model = storage_model(sys.A, sys.B, sys.C, sys.D, lift.graph.edges,
                          lift.graph.nodes, weights[0], weights[1],
                          weights[2], margin)
    report = solve_once(model.problem, name, options)
    if report.infeasible:
        raise CertificationError(
            f"{func}: no storage on the memory-{lift.memory} lift (solver "
            f"status {report.status!r}); node storages are sufficient only: "
            f"more memory may find one", SUFFICIENT_FAILED,
            dict(status=report.status, memory=lift.memory))
    if report.status not in ("optimal", "optimal_inaccurate") or \
            model.level.value is None:
        raise CertificationError(
            f"{func}: the solver gave no storage (status {report.status!r})",
            SOLVER_FAILED, dict(status=report.status))
    return model.storages(), float(model.level.value), report


def _dissipativity(sys: SwitchingSystem, weights: tuple, spec: str,
                   memory: int, cycle_length: int, tol: float, name: str | None,
                   margin: float, options: dict,
                   func: str) -> WorstCaseResult:
    """Validated arguments in, a checked result out (see the callers)."""
    bound = pattern_bound(sys, weights[0], weights[1], weights[2],
                          cycle_length)
    if bound.rate >= 1.0:
        _unstable(sys, bound, func)
    lift = sys.graph.lift(memory)
    lifted = _lifted_system(sys, lift)
    for factor in RETRIES:
        P, level_solver, report = _solve_storages(
            sys, lift, weights, factor * margin, name, options, func)
        levels, m11_max, P_min = supply_levels(lifted, P, *weights)
        level = float(levels.min())
        rate = storage_rate(sys.A, lift.graph.edges, P)
        if np.isfinite(level) and np.all(P_min > 0) and rate < 1.0:
            break
    else:
        raise CertificationError(
            f"{func}: the storage found fails the exact check (max "
            f"λmax(M11) = {m11_max.max():.3e}, min λmin(P) = "
            f"{P_min.min():.3e})", NOT_VERIFIED,
            dict(m11_max=m11_max.tolist(), P_min=P_min.tolist(),
                 level_solver=level_solver))
    figure, other = _in_units(spec, level, bound.level)
    width = abs(figure - other)
    exact = bool(np.isfinite(other) and width <= tol * max(
        abs(figure), abs(other), 1e-300))
    walk = bound.walk
    modes = tuple(int(sys.graph.edges[e, 2]) for e in walk)
    return WorstCaseResult(
        spec, figure, other, level, bound.level, exact, modes,
        tuple(int(e) for e in walk), bound.omega, memory, P, lift.walks,
        rate, bound.rate, m11_max, P_min, level_solver, bound.count, tol,
        report)


def _in_units(spec: str, level: float, level_bound: float) -> tuple:
    if spec == "gain":
        return (math.sqrt(max(-level, 0.0)),
                math.sqrt(max(-level_bound, 0.0))
                if np.isfinite(level_bound) else 0.0)
    if spec == "passivity":
        return level / 2, level_bound / 2
    return level, level_bound


def _weights(sys: SwitchingSystem, Q: Any, S: Any, R: Any) -> tuple:
    nz, nw = sys.noutputs, sys.ninputs
    out = _supply_weights(Q, S, R, nz, nw)
    return tuple(np.asarray(X, float) * np.eye(*shape) if np.ndim(X) == 0
                 else np.asarray(X, float)
                 for X, shape in zip(out, ((nz, nz), (nz, nw), (nw, nw))))


def worst_case_dissipativity(sys: Any, Q: Any, S: Any, R: Any,
                             graph: Any = None, *, memory: int = 0,
                             cycle_length: int = CYCLE_LENGTH,
                             tol: float = TOL, solver: str | None = None,
                             margin: float = MARGIN,
                             **solver_options: Any) -> WorstCaseResult:
    """Certify a supply rate for every allowed switching pattern.

    For the supply ``s(w, z) = zᵀQz + 2zᵀSw + wᵀRw`` (``Q ⪯ 0``) the
    largest level ``t`` with ``Σ s(w_k, z_k) ≥ t Σ wₖᵀwₖ`` from rest, for
    every input and every walk of the graph from a start node
    (:ref:`theory-worst-case-dissipativity`). A storage ``P_u`` per node of
    the graph's memory-``M`` lift is found by an LMI (``t`` maximised),
    then checked exactly: ``M11 ≺ 0`` per edge and ``t`` from the Schur
    complement, computed without the solver. Every periodic pattern of at
    most ``cycle_length`` steps, lifted over its period, bounds ``t`` from
    the other side (its frequency response); the result says whether the
    two meet within ``tol``.

    Parameters
    ----------
    sys : SwitchingSystem, tuple (A, B, C, D) or sequence of StateSpace
        The loop's modes: per-mode arrays (a single matrix stands for every
        mode) or one discrete-time StateSpace per mode.
    Q, S, R : float or array_like
        The supply's weights, shapes (p, p), (p, m), (m, m); a number
        stands for that multiple of ``I``. ``Q ⪯ 0``.
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed patterns (default: arbitrary switching; not with a
        SwitchingSystem, which has its graph).
    memory : int, optional
        Storages on the memory-``M`` lift (nodes remember the last ``M``
        edges); more memory can only raise the certified level.
    cycle_length : int, optional
        Longest periodic pattern examined.
    tol : float, optional
        Relative width of a bracket called exact.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver.

    Returns
    -------
    WorstCaseResult
        ``spec = 'supply'``: ``figure`` the certified ``t``, ``bound`` the
        least ``t`` a periodic pattern allows.

    Raises
    ------
    CertificationError
        ``'not_mss'`` when a periodic pattern is not stable (then no storage
        exists); ``'sufficient_failed'`` when no storage exists at this
        memory; ``'solver_failed'``; ``'not_verified'`` when the storage
        fails the exact check.
    ValueError
        ``Q`` not negative semidefinite, ``memory`` not an int ≥ 0.
    ControlDimension
        Weights or matrices of the wrong shape.

    See Also
    --------
    worst_case_gain, worst_case_passivity, control_ncs.dissipativity

    Examples
    --------
    ``x⁺ = a x + w``, ``z = x + w``, ``a`` switching freely between 0.2 and
    0.5: the sector ``(z − 0.5w)(2w − z) ≥ 0`` (``Q = -1``, ``S = 1.25``,
    ``R = -1``) fails for some pattern, proven by the pattern itself.

    >>> sys = ncs.SwitchingSystem([[[0.2]], [[0.5]]], [[1.0]], [[1.0]],
    ...                           [[1.0]])
    >>> res = ncs.worst_case_dissipativity(sys, -1.0, 1.25, -1.0)
    >>> res.status, res.bound < 0
    ('infeasible', True)
    """
    memory, cycle_length, tol, name = _common_args(
        memory, cycle_length, tol, solver, solver_options)
    system = SwitchingSystem.coerce(sys, graph)
    weights = _weights(system, Q, S, R)
    margin = positive_real(margin, "margin")
    return _dissipativity(system, weights, "supply", memory, cycle_length,
                          tol, name, margin, solver_options,
                          "worst_case_dissipativity")


def worst_case_gain(sys: Any, graph: Any = None, *, memory: int = 0,
                    cycle_length: int = CYCLE_LENGTH, tol: float = TOL,
                    solver: str | None = None, margin: float = MARGIN,
                    **solver_options: Any) -> WorstCaseResult:
    """The ℓ2 gain over every allowed pattern, certified and bracketed.

    :func:`worst_case_dissipativity` with ``Q = -I, S = 0, R = 0``:
    ``γ = √(-t)`` bounds ``Σ zᵀz ≤ γ² Σ wᵀw`` from rest for every pattern
    (the bounded real lemma with a storage per lifted node). The lower end
    is the largest gain ``σmax(G(e^{jω}))`` of a periodic pattern lifted
    over its period, on a frequency grid refined by a local search.

    Parameters
    ----------
    sys : SwitchingSystem, tuple (A, B, C, D) or sequence of StateSpace
        The loop's modes.
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed patterns (default: arbitrary switching).
    memory : int, optional
        Storages on the memory-``M`` lift.
    cycle_length : int, optional
        Longest periodic pattern examined.
    tol : float, optional
        Relative width of a bracket called exact.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver.

    Returns
    -------
    WorstCaseResult
        ``figure`` the certified ``γ``, ``bound`` the worst pattern's gain.

    Raises
    ------
    CertificationError
        As :func:`worst_case_dissipativity`.

    Examples
    --------
    ``x⁺ = 1.5x + w + θu``, ``u = -1.5x``, ``z = x``, at most one command
    lost in a row: the pattern (lost, delivered) has gain 2, and storages
    per automaton node prove 2.

    >>> sys = ncs.SwitchingSystem([[[1.5]], [[0.0]]], [[1.0]], [[1.0]],
    ...                           [[0.0]], [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> res = ncs.worst_case_gain(sys)
    >>> res.figure <= 2 * (1 + 1e-7), res.cycle
    (True, (0, 1))
    """
    memory, cycle_length, tol, name = _common_args(
        memory, cycle_length, tol, solver, solver_options)
    system = SwitchingSystem.coerce(sys, graph)
    margin = positive_real(margin, "margin")
    p, m = system.noutputs, system.ninputs
    weights = (-np.eye(p), np.zeros((p, m)), np.zeros((m, m)))
    return _dissipativity(system, weights, "gain", memory, cycle_length,
                          tol, name, margin, solver_options,
                          "worst_case_gain")


def worst_case_passivity(sys: Any, graph: Any = None, *, memory: int = 0,
                         cycle_length: int = CYCLE_LENGTH, tol: float = TOL,
                         solver: str | None = None,
                         margin: float = MARGIN,
                         **solver_options: Any) -> WorstCaseResult:
    """The input-feedforward passivity level over every pattern.

    :func:`worst_case_dissipativity` with ``Q = 0, S = I, R = 0``:
    ``η = t/2`` with ``Σ 2wᵀz ≥ 2η Σ wᵀw`` from rest for every allowed
    pattern (python-control's ``get_input_ff_index`` for one mode). The
    upper end is ``min_ω λmin(G + Gᴴ)/2`` of a periodic pattern lifted over
    its period.

    Parameters
    ----------
    sys : SwitchingSystem, tuple (A, B, C, D) or sequence of StateSpace
        The loop's modes (as many inputs as outputs).
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed patterns (default: arbitrary switching).
    memory : int, optional
        Storages on the memory-``M`` lift.
    cycle_length : int, optional
        Longest periodic pattern examined.
    tol : float, optional
        Relative width of a bracket called exact.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver.

    Returns
    -------
    WorstCaseResult
        ``figure`` the certified ``η``, ``bound`` the least ``η`` a
        periodic pattern allows.

    Raises
    ------
    ControlDimension
        Inputs and outputs differ in number.
    CertificationError
        As :func:`worst_case_dissipativity`.

    Examples
    --------
    ``x⁺ = 0.5x + w``, ``z = x + d w`` with ``d`` switching between 1 and
    2: the worst pattern keeps ``d = 1``, ``η = 1 − 1/1.5``.

    >>> sys = ncs.SwitchingSystem(0.5, 1.0, 1.0, [[[1.0]], [[2.0]]])
    >>> res = ncs.worst_case_passivity(sys)
    >>> round(res.figure, 6), res.cycle, res.exact
    (0.333333, (0,), True)
    """
    memory, cycle_length, tol, name = _common_args(
        memory, cycle_length, tol, solver, solver_options)
    system = SwitchingSystem.coerce(sys, graph)
    margin = positive_real(margin, "margin")
    m = system.ninputs
    if system.noutputs != m:
        from control.exception import ControlDimension
        raise ControlDimension(f"sys: passivity needs as many outputs as "
                               f"inputs, got {system.noutputs} and {m}")
    weights = (np.zeros((m, m)), np.eye(m), np.zeros((m, m)))
    return _dissipativity(system, weights, "passivity", memory, cycle_length,
                          tol, name, margin, solver_options,
                          "worst_case_passivity")


# -- decay rate -------------------------------------------------------------------
def _bisect_rate(model, sys: SwitchingSystem, lift: GraphLift, lo: float,
                 tol: float, name: str | None, options: dict) -> tuple:
    """Smallest rate whose storages pass the exact check, by bisection
    between the periodic patterns' rate ``lo`` and what ``P = I`` proves."""
    edges = lift.graph.edges
    n = sys.nstates
    best_P = np.broadcast_to(np.eye(n), (lift.graph.nodes, n, n)).copy()
    best = storage_rate(sys.A, edges, best_P)
    hi, iterations = best, 0
    while hi - lo > tol * hi and iterations < 60:
        r = 0.5 * (lo + hi)
        iterations += 1
        model.rate2.value = r * r
        report = solve_once(model.problem, name, options)
        ok = report.status in ("optimal", "optimal_inaccurate") and all(
            X.value is not None for X in model.P)
        found = storage_rate(sys.A, edges, model.storages()) if ok \
            else math.inf
        if found < best:
            best, best_P = found, model.storages()
        if found <= r * (1 + tol):
            hi = min(hi, max(found, lo))
        else:
            lo = r
    return best, best_P, iterations


def worst_case_rate(sys: Any, graph: Any = None, *, rate: float | None = None,
                    memory: int = 0, cycle_length: int = CYCLE_LENGTH,
                    tol: float = TOL, solver: str | None = None,
                    **solver_options: Any) -> WorstCaseRate:
    """A decay rate for every allowed pattern, bracketed.

    Node storages ``P_u ≻ 0`` on the memory-``M`` lift with
    ``A_eᵀ P_v A_e ≼ r² P_u`` on every edge prove ``‖x_k‖ ≤ κ rᵏ ‖x_0‖``
    for every allowed pattern (:ref:`theory-worst-case-dissipativity`):
    an upper bound on the joint spectral radius. The rate returned is
    recomputed from the storages exactly
    (``max_e λmax(L_u⁻¹A_eᵀP_vA_eL_u⁻ᵀ)^½``); the lower end is the fastest
    periodic pattern of at most ``cycle_length`` steps.

    Parameters
    ----------
    sys : SwitchingSystem, tuple (A, B, C, D) or sequence of StateSpace
        The loop's modes (only ``A`` is read).
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed patterns (default: arbitrary switching).
    rate : float, optional
        Certify this rate (one LMI); default: the least rate, by bisection.
    memory : int, optional
        Storages on the memory-``M`` lift.
    cycle_length : int, optional
        Longest periodic pattern examined.
    tol : float, optional
        Relative width of the bisection and of a bracket called exact.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    **solver_options
        Passed to the solver.

    Returns
    -------
    WorstCaseRate

    Raises
    ------
    CertificationError
        With a given ``rate``: ``'infeasible'`` when a periodic pattern is
        slower than it (proven), ``'sufficient_failed'`` when no storage
        at this memory proves it.

    Examples
    --------
    The pair of Ahmadi, Jungers, Parrilo and Roozbehani switching freely:
    one quadratic storage proves 3.98; storages that remember the last two
    modes close the bracket on ``ρ(A1 A2)^½ = 3.917385``.

    >>> A = [[[-1.0, -1.0], [-4.0, 0.0]], [[3.0, 3.0], [-2.0, 1.0]]]
    >>> sys = (A, np.zeros((2, 1)), np.zeros((1, 2)), np.zeros((1, 1)))
    >>> r0 = ncs.worst_case_rate(sys)
    >>> r2 = ncs.worst_case_rate(sys, memory=2)
    >>> round(r0.rate, 2), round(r2.rate, 5), r2.exact, r2.cycle
    (3.98, 3.91739, True, (0, 1))
    """
    memory, cycle_length, tol, name = _common_args(
        memory, cycle_length, tol, solver, solver_options)
    system = SwitchingSystem.coerce(sys, graph)
    if rate is not None:
        rate = positive_real(rate, "rate")
    bound = pattern_bound(system, None, None, None, cycle_length,
                          supply=False)
    lift = system.graph.lift(memory)
    model = rate_model(system.A, lift.graph.edges, lift.graph.nodes)
    if rate is None:
        found, P, iterations = _bisect_rate(model, system, lift, bound.rate,
                                            tol, name, solver_options)
    else:
        if bound.rate >= rate:
            raise CertificationError(
                f"worst_case_rate: a periodic pattern decays at "
                f"{bound.rate:.6g} >= rate = {rate:.6g}: no certificate "
                f"exists", INFEASIBLE, dict(lower=bound.rate))
        model.rate2.value = rate * rate
        report = solve_once(model.problem, name, solver_options)
        ok = report.status in ("optimal", "optimal_inaccurate") and all(
            X.value is not None for X in model.P)
        P = model.storages() if ok else np.full(
            (lift.graph.nodes, system.nstates, system.nstates), np.nan)
        found = storage_rate(system.A, lift.graph.edges, P) if ok \
            else math.inf
        iterations = 1
        if not found < rate:
            raise CertificationError(
                f"worst_case_rate: no storage on the memory-{memory} lift "
                f"proves rate {rate:.6g} (solver status {report.status!r}, "
                f"rate checked {found:.6g}); more memory may",
                SUFFICIENT_FAILED, dict(status=report.status, found=found))
    walk = bound.rate_walk
    exact = bool(found - bound.rate <= tol * found)
    return WorstCaseRate(
        found, bound.rate, exact,
        tuple(int(system.graph.edges[e, 2]) for e in walk),
        tuple(int(e) for e in walk), memory, P, lift.walks, rate,
        iterations, bound.count, tol)

