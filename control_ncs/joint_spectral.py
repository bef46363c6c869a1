"""The joint spectral radius: growth under every allowed switching.

(:ref:`theory-worst-case`.) :func:`jsr` brackets
``ρ̂ = lim max_{|w| = k} ‖A_w‖^{1/k}`` over the walks of a graph
(arbitrary switching when there is none): ``lower`` is the rate of one
closed walk, ``cycle``; ``upper`` is proved by a certificate checked
exactly -- an invariant polytope (exact when the cycle is a dominant
spectrum-maximising product), path-dependent quadratic Lyapunov functions
on memory lifts, or norms of products (Gripenberg's branch and bound).
The searches live in ``_jsr_cycles``, ``_jsr_polytope`` and
``_jsr_quadratic``; this module validates, plans and reports.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from control.exception import ControlArgument

from ._checks import positive_real
from ._jsr_cycles import (KARP_MAX_NODES, Cycles, karp_cycle, product_bound,
                          search_cycles)
from ._jsr_polytope import invariant_polytope
from ._jsr_quadratic import node_coordinates, quadratic_bound
from ._results import Result
from ._switching import SwitchingGraph, switching_graph

__all__ = ["jsr", "JSRResult", "JSRCertificate"]

#: Expert settings of :func:`jsr` (``options=``) and their defaults.
OPTIONS = dict(
    max_length=30,        # longest closed walk searched for the lower bound
    search_budget=200_000,  # walks visited by the cycle searches, in all
    max_vertices=500,     # vertices of one invariant polytope, in all
    max_memory=2,         # path memory of the quadratic Lyapunov lifts
    product_depth=30,     # longest products of Gripenberg's upper bound
    solver=None,          # cvxpy solver of the SDPs (Clarabel by default)
)

#: Invariant polytopes grown at most, each from a new best cycle.
POLYTOPE_TRIES = 4

#: Lifts and products larger than this many matrix entries are not built.
MAX_ENTRIES = 1_000_000
#: The same for the first, Euclidean, products: a cheap look before the
#: better norms are known.
FIRST_ENTRIES = 250_000


@dataclass(frozen=True, eq=False)
class JSRCertificate:
    """What proves an upper bound on the joint spectral radius.

    Attributes
    ----------
    kind : str
        ``'polytope'`` (real invariant polytope), ``'complex_polytope'``
        (balanced complex polytope), ``'quadratic'`` (a quadratic form per
        node of the memory-``memory`` lift), ``'product_norms'`` (norms of
        products of ``length`` steps, in the node norms of ``P``, Euclidean
        when ``P`` is None) or ``'no_cycle'`` (the graph has no cycle:
        ``ρ̂ = 0``).
    bound : float
        The bound it proves, recomputed from the data below.
    nodes : tuple
        The nodes of the graph the certificate lives on (for
        ``memory > 0``: the walks of ``memory`` edges, each a tuple of the
        user's ``(node, next_node, mode)``).
    vertices : tuple of ndarray or None
        Polytopes: the vertices of each node's polytope, shape ``(k, n)``
        (complex for ``'complex_polytope'``); the unit ball of node ``u``
        is the (complex) absolutely convex hull of its rows, and every
        edge ``(u, v, σ)`` maps it into ``bound / rate`` times that of
        ``v``.
    rate : float or None
        Polytopes: the cycle's rate that the matrices were divided by.
    P : ndarray or None
        Quadratic forms and product norms: ``P_u`` per node, shape
        ``(V, n, n)``, with ``A_σᵀ P_v A_σ ≼ bound² P_u`` on every edge
        (quadratic) or ``‖·‖_u = ‖L_uᵀ ·‖`` (``P_u = L_u L_uᵀ``).
    memory : int
        Path memory of the lift the certificate lives on.
    length : int
        ``'product_norms'``: the longest products examined.
        ``'quadratic'``: the steps per edge (``T > 1``: the forms live on
        the ``T``-step graph, whose edges are the walks of ``T`` edges with
        their products, and ``bound`` is the ``T``-th root of what they
        prove there).

    Examples
    --------
    >>> res = ncs.jsr([[[1, 1], [0, 1]], [[1, 0], [1, 1]]])
    >>> res.certificate.kind, round(res.certificate.bound, 9)
    ('product_norms', 1.618033989)
    """

    kind: str
    bound: float
    nodes: tuple
    vertices: tuple | None = None
    rate: float | None = None
    P: np.ndarray | None = None
    memory: int = 0
    length: int = 1

    def describe(self) -> str:
        """One phrase: the kind of certificate and its size.

        Returns
        -------
        str

        Examples
        --------
        >>> res = ncs.jsr([[[0, 1], [0, 0]], [[0, 0], [1, 0]]])
        >>> res.certificate.describe()
        'the Euclidean norm of single steps'
        """
        if self.kind in ("polytope", "complex_polytope"):
            count = sum(len(V) for V in self.vertices or ())
            what = "balanced complex" if self.kind == "complex_polytope" \
                else "invariant"
            return (f"an {what} polytope ({count} vertices on "
                    f"{len(self.nodes)} node(s))")
        if self.kind == "quadratic":
            steps = f", {self.length}-step graph" if self.length > 1 else ""
            return (f"a quadratic Lyapunov function per node of the "
                    f"memory-{self.memory} lift{steps} ({len(self.nodes)} "
                    f"nodes)")
        if self.kind == "product_norms":
            norm = "the Euclidean norm" if self.P is None else (
                f"quadratic node norms (memory {self.memory})")
            steps = "single steps" if self.length == 1 else \
                f"products of up to {self.length} steps"
            return f"{norm} of {steps}"
        return "a graph without cycles"


@dataclass(frozen=True, repr=False, eq=False)
class JSRResult(Result):
    """A certified bracket on the joint spectral radius.

    Attributes
    ----------
    lower : float
        ``ρ(A_c)^{1/|c|}`` of the closed walk ``cycle``: ``ρ̂ ≥ lower``.
    upper : float
        Proved by ``certificate`` (and, on a graph with several strongly
        connected components, by ``certificates``): ``ρ̂ ≤ upper``.
    cycle : tuple
        The modes of the closed walk attaining ``lower``, in order of
        application (``A_c = A_{cycle[-1]} ⋯ A_{cycle[0]}``); empty when no
        cycle has a positive spectral radius. For a loop over loss budgets
        a mode reads ``(phase, (q, θ))``: the phase of the period, the
        automaton's state ``q`` the step leads to (for :func:`weakly_hard`
        the last outcomes, oldest first, ``'1'`` delivered, ``'0'`` lost)
        and the step's outcome ``θ`` (1 delivered, 0 lost or not sent).
    walk : tuple of (node, next_node, mode)
        The same closed walk as edges of the graph.
    certificate : JSRCertificate
        What proves ``upper`` (the component attaining it).
    certificates : tuple of JSRCertificate
        One per strongly connected component with a cycle.
    route : str
        Which route produced ``upper``: ``'polytope'``,
        ``'complex_polytope'``, ``'quadratic'``, ``'product_norms'`` or
        ``'no_cycle'``.
    exact : bool
        ``upper - lower <= tol * upper``.
    tol : float
    scale : str
        What the radius measures: ``'matrices'`` -- the growth rate per
        step of ``‖x‖`` under ``x⁺ = A_σ x`` for the matrices given;
        ``'mean_square'`` -- of ``E‖x‖²`` (the squared scale of
        :func:`ms_radius`), when ``sys`` supplies second-moment operators.
    time_limited : bool
        True when ``time_limit`` cut a search before the bracket closed.
    stages : tuple of str
        What was tried, in order, with its figure and time.

    Examples
    --------
    >>> res = ncs.jsr([[[0, 1], [0, 0]], [[0, 0], [1, 0]]])
    >>> res.lower, res.upper, res.cycle, res.exact
    (1.0, 1.0, (0, 1), True)
    """

    lower: float
    upper: float
    cycle: tuple
    walk: tuple
    certificate: JSRCertificate
    certificates: tuple
    route: str
    exact: bool
    tol: float
    scale: str
    time_limited: bool = False
    stages: tuple = field(default=())

    _repr_fields: ClassVar[tuple[str, ...]] = ("lower", "upper", "route")

    @property
    def success(self) -> bool:
        """True when the bracket closed to ``tol`` (``exact``)."""
        return self.exact

    @property
    def status(self) -> str:
        """``'exact'``, ``'bracket'`` or ``'time_limit'``."""
        if self.exact:
            return "exact"
        return "time_limit" if self.time_limited else "bracket"

    @property
    def message(self) -> str:
        """One sentence: the bracket and what it rests on."""
        if self.exact:
            return (f"exact to tol = {self.tol:g}: {self.upper:.10g}, "
                    f"attained by a cycle of length {len(self.cycle)} and "
                    f"proved by {self.certificate.describe()}")
        cut = "; the time limit cut the search" if self.time_limited else ""
        return (f"bracket [{self.lower:.10g}, {self.upper:.10g}]: lower "
                f"from a cycle of length {len(self.cycle)}, upper proved by "
                f"{self.certificate.describe()}{cut}")

    @property
    def stable(self) -> bool | None:
        """Stable for every allowed switching (True), not (False), or open.

        ``upper < 1`` proves that every allowed product decays; ``lower
        >= 1`` that some allowed periodic switching does not.
        """
        if self.upper < 1.0:
            return True
        if self.lower >= 1.0:
            return False
        return None

    def _details(self) -> list[str]:
        width = self.upper - self.lower
        rel = width / self.upper if self.upper > 0 else 0.0
        lines = [f"lower {self.lower:.12g}  upper {self.upper:.12g}  "
                 f"(width {width:.3g}, relative {rel:.3g})",
                 f"cycle (order of application): {list(self.cycle)}",
                 f"upper by route {self.route!r}: "
                 f"{self.certificate.describe()}",
                 f"scale: {self.scale}"]
        return lines + [f"  {s}" for s in self.stages]


# -- the plan, per strongly connected component -----------------------------------
@dataclass
class _Best:
    """The running bracket of one component; ``floor`` is the best lower
    bound of the components bracketed before (the graph's radius is at
    least that, so this one need not be known more closely)."""

    graph: SwitchingGraph
    tol: float
    deadline: float
    options: dict
    floor: float = 0.0
    cycles: Cycles = field(default_factory=Cycles)
    upper: float = math.inf
    certificate: JSRCertificate | None = None
    stages: list = field(default_factory=list)
    time_limited: bool = False
    started: float = field(default_factory=time.perf_counter)

    @property
    def level(self) -> float:
        """The radius is at least this (this component's or an earlier)."""
        return max(self.cycles.rate, self.floor)

    @property
    def exact(self) -> bool:
        return math.isfinite(self.upper) and \
            self.upper - self.level <= self.tol * self.upper

    def late(self) -> bool:
        if time.perf_counter() > self.deadline:
            self.time_limited = True
        return self.time_limited

    def note(self, text: str) -> None:
        self.stages.append(f"{text} [{time.perf_counter() - self.started:.3g}"
                           f" s]")

    def offer(self, cert: JSRCertificate) -> None:
        if cert.bound < self.upper:
            self.upper, self.certificate = cert.bound, cert


def _search(best: _Best, mats: np.ndarray | None, budget: int,
            max_length: int) -> None:
    """Iterative deepening of the cycle search up to ``max_length``."""
    g, cyc = best.graph, best.cycles
    if budget <= 0:
        return
    length = min(8, max_length)
    used = 0
    while not best.late():
        before = cyc.visited
        search_cycles(g, length, mats=mats, found=cyc, budget=budget - used,
                      deadline=best.deadline)
        used += cyc.visited - before
        if not cyc.complete or length >= max_length or used >= budget:
            break
        length = min(length + 4, max_length)
    if best.late() and not cyc.complete:
        best.time_limited = True
    best.note(f"cycles up to length {length}"
              f"{'' if cyc.complete else ' (cut)'}: lower {cyc.rate:.12g}")


def _polytope(best: _Best, walk: tuple, rate: float) -> None:
    g = best.graph
    poly = invariant_polytope(g, walk, rate, tol=best.tol / 4,
                              max_vertices=best.options["max_vertices"],
                              deadline=best.deadline)
    if poly.reason == "time limit":
        best.time_limited = True
    kind = "complex_polytope" if poly.is_complex else "polytope"
    if poly.success:
        best.offer(JSRCertificate(kind, poly.bound, g.nodes,
                                  tuple(np.array(V) for V in poly.vertices),
                                  rate))
        best.note(f"{kind} from a cycle of length {len(walk)}: upper "
                  f"{poly.bound:.12g}")
    else:
        best.note(f"{kind} from a cycle of length {len(walk)}: stopped "
                  f"({poly.reason})")
    if poly.better is not None and poly.better[0] > best.cycles.rate:
        # the polytope met a faster cycle: the next candidate
        best.cycles.rate, best.cycles.walk = poly.better
        best.note(f"a cycle of length {len(poly.better[1])} met on the way: "
                  f"lower {poly.better[0]:.12g}")


def _quadratic(best: _Best, memory: int, steps: int = 1
               ) -> np.ndarray | None:
    """Quadratic forms on the memory lift (or its ``steps``-step graph),
    then Gripenberg's bound in their norms; the edge matrices in those
    norms' coordinates."""
    g = best.graph
    size = max(g.walk_count(memory), g.walk_count(memory + steps))
    if size * g.n ** 2 > MAX_ENTRIES // 8:
        best.note(f"memory-{memory}, {steps}-step graph: too large, skipped")
        return None
    lift = g.lift(memory).steps(steps)
    mats = lift.edge_matrices()
    quad = quadratic_bound(mats, lift.source, lift.target, lift.node_count,
                           best.level ** steps, rel=max(best.tol, 1e-7),
                           deadline=best.deadline,
                           solver=best.options["solver"])
    best.late()
    bound = quad.bound ** (1.0 / steps)
    best.offer(JSRCertificate("quadratic", bound, lift.nodes, P=quad.P,
                              memory=memory, length=steps))
    best.note(f"quadratic, memory {memory}"
              f"{f', {steps} steps' if steps > 1 else ''} ({quad.solves} "
              f"SDPs): upper {bound:.12g}")
    if best.exact or quad.P is None or steps > 1:
        return None
    coords = node_coordinates(mats, lift.source, lift.target, quad.P)
    _products(best, coords, lift, quad.P, memory)
    return coords if memory == 0 else None


def _products(best: _Best, coords: np.ndarray, lift: SwitchingGraph,
              P: np.ndarray | None, memory: int,
              entries: int = MAX_ENTRIES) -> None:
    beta = best.level * (1.0 + best.tol / 2)
    bound, depth = product_bound(coords, lift.source, lift.target,
                                 lift.node_count, beta,
                                 best.options["product_depth"],
                                 max_entries=entries,
                                 deadline=best.deadline)
    best.late()
    best.offer(JSRCertificate("product_norms", bound, lift.nodes, P=P,
                              memory=memory, length=depth))
    best.note(f"products of up to {depth} steps: upper {bound:.12g}")


def _component(g: SwitchingGraph, tol: float, deadline: float,
               options: dict, floor: float) -> _Best:
    """Bracket one strongly connected component: cheap routes first."""
    best = _Best(g, tol, deadline, options, floor)
    budget, max_length = options["search_budget"], options["max_length"]
    if g.n == 1 and g.node_count <= KARP_MAX_NODES:
        # scalars: the best cycle is the maximum cycle mean, exactly
        rate, walk = karp_cycle(g)
        best.cycles.rate, best.cycles.walk = rate, walk
        best.cycles.complete = False
        best.note(f"maximum cycle mean (Karp): lower {rate:.12g}")
    else:
        _search(best, None, budget // 10, min(16, max_length))
    _products(best, g.edge_matrices(), g, None, 0, FIRST_ENTRIES)
    tried: set = set()

    def polytope() -> None:
        cyc = best.cycles
        while not best.exact and cyc.rate > 0 and cyc.walk not in tried \
                and len(tried) < POLYTOPE_TRIES and not best.late():
            tried.add(cyc.walk)
            _polytope(best, cyc.walk, cyc.rate)

    polytope()
    if best.exact or best.late():
        return best
    coords = _quadratic(best, 0)
    if best.exact or best.late():
        return best
    # deeper cycles, pruned in the quadratic node norms
    _search(best, coords, budget - best.cycles.visited, max_length)
    polytope()
    for memory in range(1, options["max_memory"] + 1):
        if best.exact or best.late():
            break
        _quadratic(best, memory)
    if not (best.exact or best.late()):
        _quadratic(best, 0, steps=2)
    return best


# -- the public function ---------------------------------------------------------
def _options(options: dict | None) -> dict:
    if options is None:
        return dict(OPTIONS)
    if not isinstance(options, dict):
        raise ControlArgument(f"options: expected a dict, got "
                              f"{type(options).__name__}")
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise TypeError(f"jsr() got unknown option(s) {unknown}; known: "
                        f"{sorted(OPTIONS)}")
    out = dict(OPTIONS, **options)
    for key in OPTIONS:
        if key == "solver":
            continue
        value = out[key]
        if isinstance(value, (bool, np.bool_)) or not isinstance(
                value, (int, np.integer)) or value < (0 if key ==
                                                     "max_memory" else 1):
            raise ValueError(f"options[{key!r}]: expected an int >= "
                             f"{0 if key == 'max_memory' else 1}, got "
                             f"{value!r}")
    return out


def jsr(sys: Any, graph: Any = None, *, tol: float = 1e-6,
        time_limit: float | None = None,
        options: dict | None = None) -> JSRResult:
    """The joint spectral radius: a certified bracket, exact if it can.

    ``ρ̂ = lim_k max ‖A_w‖^{1/k}`` over the products ``A_w`` of ``k``
    modes allowed by ``graph`` (:ref:`theory-worst-case`): every allowed
    switching decays when ``ρ̂ < 1``. The result brackets it:
    ``lower`` is the rate ``ρ(A_c)^{1/|c|}`` of a closed walk ``cycle``
    (found by a pruned search over cycles), ``upper`` is proved by a
    certificate re-checked exactly -- an invariant polytope grown from the
    best cycle (exact to ``tol`` when that cycle is a dominant
    spectrum-maximising product), path-dependent quadratic Lyapunov
    functions of growing memory, or norms of products. ``upper`` is never
    a solver's figure: the bound is recomputed from the certificate.

    Parameters
    ----------
    sys : sequence or mapping of array_like, or object
        The modes: square matrices of one size, as a sequence (mode ``i``
        is ``sys[i]``), a 3-D array, or a mapping (mode names are its
        keys). Or any object with a method ``switching_system()``
        returning ``(matrices, edges)`` or ``(matrices, edges, scale)``,
        with ``matrices`` and ``edges`` as ``sys`` and ``graph`` here and
        ``scale`` ``'matrices'`` or ``'mean_square'`` (then ``graph`` must
        be None).
    graph : sequence of (node, next_node, mode) or LossAutomaton, optional
        Constrained switching: from ``node`` to ``next_node`` apply the
        matrix of ``mode``; nodes are any hashable names. A
        :class:`LossAutomaton` is its own graph, its outcomes naming the
        modes (``[A_lost, A_delivered]`` for one link). Default: arbitrary
        switching among all modes.
    tol : float, optional
        Relative width at which the bracket counts as exact.
    time_limit : float, optional
        Seconds for everything (searches, SDPs, polytopes); when it cuts
        the search, the bracket found so far is returned and says so.
    options : dict, optional
        Expert settings: ``max_length`` (30, longest cycle searched),
        ``search_budget`` (200000 walks), ``max_vertices`` (500 per
        polytope), ``max_memory`` (2, path memory of the quadratic
        lifts), ``product_depth`` (30), ``solver`` (cvxpy solver name).

    Returns
    -------
    JSRResult
        ``lower``, ``upper``, ``cycle``, ``certificate``, ``exact``,
        ``route``, ``scale``, ``summary()``.

    Raises
    ------
    ControlDimension
        A matrix is not square, or the sizes differ.
    ValueError
        Non-finite entries; a graph edge naming a mode ``sys`` does not
        have; a bad ``tol``, ``time_limit`` or option value.
    ControlArgument
        ``sys`` or ``graph`` of the wrong kind.
    TypeError
        An unknown option.

    See Also
    --------
    weakly_hard, max_consecutive_losses, loss_automaton

    Notes
    -----
    A graph's radius is the largest of its strongly connected components'
    (parts of the graph on no cycle are passed at most once); each is
    bracketed on its own and ``certificates`` holds one per component.

    References
    ----------
    .. [1] G. Gripenberg, "Computing the joint spectral radius", *Linear
           Algebra Appl.* 234, 1996.
    .. [2] N. Guglielmi and V. Protasov, "Exact computation of joint
           spectral characteristics of linear operators", *Found. Comput.
           Math.* 13, 2013.
    .. [3] A. A. Ahmadi, R. Jungers, P. Parrilo and M. Roozbehani, "Joint
           spectral radius and path-complete graph Lyapunov functions",
           *SIAM J. Control Optim.* 52, 2014.
    .. [4] M. Philippe, R. Essick, G. Dullerud and R. Jungers, "Stability
           of discrete-time switching systems with constrained switching
           sequences", *Automatica* 72, 2016.

    Examples
    --------
    The golden-ratio pair: the cycle ``A1 A2`` has rate ``φ``, and so has
    the Euclidean norm of each matrix.

    >>> res = ncs.jsr([[[1, 1], [0, 1]], [[1, 0], [1, 1]]])
    >>> round(res.lower, 10), res.exact, res.cycle
    (1.6180339887, True, (0, 1))

    A scalar loop that loses ``a = 3`` and delivers ``b = 0.2``, at most
    one loss in any four transmissions:

    >>> res = ncs.jsr([[[3.0]], [[0.2]]], ncs.weakly_hard(1, 4))
    >>> round(res.upper, 5), res.exact, sorted(res.cycle)
    (0.3936, True, [0, 1, 1, 1])
    """
    start = time.perf_counter()
    tol = positive_real(tol, "tol")
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    opts = _options(options)
    g = switching_graph(sys, graph)
    deadline = start + time_limit if time_limit is not None else math.inf
    parts = g.components()
    if not parts:
        cert = JSRCertificate("no_cycle", 0.0, g.nodes)
        return JSRResult(0.0, 0.0, (), (), cert, (cert,), "no_cycle", True,
                         tol, g.scale, False, ("no cycle in the graph",))
    results: list[_Best] = []
    for part in parts:
        floor = max((b.cycles.rate for b in results), default=0.0)
        results.append(_component(part, tol, deadline, opts, floor))
    low = max(results, key=lambda b: b.cycles.rate)
    high = max(results, key=lambda b: b.upper)
    stages = tuple(f"component {k}: {s}" if len(results) > 1 else s
                   for k, b in enumerate(results) for s in b.stages)
    lower, upper = low.cycles.rate, high.upper
    certs = tuple(b.certificate for b in results)
    assert high.certificate is not None   # every component has one
    return JSRResult(
        lower, upper,
        tuple(low.graph.modes[low.graph.mode[e]] for e in low.cycles.walk),
        tuple(low.graph.label(e) for e in low.cycles.walk),
        high.certificate, certs, high.certificate.kind,
        upper - lower <= tol * upper, tol, g.scale,
        any(b.time_limited for b in results) and
        not upper - lower <= tol * upper, stages)
