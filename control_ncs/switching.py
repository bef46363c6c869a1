"""Constrained switching systems: which mode sequences a network allows.

A loss budget (at most ``m`` lost in any ``K``, at most ``k`` in a row, a
user's automaton) is a labelled directed graph: an edge ``(u, v, i)`` says
"from node ``u`` the network may go to node ``v`` with mode ``i``"
(:ref:`theory-worst-case-dissipativity`). The worst-case analysis and design
read three small frozen objects, all validated here once:

* :class:`SwitchingGraph` -- the nodes, edges and start nodes, and its
  memory-``M`` lift (nodes that remember the last ``M`` edges);
* :class:`SwitchingSystem` -- a fixed loop: ``(A_i, B_i, C_i, D_i)`` per
  mode on a graph;
* :class:`ConstrainedPlant` -- an open loop for full-information design:
  ``(A_i, Bu_i, Bw_i, Cz_i, Du_i, Dw_i)`` per mode on a graph; a gain per
  node closes it into a :class:`SwitchingSystem`.

Nothing here solves anything: the analysis is in
:mod:`control_ncs.worstcase`, the design in
:mod:`control_ncs.worstcase_synthesis`.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any, Sequence

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import positive_int, real_array

__all__ = ["SwitchingGraph", "SwitchingSystem", "ConstrainedPlant",
           "GraphLift"]


def _node_index(value: Any, name: str, nodes: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, np.integer)) or not 0 <= value < nodes:
        raise ControlArgument(f"{name}: expected a node in 0..{nodes - 1}, "
                              f"got {value!r}")
    return int(value)


@dataclass(frozen=True, eq=False)
class SwitchingGraph:
    """The mode sequences a network allows: a labelled directed graph.

    An edge ``(u, v, i)`` means "from node ``u`` to node ``v``, apply mode
    ``i``"; a pattern is a walk, its modes in order of application. A loss
    automaton with edges ``(state, next_state, delivered)`` is one, with
    mode 0 for a lost and 1 for a delivered message.

    Parameters
    ----------
    edges : sequence of (int, int, int)
        The edges ``(u, v, mode)``; at least one, each node with an edge
        out (the network never stops).
    nodes : int, optional
        Number of nodes (default: one more than the largest node in
        ``edges``).
    start : int or sequence of int, optional
        The nodes a pattern may start from, the loop at rest (default:
        every node).

    Attributes
    ----------
    edges : ndarray of int, shape (E, 3)
    nodes : int
    start : tuple of int
        The start nodes (every node when none was given).

    Raises
    ------
    ControlArgument
        An edge that is not three non-negative ints, a node out of range,
        or a node without an edge out.

    Examples
    --------
    At most one message lost in a row: node 0 after a delivery, node 1
    after a loss (mode 0 lost, 1 delivered).

    >>> G = ncs.SwitchingGraph([(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> G.nodes, G.modes, G.start
    (2, 2, (0, 1))
    >>> ncs.SwitchingGraph.arbitrary(3).edges.tolist()
    [[0, 0, 0], [0, 0, 1], [0, 0, 2]]
    """

    edges: np.ndarray
    nodes: int
    start: tuple[int, ...]

    def __init__(self, edges: Any, nodes: int | None = None,
                 start: Any = None) -> None:
        try:
            rows = [tuple(e) for e in edges]
        except TypeError:
            raise ControlArgument("edges: expected a sequence of (u, v, mode) "
                                  f"triples, got {edges!r}") from None
        if not rows:
            raise ControlArgument("edges: expected at least one edge")
        for row in rows:
            if len(row) != 3 or not all(
                    isinstance(x, (int, np.integer)) and not isinstance(
                        x, (bool, np.bool_)) and x >= 0 for x in row):
                raise ControlArgument(
                    f"edges: expected (u, v, mode) triples of non-negative "
                    f"ints, got {row!r}")
        E = np.array(rows, dtype=int).reshape(-1, 3)
        count = int(E[:, :2].max()) + 1
        if nodes is None:
            nodes = count
        nodes = positive_int(nodes, "nodes")
        if count > nodes:
            raise ControlArgument(f"edges: a node {count - 1} is out of range "
                                  f"for nodes={nodes}")
        dead = sorted(set(range(nodes)) - set(E[:, 0].tolist()))
        if dead:
            raise ControlArgument(
                f"edges: node(s) {dead} have no edge out; every node needs "
                f"one (the network never stops)")
        if start is None:
            first = tuple(range(nodes))
        else:
            seq = [start] if np.ndim(start) == 0 else list(start)
            if not seq:
                raise ControlArgument("start: expected at least one node")
            first = tuple(sorted({_node_index(s, "start", nodes)
                                  for s in seq}))
        E.setflags(write=False)
        object.__setattr__(self, "edges", E)
        object.__setattr__(self, "nodes", int(nodes))
        object.__setattr__(self, "start", first)

    @classmethod
    def arbitrary(cls, modes: int) -> "SwitchingGraph":
        """Arbitrary switching: one node, a loop per mode.

        Parameters
        ----------
        modes : int
            Number of modes.

        Returns
        -------
        SwitchingGraph

        Examples
        --------
        >>> ncs.SwitchingGraph.arbitrary(2).edges.tolist()
        [[0, 0, 0], [0, 0, 1]]
        """
        modes = positive_int(modes, "modes")
        return cls([(0, 0, i) for i in range(modes)])

    @property
    def modes(self) -> int:
        """One more than the largest mode on an edge."""
        return int(self.edges[:, 2].max()) + 1

    def out_edges(self) -> list[list[int]]:
        """The indices of the edges leaving each node.

        Returns
        -------
        list of list of int

        Examples
        --------
        >>> ncs.SwitchingGraph([(0, 0, 1), (0, 1, 0), (1, 0, 1)]).out_edges()
        [[0, 1], [2]]
        """
        out: list[list[int]] = [[] for _ in range(self.nodes)]
        for e, u in enumerate(self.edges[:, 0]):
            out[int(u)].append(e)
        return out

    def lift(self, memory: int = 0) -> "GraphLift":
        """The memory-``M`` lift: nodes that remember the last ``M`` edges.

        A lifted node is a node ``u`` of this graph with the last ``M``
        edges of the walk that reached it (fewer while a pattern is younger
        than ``M`` steps and no longer history leads to its start); a
        lifted edge appends one edge. Only nodes reachable from the start
        nodes are kept. Storages and gains on lifted nodes may depend on
        the recent pattern; the allowed patterns are the same
        (:ref:`theory-worst-case-dissipativity`).

        Parameters
        ----------
        memory : int, optional
            ``M ≥ 0``; 0 keeps the nodes (restricted to the reachable ones).

        Returns
        -------
        GraphLift

        Examples
        --------
        >>> G = ncs.SwitchingGraph([(0, 0, 1), (0, 1, 0), (1, 0, 1)])
        >>> lift = G.lift(1)
        >>> lift.walks          # after a delivery, after a loss, and again
        ((0, (0,)), (1, (1,)), (0, (2,)))
        >>> lift.graph.edges.tolist()
        [[0, 0, 1], [0, 1, 0], [1, 2, 1], [2, 0, 1], [2, 1, 0]]
        """
        if isinstance(memory, (bool, np.bool_)) or not isinstance(
                memory, (int, np.integer)) or memory < 0:
            raise ValueError(f"memory: expected an int >= 0, got {memory!r}")
        return _lift(self, int(memory))

    def __repr__(self) -> str:
        return (f"<SwitchingGraph: {self.nodes} nodes, {len(self.edges)} "
                f"edges, {self.modes} modes>")


@dataclass(frozen=True, eq=False)
class GraphLift:
    """A graph's memory-``M`` lift and how it maps back.

    Attributes
    ----------
    graph : SwitchingGraph
        The lifted graph: its modes are the original modes; its start nodes
        the lifted nodes where patterns start, the loop at rest.
    walks : tuple of (int, tuple of int)
        Per lifted node: the original node and the indices of the last
        (up to ``memory``) original edges.
    origin : ndarray of int
        Per lifted edge: the original edge it appends.
    memory : int

    Examples
    --------
    >>> lift = ncs.SwitchingGraph.arbitrary(2).lift(2)
    >>> len(lift.walks), lift.origin.tolist()[:4]
    (4, [0, 1, 0, 1])
    """

    graph: SwitchingGraph
    walks: tuple
    origin: np.ndarray
    memory: int


def _history(graph: SwitchingGraph, node: int, memory: int
             ) -> tuple[int, ...] | None:
    """The smallest (by edge indices) walk of ``memory`` edges ending at
    ``node``, or None if no walk that long ends there."""
    into: list[list[int]] = [[] for _ in range(graph.nodes)]
    for e, v in enumerate(graph.edges[:, 1]):
        into[int(v)].append(e)
    # depth-first backwards, smallest edge first: the first walk found
    stack: list[tuple[int, tuple[int, ...]]] = [(node, ())]
    seen: set = set()
    while stack:
        v, tail = stack.pop()
        if len(tail) == memory:
            return tail
        if (v, len(tail)) in seen:
            continue
        seen.add((v, len(tail)))
        for e in sorted(into[v], reverse=True):
            stack.append((int(graph.edges[e, 0]), (e,) + tail))
    return None


def _lift(graph: SwitchingGraph, memory: int) -> GraphLift:
    out = graph.out_edges()
    starts = []
    for s in graph.start:
        # at rest the history before the start is immaterial (x = 0, V = 0):
        # any walk of M edges into s stands for it; only a start with no
        # such history needs the shorter, transient nodes
        tail = _history(graph, s, memory) if memory else ()
        starts.append((s, () if tail is None else tail))
    index: dict = {}
    walks: list = []
    queue: deque = deque()
    for key in starts:
        if key not in index:
            index[key] = len(walks)
            walks.append(key)
            queue.append(key)
    edges, origin = [], []
    while queue:
        u, tail = key = queue.popleft()
        for e in out[u]:
            v = int(graph.edges[e, 1])
            nxt = (v, (tail + (e,))[-memory:] if memory else ())
            if nxt not in index:
                index[nxt] = len(walks)
                walks.append(nxt)
                queue.append(nxt)
            edges.append((index[key], index[nxt], int(graph.edges[e, 2])))
            origin.append(e)
    lifted = SwitchingGraph(edges, nodes=len(walks),
                            start=sorted({index[k] for k in starts}))
    org = np.array(origin, dtype=int)
    org.setflags(write=False)
    return GraphLift(lifted, tuple(walks), org, memory)


# -- the matrices per mode -----------------------------------------------------
def _per_mode(value: Any, name: str, modes: int | None,
              shape: tuple[int | None, int | None]) -> np.ndarray:
    """An array of one matrix per mode, shape (M, rows, cols); a single
    matrix stands for every mode."""
    arr = real_array(value, name, ndim=(0, 1, 2, 3))
    if arr.ndim == 0 and all(s in (None, 1) for s in shape):
        arr = arr.reshape(1, 1)
    if arr.ndim == 1 and shape[0] == 1 and shape[1] == arr.size:
        arr = arr.reshape(1, -1)
    if arr.ndim < 2:
        raise ControlDimension(f"{name}: expected a matrix or one matrix per "
                               f"mode, got shape {arr.shape}")
    if arr.ndim == 2:
        arr = np.broadcast_to(arr, (modes or 1,) + arr.shape)
    if modes is not None and arr.shape[0] != modes:
        raise ControlDimension(f"{name}: expected {modes} modes, got "
                               f"{arr.shape[0]}")
    for got, want, what in zip(arr.shape[1:], shape, ("rows", "columns")):
        if want is not None and got != want:
            raise ControlDimension(f"{name}: expected {want} {what} per mode, "
                                   f"got shape {arr.shape}")
    out = np.array(arr, dtype=float)
    out.setflags(write=False)
    return out


def _modes_of(mats: Sequence[Any]) -> int | None:
    counts = {np.shape(M)[0] for M in mats if np.ndim(M) == 3}
    if len(counts) > 1:
        raise ControlDimension(f"expected the same number of modes in every "
                               f"per-mode array, got {sorted(counts)}")
    return counts.pop() if counts else None


def _graph_for(graph: Any, modes: int) -> SwitchingGraph:
    if graph is None:
        return SwitchingGraph.arbitrary(modes)
    G = graph if isinstance(graph, SwitchingGraph) else SwitchingGraph(graph)
    if G.modes > modes:
        raise ControlDimension(f"graph: an edge applies mode {G.modes - 1}, "
                               f"but only {modes} modes are given")
    return G


def _statespace_modes(systems: Sequence[Any]
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                 np.ndarray]:
    for k, sys in enumerate(systems):
        if not isinstance(sys, ct.StateSpace) or not ct.isdtime(
                sys, strict=True):
            raise ControlArgument(
                f"sys[{k}]: expected a discrete-time StateSpace per mode, got "
                f"{type(sys).__name__}")
    A, B, C, D = (np.array([getattr(sys, X) for sys in systems])
                  for X in "ABCD")
    return A, B, C, D


@dataclass(frozen=True, eq=False)
class SwitchingSystem:
    """A fixed loop whose modes switch along a graph.

    ``x⁺ = A_i x + B_i w``, ``z = C_i x + D_i w`` with the mode ``i`` of
    each step an edge of ``graph``.

    Parameters
    ----------
    A, B, C, D : array_like
        One matrix per mode, shapes (M, n, n), (M, n, m), (M, p, n),
        (M, p, m); a single matrix stands for every mode.
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed mode sequences (default: arbitrary switching).

    Attributes
    ----------
    A, B, C, D : ndarray
        Shapes (M, n, n), (M, n, m), (M, p, n), (M, p, m).
    graph : SwitchingGraph

    Raises
    ------
    ControlDimension
        Shapes that do not fit, or a graph applying a mode not given.

    Examples
    --------
    ``x⁺ = 1.5x + w`` when the command is lost, ``x⁺ = w`` when it
    arrives, at most one loss in a row:

    >>> sys = ncs.SwitchingSystem([[[1.5]], [[0.0]]], [[1.0]], [[1.0]],
    ...                           [[0.0]], [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> sys.nstates, sys.ninputs, sys.noutputs, sys.graph.nodes
    (1, 1, 1, 2)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    graph: SwitchingGraph

    def __init__(self, A: Any, B: Any, C: Any, D: Any,
                 graph: Any = None) -> None:
        M = _modes_of([A, B, C, D])
        A = _per_mode(A, "A", M, (None, None))
        n = A.shape[-1]
        if A.shape[-2] != n:
            raise ControlDimension(f"A: expected square matrices, got shape "
                                   f"{A.shape}")
        M = A.shape[0]
        B = _per_mode(B, "B", M, (n, None))
        C = _per_mode(C, "C", M, (None, n))
        D = _per_mode(D, "D", M, (C.shape[1], B.shape[2]))
        for name, value in zip("ABCD", (A, B, C, D)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "graph", _graph_for(graph, M))

    @classmethod
    def coerce(cls, sys: Any, graph: Any = None) -> "SwitchingSystem":
        """``sys`` as a SwitchingSystem: itself, ``(A, B, C, D)`` or a
        sequence of discrete-time StateSpace, one per mode.

        Parameters
        ----------
        sys : SwitchingSystem, tuple of array_like or sequence of StateSpace
        graph : SwitchingGraph or sequence of (u, v, mode), optional
            Not with a SwitchingSystem (it has its graph).

        Returns
        -------
        SwitchingSystem

        Examples
        --------
        >>> import control as ct
        >>> modes = [ct.ss([[0.5]], [[1]], [[1]], [[0]], True),
        ...          ct.ss([[0.9]], [[1]], [[1]], [[0]], True)]
        >>> ncs.SwitchingSystem.coerce(modes).A.ravel().tolist()
        [0.5, 0.9]
        """
        if isinstance(sys, SwitchingSystem):
            if graph is not None:
                raise ControlArgument("graph: a SwitchingSystem carries its "
                                      "graph; give one or the other")
            return sys
        if isinstance(sys, (list, tuple)) and sys and all(
                isinstance(s, ct.LTI) for s in sys):
            A, B, C, D = _statespace_modes(sys)
            return cls(A, B, C, D, graph)
        if isinstance(sys, (list, tuple)) and len(sys) == 4:
            A, B, C, D = sys
            return cls(A, B, C, D, graph)
        raise ControlArgument(
            f"sys: expected a SwitchingSystem, a tuple (A, B, C, D) of "
            f"per-mode arrays or a sequence of StateSpace, got "
            f"{type(sys).__name__}")

    @property
    def nstates(self) -> int:
        """Number of states ``n``."""
        return self.A.shape[-1]

    @property
    def ninputs(self) -> int:
        """Number of disturbance inputs ``m``."""
        return self.B.shape[-1]

    @property
    def noutputs(self) -> int:
        """Number of performance outputs ``p``."""
        return self.C.shape[-2]

    def __repr__(self) -> str:
        return (f"<SwitchingSystem: {self.A.shape[0]} modes, {self.nstates} "
                f"states, {self.ninputs} inputs, {self.noutputs} outputs, "
                f"{self.graph.nodes} nodes, {len(self.graph.edges)} edges>")


@dataclass(frozen=True, eq=False)
class ConstrainedPlant:
    """An open loop whose modes switch along a graph (state feedback).

    ``x⁺ = A_i x + Bu_i u + Bw_i w``, ``z = Cz_i x + Du_i u + Dw_i w`` with
    the mode ``i`` of each step an edge of ``graph``. The controller reads
    the state and the node it is at (acknowledgements tell it which
    messages arrived); a lost command is ``Bu_i = 0``, ``Du_i = 0``.

    Parameters
    ----------
    A, Bu, Bw, Cz, Du, Dw : array_like
        One matrix per mode (a single matrix stands for every mode).
    graph : SwitchingGraph or sequence of (u, v, mode), optional
        The allowed mode sequences (default: arbitrary switching).

    Attributes
    ----------
    A, Bu, Bw, Cz, Du, Dw : ndarray
        Shapes (M, n, n), (M, n, q), (M, n, m), (M, p, n), (M, p, q),
        (M, p, m).
    graph : SwitchingGraph

    Raises
    ------
    ControlDimension
        Shapes that do not fit, or a graph applying a mode not given.

    Examples
    --------
    ``x⁺ = 1.5x + w + θu``, ``z = x``: mode 0 loses the command.

    >>> P = ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 0.0,
    ...                                [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
    >>> P.Bu.ravel().tolist()
    [0.0, 1.0]
    >>> P.close([[-1.5]]).A.ravel().tolist()      # one mode per edge
    [0.0, 1.5, 0.0]
    """

    A: np.ndarray
    Bu: np.ndarray
    Bw: np.ndarray
    Cz: np.ndarray
    Du: np.ndarray
    Dw: np.ndarray
    graph: SwitchingGraph

    def __init__(self, A: Any, Bu: Any, Bw: Any, Cz: Any, Du: Any, Dw: Any,
                 graph: Any = None) -> None:
        M = _modes_of([A, Bu, Bw, Cz, Du, Dw])
        A = _per_mode(A, "A", M, (None, None))
        n, M = A.shape[-1], A.shape[0]
        if A.shape[-2] != n:
            raise ControlDimension(f"A: expected square matrices, got shape "
                                   f"{A.shape}")
        Bu = _per_mode(Bu, "Bu", M, (n, None))
        Bw = _per_mode(Bw, "Bw", M, (n, None))
        Cz = _per_mode(Cz, "Cz", M, (None, n))
        Du = _per_mode(Du, "Du", M, (Cz.shape[1], Bu.shape[2]))
        Dw = _per_mode(Dw, "Dw", M, (Cz.shape[1], Bw.shape[2]))
        for name, value in zip(("A", "Bu", "Bw", "Cz", "Du", "Dw"),
                               (A, Bu, Bw, Cz, Du, Dw)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "graph", _graph_for(graph, M))

    @classmethod
    def lossy(cls, A: Any, Bu: Any, Bw: Any, Cz: Any, Du: Any, Dw: Any,
              graph: Any) -> "ConstrainedPlant":
        """One plant over a lossy actuator link: mode 0 lost, 1 delivered.

        The matrices are the plant's (one each); a lost command applies
        zero (``Bu = 0``, ``Du = 0`` in mode 0).

        Parameters
        ----------
        A, Bu, Bw, Cz, Du, Dw : array_like
            The plant's matrices.
        graph : SwitchingGraph or sequence of (u, v, delivered)
            A loss automaton.

        Returns
        -------
        ConstrainedPlant

        Examples
        --------
        >>> P = ncs.ConstrainedPlant.lossy(1.2, 1.0, 1.0, 1.0, 0.0, 0.0,
        ...                                [(0, 0, 0), (0, 0, 1)])
        >>> P.Bu.shape
        (2, 1, 1)
        """
        A = _per_mode(A, "A", 1, (None, None))[0]
        n = A.shape[0]
        Bu = _per_mode(Bu, "Bu", 1, (n, None))[0]
        Cz = _per_mode(Cz, "Cz", 1, (None, n))[0]
        Du = _per_mode(Du, "Du", 1, (Cz.shape[0], Bu.shape[1]))[0]
        return cls(np.stack([A, A]), np.stack([0 * Bu, Bu]), Bw, Cz,
                   np.stack([0 * Du, Du]), Dw, graph)

    @property
    def nstates(self) -> int:
        """Number of states ``n``."""
        return self.A.shape[-1]

    @property
    def ncontrols(self) -> int:
        """Number of control inputs ``q``."""
        return self.Bu.shape[-1]

    def close(self, K: Any, lift: GraphLift | None = None) -> SwitchingSystem:
        """The fixed loop under ``u = K x`` (one gain, or one per node).

        Parameters
        ----------
        K : array_like
            Shape (q, n): one gain; or (V, q, n): a gain per node of
            ``lift.graph`` (of this graph without ``lift``), applied on the
            edges leaving it.
        lift : GraphLift, optional
            A lift of this plant's graph (:meth:`SwitchingGraph.lift`).

        Returns
        -------
        SwitchingSystem
            On the (lifted) graph, one mode per edge.

        Examples
        --------
        >>> P = ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 0.0,
        ...                                [(0, 0, 1), (0, 1, 0), (1, 0, 1)])
        >>> loop = P.close([[[-1.0]], [[-1.5]]])
        >>> loop.A.ravel().tolist()
        [0.5, 1.5, 0.0]
        """
        if lift is not None and lift.graph.nodes and (
                len(lift.origin) and lift.origin.max() >= len(
                    self.graph.edges)):
            raise ControlArgument("lift: not a lift of this plant's graph")
        graph = self.graph if lift is None else lift.graph
        origin = (np.arange(len(graph.edges)) if lift is None
                  else lift.origin)
        V, q, n = graph.nodes, self.ncontrols, self.nstates
        gains = real_array(K, "K", ndim=(2, 3))
        if gains.ndim == 2:
            gains = np.broadcast_to(gains, (V,) + gains.shape)
        if gains.shape != (V, q, n):
            raise ControlDimension(f"K: expected shape ({q}, {n}) or ({V}, "
                                   f"{q}, {n}), got {gains.shape}")
        u = graph.edges[:, 0]
        i = self.graph.edges[origin, 2]
        Kt = gains[u]
        A = self.A[i] + self.Bu[i] @ Kt
        C = self.Cz[i] + self.Du[i] @ Kt
        E = len(graph.edges)
        edges = [(int(a), int(b), e) for e, (a, b) in
                 enumerate(graph.edges[:, :2])]
        return SwitchingSystem(A, self.Bw[i], C, self.Dw[i],
                               SwitchingGraph(edges, nodes=graph.nodes,
                                              start=graph.start)
                               if E else graph)

    def __repr__(self) -> str:
        return (f"<ConstrainedPlant: {self.A.shape[0]} modes, {self.nstates} "
                f"states, {self.ncontrols} controls, {self.graph.nodes} "
                f"nodes, {len(self.graph.edges)} edges>")
