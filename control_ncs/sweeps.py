"""Design maps and schedule search: many verified syntheses at once.

A designer's questions are maps, not points: for which loss probabilities
does a passive design exist, and with what ``η`` and decay
(:func:`design_map`)? Which communication schedule of period ``N`` gives the
best loop (:func:`schedule_search`)? Both run :func:`control_ncs.passivesyn`
once per cell or schedule, exactly as a user would (same checks, same
verification), and never re-derive a verdict.

Every sweep accepts ``executor=``: any :class:`concurrent.futures.Executor`
(a thread or process pool, or a Dask cluster through
``client.get_executor()``). One task is submitted per cell or schedule,
results are placed by index, so a parallel run returns exactly what the
sequential one does. Workers receive only picklable data (the plant and the
options) and run a module-level function.
"""

from __future__ import annotations

import importlib
import math
import time
import warnings
from concurrent.futures import Executor
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from .exceptions import (ScheduleWarning)
from .plant import NetworkedStateSpace
from ._checks import (choice, decay_bound, finite_real, flag,
                      positive_int)
from ._map_grid import loss, map_cells
from .budgets import budget_cell, budget_plant
from .strategies import build
from ._sweep_cells import design_cells, perform, sweep_options
from ._tasks import check_executor, progress_check, run_tasks
from ._schedules import (PRUNE_REASONS, _alphabet, _big, _canonical_schedules,
                         _letter_maps, _loop_closes, _orbit_count, _prune,
                         _relabellings)
from .synthesis.passive import METHODS

__all__ = ["design_map", "DesignMap", "schedule_search", "ScheduleSearch",
           "RankedSchedule"]

#: Most canonical schedules a search enumerates even with ``limit=None``:
#: beyond it the enumeration alone would run for hours.
MAX_SCHEDULES = 10**7


# the controllers whose exact pruning tests are written here (not the whole
# strategies registry: a new controller needs its own pruning first)
_CONTROLLERS = ("static", "predictor")
_ACTUATORS = ("zero", "hold")
_OBJECTIVES = ("eta", "rate", "h2", "hinf")
# what a design map optimises in each cell: passivesyn's certified η, or the
# H2 norm / ℓ2-gain bound of h2syn / hinfsyn (their exact programs, or their
# local searches for structured gains)
_MAP_OBJECTIVES = {"eta": "certified η (passivesyn)",
                   "h2": "exact H2 norm (h2syn)",
                   "hinf": "certified ℓ2-gain bound (hinfsyn)"}


# -- boundary checks ----------------------------------------------------------

def _plant(P: Any, passivity: bool = True) -> NetworkedStateSpace:
    """``P``, checked for what synthesis needs (as passivesyn does), so that
    a sweep fails before its first task, not in a worker; ``passivity``:
    also ``dim w = dim z``."""
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    n = P.nstates
    if P.C2.shape != (n, n) or not np.array_equal(P.C2, np.eye(n)):
        raise ControlArgument(
            f"P: synthesis needs the state measured, y = x (C2 = I, {n}x{n}), "
            f"got C2 of shape {P.C2.shape}")
    if np.any(P.D21 != 0):
        raise ControlArgument(
            "P: sweeps design for measurements without noise (D21 = 0); "
            "with D21 ≠ 0 the gain also acts on w, which the programs do "
            "not cover yet")
    m1, p1 = P.B1.shape[1], P.C1.shape[0]
    if passivity and (m1 != p1 or m1 == 0):
        raise ControlDimension(
            f"P: passivity needs w and z of equal, nonzero size (m1 = p1), "
            f"got {m1} disturbance inputs and {p1} performance outputs")
    return P


# -- design maps ----------------------------------------------------------------

@dataclass
class DesignMap:
    """Certified designs over a grid of network parameters.

    Cell ``[i, j]`` is :func:`control_ncs.passivesyn` (or, by
    ``objective``, :func:`control_ncs.h2syn` or :func:`control_ncs.hinfsyn`)
    for the plant with ``axes[0]`` at ``values[0][i]`` and ``axes[1]`` at
    ``values[1][j]``. The axes are stored by name and values (not as fixed
    attributes), so that other axis kinds, such as the burst length of
    Markov losses, can be added without changing this class.

    Attributes
    ----------
    axes : tuple of str
        Names of the two axes, e.g. ``('sensor_loss', 'actuator_loss')``.
    values : tuple of ndarray
        Grid values along each axis.
    eta : ndarray, shape (len(values[0]), len(values[1]))
        Certified dissipation ``η`` (NaN where no gain is certified, and
        everywhere in an H2 or H∞ map).
    ms_radius : ndarray, same shape
        Exact per-step mean-square rate of the certified closed loop (NaN
        where none).
    feasible : ndarray of bool, same shape
        True where passivesyn returned a verified gain.
    reason : ndarray of object, same shape
        ``'certified'``, or the :class:`SynthesisError` ``reason``.
    eta_requested, decay : float or None
        The synthesis options (``eta=None``: η maximised).
    controller, actuator : str
    elapsed : float
        Wall-clock time of the sweep in seconds.
    objective : {'eta', 'h2', 'hinf'}
        What each cell optimised.
    value : ndarray, same shape
        The certified figure of each cell: ``eta`` for ``'eta'``, the
        designed loop's exact H2 norm for ``'h2'``, its certified ℓ2-gain
        bound for ``'hinf'`` (NaN where none).
    worst_case : bool
        True for a map over a loss budget's (misses, window): each figure
        is certified for every allowed pattern
        (:func:`control_ncs.worst_case_route`), and ``ms_radius`` holds
        the squared certified decay rate of every pattern.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> dm = ncs.design_map(P, [0.0, 0.5], [0.0], decay=0.95, progress=False)
    >>> dm.feasible.tolist()
    [[True], [True]]
    """

    axes: tuple
    values: tuple
    eta: np.ndarray
    ms_radius: np.ndarray
    feasible: np.ndarray
    reason: np.ndarray
    eta_requested: float | None = None
    decay: float | None = None
    controller: str = "static"
    actuator: str = "zero"
    elapsed: float = 0.0
    objective: str = "eta"
    value: np.ndarray | None = None
    worst_case: bool = False

    def __post_init__(self) -> None:
        if self.value is None:
            self.value = self.eta

    @property
    def shape(self) -> tuple:
        """The map's shape: (points of the first axis, of the second)."""
        return self.eta.shape

    def __repr__(self) -> str:
        what = "" if self.objective == "eta" else f", objective={self.objective!r}"
        return (f"<DesignMap {self.axes[0]} × {self.axes[1]}: "
                f"{self.shape[0]}×{self.shape[1]} cells, "
                f"{int(self.feasible.sum())} certified, "
                f"controller={self.controller!r}{what}>")

    def summary(self) -> str:
        """A few lines for humans: the grid, the counts, the best cell."""
        what = _MAP_OBJECTIVES[self.objective]
        if self.worst_case:
            what = {"eta": "certified worst-case η",
                    "hinf": "certified worst-case ℓ2 gain"}[
                        self.objective] + \
                " for every allowed pattern (worst_case_route)"
        lines = [repr(self),
                 f"  {self.axes[0]}: {np.round(self.values[0], 6).tolist()}",
                 f"  {self.axes[1]}: {np.round(self.values[1], 6).tolist()}",
                 (f"  eta={'max' if self.eta_requested is None else self.eta_requested}"
                  f", decay={self.decay}, elapsed {self.elapsed:.3g} s"
                  if self.objective == "eta" and not self.worst_case else
                  f"  {what}, elapsed {self.elapsed:.3g} s")]
        reasons, counts = np.unique(self.reason.astype(str), return_counts=True)
        lines.append("  verdicts: " + ", ".join(
            f"{r} {c}" for r, c in zip(reasons, counts)))
        if self.feasible.any():
            value = np.asarray(self.value)
            best = np.nanargmax(value) if self.objective == "eta" \
                else np.nanargmin(value)
            i, j = np.unravel_index(best, self.shape)
            rate = (f"worst-case rate {np.sqrt(self.ms_radius[i, j]):.6g}"
                    if self.worst_case else
                    f"ms_radius {self.ms_radius[i, j]:.6g}")
            lines.append(f"  best {self.objective} = {value[i, j]:.6g} at "
                         f"{self.axes[0]} = {self.values[0][i]:g}, "
                         f"{self.axes[1]} = {self.values[1][j]:g} "
                         f"({rate})")
        return "\n".join(lines)

    def to_pandas(self) -> Any:
        """One row per cell: the axes, eta, ms_radius, feasible, reason.

        An H2 or H∞ map has its figure as one more column (``'h2'`` or
        ``'hinf'``).

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        pd = _pandas()
        I, J = (g.ravel() for g in np.meshgrid(
            np.arange(self.shape[0]), np.arange(self.shape[1]), indexing="ij"))
        columns = {
            self.axes[0]: self.values[0][I], self.axes[1]: self.values[1][J],
            "eta": self.eta[I, J], "ms_radius": self.ms_radius[I, J],
            "feasible": self.feasible[I, J], "reason": self.reason[I, J]}
        if self.objective != "eta":
            columns[self.objective] = np.asarray(self.value)[I, J]
        return pd.DataFrame(columns)

    def plot(self, quantity: str | None = None, *, ax: Any = None,
             title: str | None = None) -> ct.ControlPlot:
        """Heat map of the map's figure: :func:`design_map_plot`.

        Parameters
        ----------
        quantity : {'eta', 'h2', 'hinf', 'ms_radius'}, optional
            Default: the map's objective.
        ax : matplotlib.axes.Axes, optional
        title : str, optional

        Returns
        -------
        control.ControlPlot
        """
        from .plots import design_map_plot
        return design_map_plot(self, quantity, ax=ax, title=title)


def _pandas() -> Any:
    try:
        return importlib.import_module("pandas")
    except ImportError:
        raise ImportError("to_pandas() needs pandas: pip install pandas") \
            from None


def design_map(P: NetworkedStateSpace, sensor_loss: Any = (0.0,),
               actuator_loss: Any = (0.0,), *, eta: float | None = None,
               decay: float | None = None, controller: str = "static",
               actuator: str = "zero", executor: Executor | None = None,
               progress: bool | None = None, method: str = "auto",
               objective: str = "eta", sensor_burst: Any = None,
               actuator_burst: Any = None,
               sensor_delay: Any = None, sensor_budget: Any = None,
               actuator_budget: Any = None,
               options: Mapping[str, Any] | None = None) -> DesignMap:
    """Verified synthesis over a grid of loss probabilities.

    Cell ``[i, j]`` is ``passivesyn(P.with_network(sensor_loss=a1[i],
    actuator_loss=a2[j]), eta, decay=..., controller=..., actuator=...)``:
    the same synthesis and exact verification as a single call; a cell
    without a certified gain records the :class:`SynthesisError` reason.
    With ``objective='h2'`` or ``'hinf'`` the cell is
    :func:`control_ncs.h2syn` or :func:`control_ncs.hinfsyn` instead, and
    its figure the designed loop's exact H2 norm or certified ℓ2-gain
    bound: what each loss probability costs.

    Over a bursty (Gilbert–Elliott) link a grid value is the link's
    stationary loss at the link's own mean burst length: the cells keep
    the bursts (``gilbert_elliott(loss=a, burst=link.burst)``; a loss of 0
    is a link that never fails). With ``actuator_burst`` (or
    ``sensor_burst``), a grid of mean burst lengths, the map's axes are
    that link's stationary loss and its mean burst length instead: cell
    ``[i, j]`` is the link ``gilbert_elliott(loss=a[i], burst=b[j])``, the
    other link at its one given loss. A burst of ``1/(1 - a)`` steps is the
    Bernoulli link of loss ``a``. With ``sensor_delay``, a list of delay
    laws (pmfs or :func:`control_ncs.random_delay` links), the axes are the
    sensor link's loss and its delay law, valued by its mean delay (of a
    delivered packet): cell ``[i, j]`` is law ``j`` scaled to the loss
    ``a[i]`` (its shape and buffer kept). With ``actuator_budget`` (or
    ``sensor_budget``), ``(misses, window)`` grids, the axes are a loss
    budget's: cell ``[i, j]`` gives the link ``weakly_hard(misses[i],
    window[j])`` (every pattern when ``misses >= window``) and is designed
    for every allowed pattern by :func:`control_ncs.worst_case_route`
    (:ref:`theory-worst-case`).

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its schedules; its own loss probabilities are replaced.
    sensor_loss, actuator_loss : sequence of float in [0, 1)
        Grids of ``α1`` and ``α2`` (a scalar is a grid of one point).
    eta : float, optional
        Dissipation to achieve in every cell; None maximises it.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r`` (``ms_radius < r²``).
    controller : {'static', 'predictor'}
    actuator : {'zero', 'hold'}
    executor : concurrent.futures.Executor, optional
        Runs one task per cell (thread or process pool, or a Dask
        ``client.get_executor()``); None runs sequentially in this thread.
        The result is identical either way.
    progress : bool or None
        Show a progress bar (needs tqdm). Default None: only where a person
        watches (an interactive terminal or a notebook), never in scripts'
        logs or CI.
    method : {'auto', 'lmi', 'refine'}
        How each cell is designed. ``'auto'`` (default): every cell by the
        LMI (exact with full information, fast), then every cell where the
        LMI is only sufficient refined, warm-started from its own LMI gain
        or its nearest certified neighbour's (the LMI is not solved twice);
        the better certified level is kept, and a cell is "infeasible"
        only with a proof. ``'lmi'``: the LMI only (structured cells may
        end ``'sufficient_failed'``). ``'refine'``:
        :func:`control_ncs.passivesyn` with ``method='refine'`` for every
        cell, each from its own LMI start (slowest).
    objective : {'eta', 'h2', 'hinf'}
        What each cell designs for: passivity with the largest certified
        ``η`` (default), the least H2 norm, or the least ℓ2 gain, each cell
        by :func:`control_ncs.h2syn` / :func:`control_ncs.hinfsyn` with
        ``controller`` and ``actuator`` (their exact programs for static
        state feedback with a zero actuator, their local searches for
        structured gains: schedules, predictor, hold, delayed links); these
        take none of ``eta``, ``decay`` or ``method``.
    sensor_burst, actuator_burst : sequence of float >= 1, optional
        A grid of mean burst lengths (steps) of one link: the map's second
        axis (the other link's loss grid must then have one value).
    sensor_delay : sequence of array_like or RandomDelay, optional
        A grid of delay laws of the sensor link: the map's second axis (the
        actuator's loss grid must then have one value). Designs over
        delayed links are local searches on exact figures.
    sensor_budget, actuator_budget : (sequence of int, sequence of int), optional
        Grids of losses allowed and of window lengths of one link's
        weakly-hard budget: the map's two axes (the other link must be
        perfect, the budget link's own loss grid left out). Each cell is
        :func:`control_ncs.worst_case_route` on the cell's
        ``build(P)``: ``objective='eta'`` maximises the worst-case
        passivity level (at least ``eta`` when given), ``'hinf'`` minimises
        the worst-case ℓ2 gain; ``decay`` bounds the decay rate of every
        pattern (``jsr < decay``); ``ms_radius`` holds the squared
        certified rate (the same scale). Static state feedback with a zero
        actuator only; ``'h2'`` is refused (an average over patterns has
        no meaning without probabilities).
    options : dict, optional
        The solver options of every cell's design, as
        :func:`control_ncs.passivesyn` (``objective='eta'``) or
        :func:`control_ncs.h2syn` / :func:`control_ncs.hinfsyn` take them,
        e.g. ``{'time_limit': 30}``; unknown keys raise ``TypeError``
        before any cell runs. A cell searched locally (a delayed sensor
        link; for ``'h2'``/``'hinf'`` a structured gain) takes only
        ``time_limit`` and ``margin``. Not with a loss budget.

    Returns
    -------
    DesignMap

    Raises
    ------
    ValueError
        An empty grid, a loss outside ``[0, 1)``, a bad ``eta`` or
        ``decay``, a static gain that never closes the loop; any pre-solve
        error of :func:`passivesyn` (e.g. ``D11 + D11ᵀ ⊁ 2ηI``) as it
        raises it.
    ControlArgument
        ``P`` not a NetworkedStateSpace or without ``y = x``, unknown
        ``controller`` or ``actuator``, ``executor`` not an Executor.
    ControlDimension
        ``dim w ≠ dim z``.
    KeyboardInterrupt
        Pending cells are cancelled, then it propagates.

    Examples
    --------
    ``x⁺ = 1.2x + w + u``, ``z = x + w``: the certified η falls as the
    actuator loses more messages.

    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> dm = ncs.design_map(P, [0.0], [0.0, 0.3], decay=0.95, progress=False)
    >>> bool(dm.eta[0, 0] > dm.eta[0, 1])
    True

    The least H2 norm over the same grid (``z = [x; u]``, ``w`` the
    process noise): losing commands costs.

    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], nmeas=1, ncon=1)
    >>> dm = ncs.design_map(P, [0.0], [0.0, 0.3], objective='h2',
    ...                     progress=False)
    >>> dm.value.round(4).tolist()          # √S of the (modified) Riccati
    [[1.3972, 1.7614]]
    """
    objective = choice(objective, "objective", _MAP_OBJECTIVES)
    P = _plant(P, passivity=objective == "eta")
    budgets = {link: grid for link, grid in (("sensor", sensor_budget),
                                             ("actuator", actuator_budget))
               if grid is not None}
    axes, (a1, a2), cells = map_cells(P, sensor_loss, actuator_loss,
                                      sensor_burst, actuator_burst,
                                      sensor_delay, budgets)
    eta = finite_real(eta, "eta", allow_none=True)
    decay = None if decay is None else decay_bound(decay)
    controller = choice(controller, "controller", _CONTROLLERS)
    actuator = choice(actuator, "actuator", _ACTUATORS)
    executor = check_executor(executor)
    progress = progress_check(progress)
    method = choice(method, "method", METHODS)
    options = sweep_options("design_map", objective, options)
    if controller == "static" and not _loop_closes(
            P.sensor_schedule.pattern.any(axis=1),
            P.actuator_schedule.pattern.any(axis=1)):
        raise ValueError(
            "P: a memoryless (static) gain never closes this loop: no phase "
            "schedules a sensor and an actuator together (theory: static-gain loop). Use "
            "controller='predictor'.")
    start = time.perf_counter()
    shape = (a1.size, a2.size)
    if budgets:
        if options is not None:
            raise ControlArgument(
                "options: over a loss budget each cell is one convex program "
                "of worst_case_route, which takes no options here")
        return _budget_map(cells, axes, (a1, a2), objective, eta, decay,
                           controller, actuator, method, executor, progress,
                           start)
    if objective != "eta":
        _performance_options(objective, eta, decay, method)
    if objective != "eta":
        out = run_tasks(perform, [(c, objective, controller, actuator,
                                    options) for c in cells], executor,
                        progress, "design_map")
        reason = np.empty(shape, dtype=object)
        reason.ravel()[:] = [r[3] for r in out]
        return DesignMap(
            axes=axes, values=(a1, a2), eta=np.full(shape, math.nan),
            ms_radius=np.array([r[1] for r in out]).reshape(shape),
            feasible=np.array([r[2] for r in out], dtype=bool).reshape(shape),
            reason=reason, controller=controller, actuator=actuator,
            elapsed=time.perf_counter() - start, objective=objective,
            value=np.array([r[0] for r in out]).reshape(shape))
    tasks = [(c, eta, decay, controller, actuator) for c in cells]

    def neighbours(index: int) -> list:
        i, j = divmod(index, shape[1])
        cells = [(abs(i - u) + abs(j - v), u * shape[1] + v)
                 for u in range(shape[0]) for v in range(shape[1])
                 if (u, v) != (i, j)]
        return [c for _, c in sorted(cells)]

    out = design_cells(tasks, method, executor, progress, "design_map",
                       neighbours, options)
    reason = np.empty(shape, dtype=object)
    reason.ravel()[:] = [r[3] for r in out]
    return DesignMap(
        axes=axes, values=(a1, a2),
        eta=np.array([r[0] for r in out]).reshape(shape),
        ms_radius=np.array([r[1] for r in out]).reshape(shape),
        feasible=np.array([r[2] for r in out], dtype=bool).reshape(shape),
        reason=reason, eta_requested=eta, decay=decay, controller=controller,
        actuator=actuator, elapsed=time.perf_counter() - start)


def _budget_map(cells: list, axes: tuple, values: tuple, objective: str,
                eta: float | None, decay: float | None, controller: str,
                actuator: str, method: str, executor: Executor | None,
                progress: bool, start: float) -> DesignMap:
    """A map over a loss budget's (misses, window): one
    :func:`control_ncs.worst_case_route` per cell, its options checked
    before the first cell runs."""
    (link, other) = ("sensor", "actuator") if axes[0].startswith(
        "sensor") else ("actuator", "sensor")
    if objective == "h2":
        raise ControlArgument(
            f"objective: an H2 norm is an average over the loss patterns; "
            f"a {link}_budget has no probabilities to average with. Use "
            f"objective='hinf' (the worst-case l2 gain) or 'eta'")
    if controller != "static" or actuator != "zero":
        raise ControlArgument(
            f"controller, actuator: over a {link}_budget each cell designs "
            f"a static state-feedback gain with a zero actuator, got "
            f"controller={controller!r}, actuator={actuator!r}")
    if method != "auto":
        raise ControlArgument(
            f"method: over a {link}_budget each cell is one convex program "
            f"on the graph of budget states (worst_case_route); it takes no "
            f"method, got {method!r}")
    if getattr(cells[0], f"{other}_loss") != 0.0 or             getattr(cells[0], f"{other}_delay") is not None:
        raise ControlArgument(
            f"{other}_loss: over a {link}_budget the {other} link must be "
            f"perfect (the route designs for a network the budget alone "
            f"decides)")
    budget_plant(build(cells[0]))     # what the route refuses, said once
    rate = 1.0 if decay is None else decay
    out = run_tasks(budget_cell, [(c, objective, eta, rate) for c in cells],
                    executor, progress, "design_map")
    shape = (values[0].size, values[1].size)
    reason = np.empty(shape, dtype=object)
    reason.ravel()[:] = [r[3] for r in out]
    value = np.array([r[0] for r in out], float).reshape(shape)
    return DesignMap(
        axes=axes, values=values,
        eta=value if objective == "eta" else np.full(shape, math.nan),
        ms_radius=np.array([r[1] for r in out], float).reshape(shape),
        feasible=np.array([r[2] for r in out], dtype=bool).reshape(shape),
        reason=reason, eta_requested=eta, decay=decay, controller=controller,
        actuator=actuator, elapsed=time.perf_counter() - start,
        objective=objective, value=value, worst_case=True)


def _performance_options(objective: str, eta: Any, decay: Any,
                         method: str) -> None:
    """The options an H2 or H∞ map refuses (passivesyn's), said before any
    cell runs."""
    given = [name for name, value, default in (
        ("eta", eta, None), ("decay", decay, None),
        ("method", method, "auto")) if value != default]
    if given:
        raise ControlArgument(
            f"{given[0]}: objective={objective!r} designs each cell with "
            f"h2syn / hinfsyn; it takes no {', '.join(given)} (those are "
            f"passivesyn's options, objective='eta')")


@dataclass(frozen=True)
class RankedSchedule:
    """One schedule of a :class:`ScheduleSearch` ranking.

    Attributes
    ----------
    sensor_schedule, actuator_schedule : tuple of int
        Index vectors (paper §2: node at each phase, 1-based, 0 = nobody).
    eta : float
        Certified dissipation (NaN when ranked by ``'h2'`` or ``'hinf'``).
    ms_radius : float
        Exact per-step mean-square rate of the certified loop.
    value : float or None
        ``objective='h2'`` or ``'hinf'``: the designed loop's exact H2 norm
        or certified ℓ2-gain bound; else None.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> best = ncs.schedule_search(P, 2, decay=0.98, progress=False).ranking[0]
    >>> best.sensor_schedule, best.actuator_schedule
    ((1, 1), (1, 1))
    """

    sensor_schedule: tuple
    actuator_schedule: tuple
    eta: float
    ms_radius: float
    value: float | None = None


@dataclass
class ScheduleSearch:
    """Every schedule of a period up to symmetry, pruned or designed.

    Row ``i`` of each array is one canonical schedule (the smallest word of
    its orbit under cyclic shifts and valid relabellings).

    Attributes
    ----------
    period : int
    sensor_schedules, actuator_schedules : ndarray of int, shape (count, N)
        Index vectors (1-based node, 0 = nobody).
    eta, ms_radius : ndarray, shape (count,)
        Certified ``η`` and exact per-step mean-square rate (NaN where none).
    value : ndarray or None
        ``objective='h2'`` or ``'hinf'``: the exact H2 norm or certified
        ℓ2-gain bound of each designed loop.
    feasible : ndarray of bool
    reason : ndarray of object
        ``'certified'``, a pruning reason (:data:`PRUNE_REASONS`) or the
        :class:`SynthesisError` reason.
    pruned : ndarray of bool
        Removed by an exact test before any LMI.
    total : int
        Number of schedules before symmetry, ``((p2+1)(m2+1))^N`` (fewer
        with a shared channel).
    relabellings : int
        Size of the relabelling group used (1: none).
    objective : {'eta', 'rate', 'h2', 'hinf'}
    top : int
        Length of :attr:`ranking`.
    shared_channel : bool
    controller, actuator : str
    sensor_loss, actuator_loss : float
    eta_requested, decay : float or None
        The options of the search.
    elapsed : float
        Wall-clock time in seconds.
    order : ndarray of int
        Indices of the certified schedules, best first.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> res = ncs.schedule_search(P, 2, decay=0.98, progress=False)
    >>> res.explored, res.pruned_counts, len(res.ranking)
    (10, {'loop_open': 6}, 4)
    """

    period: int
    sensor_schedules: np.ndarray
    actuator_schedules: np.ndarray
    eta: np.ndarray
    ms_radius: np.ndarray
    feasible: np.ndarray
    reason: np.ndarray
    pruned: np.ndarray
    total: int
    relabellings: int
    objective: str = "eta"
    top: int = 10
    shared_channel: bool = False
    controller: str = "static"
    actuator: str = "zero"
    sensor_loss: float = 0.0
    actuator_loss: float = 0.0
    eta_requested: float | None = None
    decay: float | None = None
    elapsed: float = 0.0
    order: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    value: np.ndarray | None = None

    @property
    def explored(self) -> int:
        """Number of canonical schedules (pruned ones included)."""
        return int(self.eta.size)

    @property
    def evaluated(self) -> int:
        """Number of schedules given to passivesyn."""
        return int((~self.pruned).sum())

    @property
    def pruned_counts(self) -> dict:
        """``{reason: count}`` of the schedules pruned before any LMI."""
        return {r: int(np.sum(self.reason[self.pruned] == r))
                for r in PRUNE_REASONS if np.any(self.reason[self.pruned] == r)}

    @property
    def ranking(self) -> list:
        """The ``top`` best certified schedules, best first."""
        value = self.value
        return [RankedSchedule(tuple(self.sensor_schedules[i].tolist()),
                               tuple(self.actuator_schedules[i].tolist()),
                               float(self.eta[i]), float(self.ms_radius[i]),
                               None if value is None else float(value[i]))
                for i in self.order[:self.top]]

    def __repr__(self) -> str:
        return (f"<ScheduleSearch N={self.period}: {self.explored} schedules "
                f"explored of {self.total}, {int(self.pruned.sum())} pruned, "
                f"{int(self.feasible.sum())} certified>")

    def summary(self) -> str:
        """The counts, the pruning reasons and the ranking, for humans."""
        lines = [repr(self),
                 f"  controller={self.controller!r}, actuator="
                 f"{self.actuator!r}, shared_channel={self.shared_channel}, "
                 f"α1={self.sensor_loss:g}, α2={self.actuator_loss:g}, "
                 f"objective={self.objective!r}, decay={self.decay}",
                 f"  symmetry: cyclic shifts × {self.relabellings} "
                 f"relabelling(s); elapsed {self.elapsed:.3g} s",
                 f"  pruned: {self.pruned_counts or 'none'}"]
        failed = self.reason[~self.pruned & ~self.feasible]
        if failed.size:
            r, c = np.unique(failed.astype(str), return_counts=True)
            lines.append("  no certified gain: " + ", ".join(
                f"{a} {b}" for a, b in zip(r, c)))
        for rank, s in enumerate(self.ranking, 1):
            figure = (f"{self.objective} = {s.value:.6g}"
                      if s.value is not None else f"eta = {s.eta:.6g}")
            lines.append(f"  {rank:2d}. sensors {list(s.sensor_schedule)} "
                         f"actuators {list(s.actuator_schedule)}: "
                         f"{figure}, ms_radius = {s.ms_radius:.6g}")
        return "\n".join(lines)

    def to_pandas(self) -> Any:
        """One row per canonical schedule, ranked ones first.

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        pd = _pandas()
        rest = [i for i in range(self.explored) if i not in set(self.order)]
        idx = list(self.order) + rest
        rank = np.full(self.explored, 0)
        rank[self.order] = np.arange(1, self.order.size + 1)
        return pd.DataFrame({
            "rank": rank[idx],
            "sensor_schedule": [tuple(self.sensor_schedules[i].tolist())
                                for i in idx],
            "actuator_schedule": [tuple(self.actuator_schedules[i].tolist())
                                  for i in idx],
            "eta": self.eta[idx], "ms_radius": self.ms_radius[idx],
            **({self.objective: self.value[idx]}
               if self.value is not None else {}),
            "feasible": self.feasible[idx], "pruned": self.pruned[idx],
            "reason": self.reason[idx]})

    def plot(self, count: int | None = None, *, title: str | None = None
             ) -> ct.ControlPlot:
        """The best schedules as timelines: :func:`schedule_search_plot`.

        Parameters
        ----------
        count : int, optional
        title : str, optional

        Returns
        -------
        control.ControlPlot
        """
        from .plots import schedule_search_plot
        return schedule_search_plot(self, count, title=title)

def schedule_search(P: NetworkedStateSpace, period: int, *,
                    shared_channel: bool = False,
                    sensor_loss: float | None = None,
                    actuator_loss: float | None = None,
                    objective: str = "eta", eta: float | None = None,
                    decay: float | None = None, controller: str = "static",
                    actuator: str = "zero", executor: Executor | None = None,
                    top: int = 10, limit: int | None = 5000,
                    progress: bool | None = None, method: str = "auto",
                    options: Mapping[str, Any] | None = None
                    ) -> ScheduleSearch:
    """Rank every schedule of one period by verified design.

    Enumerates the index schedules ``s1 ∈ {0..p2}^N``, ``s2 ∈ {0..m2}^N``
    (one sensor and one actuator message per phase, :ref:`theory-network`) up
    to symmetry, removes those for which no gain can exist by cheap exact
    tests, designs the rest with :func:`passivesyn` and ranks the certified
    ones.

    **Symmetry.** A cyclic shift of the pair ``(s1, s2)`` is a phase shift
    of a periodic system: the set of certified ``η`` is the same. Relabelling
    sensors and actuators is a symmetry only when the plant is invariant
    under it; since ``y = x``, a sensor relabelling is a state permutation
    ``Π`` and is used exactly when, for an actuator permutation ``Σ`` and a
    permutation ``Ω`` of ``w`` and ``z`` together (it keeps the supply rate),
    ``Π A Πᵀ = A``, ``Π B1 Ωᵀ = B1``, ``Π B2 Σᵀ = B2``, ``Ω C1 Πᵀ = C1``,
    ``Ω D11 Ωᵀ = D11``, ``Ω D12 Σᵀ = D12`` hold in exact arithmetic
    (searched up to ``RELABEL_MAX_STATES`` states, ``n!`` permutations).
    One representative is kept per orbit: its lexicographically smallest
    word.

    **Pruning** (exact, before any LMI; the reason is kept per schedule):
    ``'loop_open'``: no actuator is ever scheduled, or a static gain with
    no phase where a sensor and an actuator are both scheduled (every
    shared-channel schedule: only the predictor closes such loops); ``'not_stabilisable'``: the loss-free
    lifted pair ``(A^N, [A^(N-1-k) B2 Σ2,k])`` fails the PBH test on an
    eigenvalue ``|λ| ≥ 1`` (static gain: only phases where a sensor also
    reports act; ``actuator='hold'``: every actuator ever scheduled acts
    at every phase, a relaxation); ``'not_detectable'``: the dual test with
    what the gain hears (``Σ1,k``, for a static gain only where an actuator
    listens); ``'estimation_not_mss'`` (predictor): the estimation-error
    loop ``e⁺ = (I − θ1 Σ1,k+1) A e`` of :ref:`theory-predictor`, which no gain
    changes, has an exact :func:`ms_radius` ``≥ 1`` (``≥ r²`` with
    ``decay=r``).

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant (needs ``y = x`` and ``dim w = dim z``); its own schedules
        are replaced by each candidate.
    period : int
        The period ``N`` of the schedules.
    shared_channel : bool
        Only one message per phase (``s1[k] ≠ 0 ⇒ s2[k] = 0``).
    sensor_loss, actuator_loss : float in [0, 1), optional
        Loss probabilities (default: those of ``P``).
    objective : {'eta', 'rate', 'h2', 'hinf'}
        Rank by certified ``η`` (largest first) or by the exact per-step
        mean-square rate of the certified loop (smallest first). Both are
        figures of the one loop passivesyn returns: with ``eta=None`` the
        rate sits near the decay bound, so rank by ``'rate'`` with a fixed
        ``eta``. ``'h2'`` / ``'hinf'``: design every schedule with
        :func:`control_ncs.h2syn` / :func:`control_ncs.hinfsyn` instead (a
        scheduled sensor makes the gain structured: their local search)
        and rank by the exact H2 norm / certified ℓ2-gain bound (smallest
        first); these take no ``eta``, ``decay`` or ``method``.
    eta : float, optional
        Dissipation asked of every schedule; None maximises it.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r`` (``ms_radius < r²``).
    controller : {'static', 'predictor'}
    actuator : {'zero', 'hold'}
    executor : concurrent.futures.Executor, optional
        One task per schedule that survives pruning; None: sequential.
    top : int
        Length of the ranking.
    limit : int or None
        Refuse (ValueError) when there are more canonical schedules than
        this; None: up to ``MAX_SCHEDULES`` (10⁷).
    progress : bool or None
        Show a progress bar (needs tqdm). Default None: only where a person
        watches (an interactive terminal or a notebook), never in scripts'
        logs or CI.
    method : {'auto', 'lmi', 'refine'}
        How each cell is designed. ``'auto'`` (default): every cell by the
        LMI (exact with full information, fast), then every cell where the
        LMI is only sufficient refined, warm-started from its own LMI gain
        or its nearest certified neighbour's (the LMI is not solved twice);
        the better certified level is kept, and a cell is "infeasible"
        only with a proof. ``'lmi'``: the LMI only (structured cells may
        end ``'sufficient_failed'``). ``'refine'``:
        :func:`control_ncs.passivesyn` with ``method='refine'`` for every
        cell, each from its own LMI start (slowest).
    options : dict, optional
        The solver options of every schedule's design, as
        :func:`control_ncs.passivesyn` (``objective`` ``'eta'`` or
        ``'rate'``) or :func:`control_ncs.h2syn` /
        :func:`control_ncs.hinfsyn` take them; unknown keys raise
        ``TypeError`` before any schedule is designed. A schedule whose
        gain is searched locally takes only ``time_limit`` and ``margin``.

    Returns
    -------
    ScheduleSearch

    Raises
    ------
    ValueError
        ``period`` not an int >= 1, a loss outside ``[0, 1)``, more
        canonical schedules than ``limit`` (the message says how many), a
        bad ``eta``, ``decay`` or ``top``; pre-solve errors of passivesyn.
    ControlArgument
        ``P`` not a NetworkedStateSpace or without ``y = x``, unknown
        ``objective``, ``controller`` or ``actuator``, ``executor`` not an
        Executor.
    ControlDimension
        ``dim w ≠ dim z``.

    Examples
    --------
    A scalar plant, period 2, the predictor over a shared channel:

    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> res = ncs.schedule_search(P, 2, shared_channel=True, controller='predictor',
    ...                       decay=0.98, progress=False)
    >>> res.explored, res.pruned_counts
    (6, {'loop_open': 3, 'not_detectable': 2})
    >>> res.ranking[0].sensor_schedule, res.ranking[0].actuator_schedule
    ((0, 1), (1, 0))
    """
    objective = choice(objective, "objective", _OBJECTIVES)
    performance = objective in ("h2", "hinf")
    P = _plant(P, passivity=not performance)
    N = positive_int(period, "period")
    shared = flag(shared_channel, "shared_channel")
    if (sensor_loss is None or actuator_loss is None) and not P.is_iid:
        # the pruning and the synthesis are written for Bernoulli losses;
        # P's stationary loss would silently drop its bursts (theory: Markov
        # losses)
        raise ControlArgument(
            "P: its links are Markov (bursty); schedule_search works with "
            "Bernoulli losses only: pass sensor_loss= and actuator_loss= "
            "explicitly")
    a1 = P.sensor_loss if sensor_loss is None else sensor_loss
    a2 = P.actuator_loss if actuator_loss is None else actuator_loss
    a1, a2 = loss(a1, "sensor_loss"), loss(a2, "actuator_loss")
    if performance:
        given = [name for name, value, default in (
            ("eta", eta, None), ("decay", decay, None),
            ("method", method, "auto")) if value != default]
        if given:
            who = "h2syn" if objective == "h2" else "hinfsyn"
            raise ControlArgument(
                f"{given[0]}: objective={objective!r} designs every schedule "
                f"with {who}; it takes no {', '.join(given)} (passivesyn's "
                f"options)")
    eta = finite_real(eta, "eta", allow_none=True)
    decay = None if decay is None else decay_bound(decay)
    controller = choice(controller, "controller", _CONTROLLERS)
    actuator = choice(actuator, "actuator", _ACTUATORS)
    executor = check_executor(executor)
    top = positive_int(top, "top")
    if limit is not None:
        limit = positive_int(limit, "limit")
    progress = progress_check(progress)
    method = choice(method, "method", METHODS)
    options = sweep_options("schedule_search", objective, options)
    start = time.perf_counter()

    p2, m2 = P.nmeas, P.ncon
    letters = _alphabet(p2, m2, shared)
    total = len(letters) ** N       # an exact int, however long the period
    group = _relabellings(P)
    maps = _letter_maps(group, letters)
    count = _orbit_count(N, maps)
    if limit is None and count > MAX_SCHEDULES:
        raise ValueError(
            f"period: {N} gives {_big(count)} schedules up to symmetry, more "
            f"than MAX_SCHEDULES = {MAX_SCHEDULES}: search a shorter period")
    if limit is not None and count > limit:
        raise ValueError(
            f"period: {N} gives {_big(count)} schedules up to symmetry "
            f"({_big(total)} before it) for {p2} sensor(s) and {m2} "
            f"actuator(s), more than limit={limit}; raise limit= (or pass "
            f"limit=None) to search them all")
    words = list(_canonical_schedules(N, maps, len(letters)))
    s1 = np.array([[letters[x][0] for x in w] for w in words], dtype=int)
    s2 = np.array([[letters[x][1] for x in w] for w in words], dtype=int)
    s1 = s1.reshape(len(words), N)
    s2 = s2.reshape(len(words), N)

    def pattern(idx: np.ndarray, nodes: int) -> np.ndarray:
        return (idx[:, None] == np.arange(1, nodes + 1)[None, :])

    reason = np.empty(len(words), dtype=object)
    pruned = np.zeros(len(words), dtype=bool)
    for i in range(len(words)):
        why = _prune(P, pattern(s1[i], p2), pattern(s2[i], m2), controller,
                     actuator, a1, decay)
        if why is not None:
            reason[i], pruned[i] = why, True
    todo = np.flatnonzero(~pruned)
    with warnings.catch_warnings():
        # the search enumerates schedules that leave some node silent on
        # purpose; the warning is for schedules a user writes
        warnings.simplefilter("ignore", ScheduleWarning)
        tasks = [(P.with_network(sensor_schedule=s1[i].tolist(),
                                 actuator_schedule=s2[i].tolist(),
                                 sensor_loss=a1, actuator_loss=a2,
                                 shared_channel=shared),
                  eta, decay, controller, actuator) for i in todo]
    eta_a = np.full(len(words), math.nan)
    rate = np.full(len(words), math.nan)
    feasible = np.zeros(len(words), dtype=bool)
    value = None
    if performance:
        out = run_tasks(perform, [(t[0], objective, controller, actuator,
                                    options) for t in tasks], executor,
                        progress, "schedule_search")
        value = np.full(len(words), math.nan)
        for t, (v, r, ok, why, _, _) in zip(todo, out):
            value[t], rate[t], feasible[t], reason[t] = v, r, ok, why
    else:
        # schedules are not neighbours of one another: the refinement of a
        # cell the LMI leaves open starts from that cell's own LMI gain
        out = design_cells(tasks, method, executor, progress,
                           "schedule_search", None, options)
        for t, (e, r, ok, why, _, _) in zip(todo, out):
            eta_a[t], rate[t], feasible[t], reason[t] = e, r, ok, why
    good = np.flatnonzero(feasible)
    # ties are broken by the other figure, then by the canonical order
    if objective == "eta":
        keys = (good, rate[good], -eta_a[good])
    elif value is not None:
        keys = (good, rate[good], value[good])
    else:
        keys = (good, -eta_a[good], rate[good])
    order = good[np.lexsort(keys)]
    return ScheduleSearch(
        period=N, sensor_schedules=s1, actuator_schedules=s2, eta=eta_a,
        ms_radius=rate, feasible=feasible, reason=reason, pruned=pruned,
        total=total, relabellings=len(group), objective=objective, top=top,
        shared_channel=shared, controller=controller, actuator=actuator,
        sensor_loss=a1, actuator_loss=a2, eta_requested=eta, decay=decay,
        elapsed=time.perf_counter() - start, order=order, value=value)
