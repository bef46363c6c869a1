"""A constrained switching system: matrices on the edges of a graph.

(:ref:`theory-worst-case`.) The one format of the worst-case analyses:
``M`` square matrices (the modes) and a directed graph whose edge
``(u, v, σ)`` means "from node ``u`` to node ``v``, apply ``A_σ``";
arbitrary switching is one node with a loop per mode. A walk
``e_1 … e_k`` gives ``A_w = A_{σ_k} ⋯ A_{σ_1}`` (first applied on the
right). This module owns coercing what users give (sequences or mappings
of matrices; edge lists or :class:`~control_ncs.LossAutomaton`) into a
:class:`SwitchingGraph`, its strongly connected components, and the lifts
that keep the joint spectral radius (memory-``M`` De Bruijn lifts and
``T``-step graphs). Nothing here computes a radius.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import real_array
from .automata import LossAutomaton

__all__: list[str] = []

#: Largest number of nodes or edges a lift may have: lifts are refused
#: (before they are built) above it.
MAX_LIFT = 20_000

#: What ``scale`` says when the matrices are the ones given.
SCALE_MATRICES = "matrices"
#: What ``scale`` says when the matrices are second-moment operators.
SCALE_MEAN_SQUARE = "mean_square"


@dataclass(frozen=True, eq=False)
class SwitchingGraph:
    """Matrices on the edges of a directed graph.

    Attributes
    ----------
    matrices : ndarray, shape (M, n, n)
        One matrix per mode (read-only).
    modes : tuple
        The user's name of each mode (an index or a mapping's key).
    nodes : tuple
        The user's name of each node.
    source, target, mode : ndarray of int, shape (E,)
        Edge ``e`` goes from ``nodes[source[e]]`` to ``nodes[target[e]]``
        applying ``matrices[mode[e]]``.
    scale : str
        What a radius of these matrices means (``'matrices'``: the growth
        rate of ``‖x‖`` per step; ``'mean_square'``: of ``E‖x‖²``).
    """

    matrices: np.ndarray
    modes: tuple
    nodes: tuple
    source: np.ndarray
    target: np.ndarray
    mode: np.ndarray
    scale: str = SCALE_MATRICES

    @property
    def n(self) -> int:
        """The state dimension."""
        return int(self.matrices.shape[-1])

    @property
    def node_count(self) -> int:
        """Number of nodes."""
        return len(self.nodes)

    @property
    def edge_count(self) -> int:
        """Number of edges."""
        return int(self.source.size)

    def edge_matrices(self) -> np.ndarray:
        """The matrix of every edge, shape (E, n, n)."""
        return self.matrices[self.mode]

    def out_edges(self) -> list[np.ndarray]:
        """The edges leaving each node (indices, ascending)."""
        order = np.argsort(self.source, kind="stable")
        cuts = np.searchsorted(self.source[order],
                               np.arange(self.node_count + 1))
        return [order[cuts[u]:cuts[u + 1]] for u in range(self.node_count)]

    def label(self, edge: int) -> tuple:
        """Edge ``edge`` as the user names it: ``(u, v, mode)``."""
        return (self.nodes[self.source[edge]], self.nodes[self.target[edge]],
                self.modes[self.mode[edge]])

    def components(self) -> list["SwitchingGraph"]:
        """The strongly connected components that contain a cycle.

        Returns
        -------
        list of SwitchingGraph
            Each with the nodes and the edges inside one component (the
            same matrices and modes). The joint spectral radius of the
            graph is the largest of theirs; a graph without a cycle has
            none (its radius is 0).
        """
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        V = self.node_count
        adj = coo_matrix((np.ones(self.edge_count), (self.source,
                                                     self.target)),
                         shape=(V, V))
        count, labels = connected_components(adj, directed=True,
                                             connection="strong")
        out = []
        for c in range(count):
            inside = np.flatnonzero(labels == c)
            keep = np.flatnonzero((labels[self.source] == c)
                                  & (labels[self.target] == c))
            if keep.size == 0:
                continue        # a single node without a loop: no cycle
            out.append(self.subgraph(inside, keep))
        return out

    def subgraph(self, nodes: np.ndarray, edges: np.ndarray
                 ) -> "SwitchingGraph":
        """The graph on ``nodes`` (indices) with ``edges`` (indices)."""
        where = np.full(self.node_count, -1)
        where[nodes] = np.arange(nodes.size)
        return SwitchingGraph(self.matrices, self.modes,
                              tuple(self.nodes[i] for i in nodes),
                              where[self.source[edges]],
                              where[self.target[edges]],
                              self.mode[edges].copy(), self.scale)

    def walk_count(self, length: int) -> int:
        """Number of walks with ``length`` edges (exact integer)."""
        if length == 0:
            return self.node_count
        ends = [1] * self.node_count     # walks ending at each node
        for _ in range(length):
            nxt = [0] * self.node_count
            for s, t in zip(self.source.tolist(), self.target.tolist()):
                nxt[t] += ends[s]
            ends = nxt
        return sum(ends)

    def lift(self, memory: int) -> "SwitchingGraph":
        """The memory-``M`` (De Bruijn) lift: the same radius.

        Nodes are the walks of ``memory`` edges (tuples of edge indices);
        an edge appends one edge of this graph and forgets the oldest.
        ``memory = 0`` is this graph.

        Raises
        ------
        ValueError
            If the lift would have more than ``MAX_LIFT`` nodes or edges.
        """
        if memory == 0:
            return self
        nodes_n, edges_n = self.walk_count(memory), self.walk_count(
            memory + 1)
        if max(nodes_n, edges_n) > MAX_LIFT:
            raise ValueError(
                f"memory: the memory-{memory} lift would have {nodes_n} nodes "
                f"and {edges_n} edges, more than MAX_LIFT = {MAX_LIFT}")
        out = self.out_edges()
        walks: list[tuple[int, ...]] = [(e,) for e in range(self.edge_count)]
        for _ in range(memory - 1):
            walks = [w + (int(e),) for w in walks
                     for e in out[self.target[w[-1]]]]
        index = {w: i for i, w in enumerate(walks)}
        src, dst, mode = [], [], []
        for i, w in enumerate(walks):
            for e in out[self.target[w[-1]]]:
                src.append(i)
                dst.append(index[w[1:] + (int(e),)])
                mode.append(self.mode[e])
        names = tuple(tuple(self.label(e) for e in w) for w in walks)
        return SwitchingGraph(self.matrices, self.modes, names,
                              np.array(src, int), np.array(dst, int),
                              np.array(mode, int), self.scale)

    def steps(self, T: int) -> "SwitchingGraph":
        """The ``T``-step graph: one edge per walk of length ``T``.

        Its modes are the walks (tuples of this graph's mode names), its
        matrices their products; its radius is this graph's to the power
        ``T``.

        Raises
        ------
        ValueError
            If it would have more than ``MAX_LIFT`` edges.
        """
        if T == 1:
            return self
        count = self.walk_count(T)
        if count > MAX_LIFT:
            raise ValueError(f"steps: the {T}-step graph would have {count} "
                             f"edges, more than MAX_LIFT = {MAX_LIFT}")
        out = self.out_edges()
        walks: list[tuple[int, ...]] = [(e,) for e in range(self.edge_count)]
        for _ in range(T - 1):
            walks = [w + (int(e),) for w in walks
                     for e in out[self.target[w[-1]]]]
        mats = np.empty((len(walks), self.n, self.n))
        for k, w in enumerate(walks):
            P = self.matrices[self.mode[w[0]]]
            for step in w[1:]:
                P = self.matrices[self.mode[step]] @ P
            mats[k] = P
        mats.flags.writeable = False
        return SwitchingGraph(
            mats, tuple(tuple(self.modes[self.mode[e]] for e in w)
                        for w in walks),
            self.nodes, np.array([self.source[w[0]] for w in walks], int),
            np.array([self.target[w[-1]] for w in walks], int),
            np.arange(len(walks)), self.scale)

    def distances_to(self, node: int) -> np.ndarray:
        """Fewest edges from every node to ``node`` (a large number when
        ``node`` cannot be reached)."""
        into: list[list[int]] = [[] for _ in range(self.node_count)]
        for s, t in zip(self.source.tolist(), self.target.tolist()):
            into[t].append(s)
        far = np.iinfo(np.int64).max // 4
        dist = np.full(self.node_count, far, dtype=np.int64)
        dist[node] = 0
        todo = deque([node])
        while todo:
            v = todo.popleft()
            for u in into[v]:
                if dist[u] == far:
                    dist[u] = dist[v] + 1
                    todo.append(u)
        return dist


# -- coercion at the boundary ----------------------------------------------------
def _matrices(sys: Any) -> tuple[np.ndarray, tuple]:
    """The modes as an (M, n, n) array and their names."""
    if isinstance(sys, Mapping):
        keys = tuple(sys)
        values = [sys[k] for k in keys]
        what = [f"sys[{k!r}]" for k in keys]
    elif isinstance(sys, np.ndarray) and sys.ndim == 3:
        keys = tuple(range(sys.shape[0]))
        values = list(sys)
        what = [f"sys[{k}]" for k in keys]
    elif isinstance(sys, (list, tuple)):
        keys = tuple(range(len(sys)))
        values = list(sys)
        what = [f"sys[{k}]" for k in keys]
    else:
        raise ControlArgument(
            f"sys: expected a sequence or a mapping of square matrices, or "
            f"an object with a switching_system() method, got "
            f"{type(sys).__name__}")
    if not values:
        raise ValueError("sys: expected at least one matrix")
    mats: list[np.ndarray] = []
    for value, name in zip(values, what):
        arr = real_array(value, name, ndim=(0, 2))
        arr = arr.reshape(1, 1) if arr.ndim == 0 else arr
        if arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
            raise ControlDimension(f"{name}: expected a square matrix, got "
                                   f"shape {arr.shape}")
        if mats and arr.shape != mats[0].shape:
            raise ControlDimension(
                f"{name}: shape {arr.shape} differs from {what[0]}'s "
                f"{mats[0].shape}; every mode acts on the same state")
        mats.append(arr)
    out = np.array(mats)
    out.flags.writeable = False
    return out, keys


def _mode_index(keys: tuple) -> dict:
    index = {}
    for i, k in enumerate(keys):
        try:
            index[k] = i
        except TypeError:
            raise ControlArgument(f"sys: mode name {k!r} is not hashable"
                                  ) from None
    return index


def _edges(graph: Any, keys: tuple) -> tuple[tuple, list]:
    """Node names and edges ``(u, v, mode index)`` from ``graph``."""
    index = _mode_index(keys)
    if isinstance(graph, LossAutomaton):
        nodes = graph.states
        where = {s: i for i, s in enumerate(nodes)}
        triples = graph.edges
        out = []
        for u, v, label in triples:
            if label not in index:
                raise ValueError(
                    f"graph: the automaton's outcome {label!r} names no mode "
                    f"of sys (modes: {list(keys)}); give one matrix per "
                    f"outcome, e.g. [A_lost, A_delivered]")
            out.append((where[u], where[v], index[label]))
        return tuple(nodes), out
    if isinstance(graph, (str, bytes, Mapping)) or not hasattr(
            graph, "__iter__"):
        raise ControlArgument(
            f"graph: expected a sequence of (node, next_node, mode) edges or "
            f"a LossAutomaton, got {type(graph).__name__}")
    names: dict = {}
    out = []
    for k, edge in enumerate(graph):
        try:
            u, v, mode = edge
        except (TypeError, ValueError):
            raise ControlArgument(f"graph[{k}]: expected (node, next_node, "
                                  f"mode), got {edge!r}") from None
        mode = mode.item() if isinstance(mode, np.generic) else mode
        try:
            known = mode in index and not isinstance(mode, (bool, np.bool_))
        except TypeError:
            known = False
        if not known:
            raise ValueError(f"graph[{k}]: mode {mode!r} is not one of sys's "
                             f"modes {list(keys)[:8]}")
        ends = []
        for node in (u, v):
            node = node.item() if isinstance(node, np.generic) else node
            try:
                ends.append(names.setdefault(node, len(names)))
            except TypeError:
                raise ControlArgument(f"graph[{k}]: node {node!r} is not "
                                      f"hashable") from None
        out.append((ends[0], ends[1], index[mode]))
    if not out:
        raise ValueError("graph: expected at least one edge")
    # a repeated edge allows no new walk
    return tuple(names), list(dict.fromkeys(out))


def switching_graph(sys: Any, graph: Any = None) -> SwitchingGraph:
    """Coerce ``(sys, graph)`` into a :class:`SwitchingGraph`, once.

    ``sys`` is a sequence (or 3-D array) or mapping of square matrices,
    or an object with a method ``switching_system()`` returning
    ``(matrices, edges)`` or ``(matrices, edges, scale)``. ``graph`` is
    None (arbitrary switching), a sequence of ``(node, next_node, mode)``
    or a :class:`~control_ncs.LossAutomaton` (its outcomes name the
    modes).
    """
    scale = SCALE_MATRICES
    hook = getattr(sys, "switching_system", None)
    if callable(hook):
        if graph is not None:
            raise ControlArgument("graph: sys carries its own graph "
                                  "(switching_system()); do not give graph")
        given = hook()
        if not isinstance(given, tuple) or len(given) not in (2, 3):
            raise ControlArgument(
                "sys.switching_system(): expected (matrices, edges) or "
                "(matrices, edges, scale)")
        sys, graph = given[0], given[1]
        if len(given) == 3:
            scale = str(given[2])
    mats, keys = _matrices(sys)
    if graph is None:
        nodes: tuple = (0,)
        edges = [(0, 0, i) for i in range(len(keys))]
    else:
        nodes, edges = _edges(graph, keys)
    arr = np.array(edges, dtype=int).reshape(-1, 3)
    return SwitchingGraph(mats, keys, nodes, arr[:, 0].copy(),
                          arr[:, 1].copy(), arr[:, 2].copy(), scale)
