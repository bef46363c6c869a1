"""Every figure of the package: responses, schedules, sweeps.

Every function returns python-control's :class:`control.ControlPlot`
(``lines``, ``axes``, ``figure``, ``legend``), as
:func:`control.time_response_plot` does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import control as ct
import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.ticker import Formatter
from control.exception import ControlArgument, ControlDimension

from ._checks import choice, positive_int
from .plant import NetworkedStateSpace
from .responses import EnsembleResponse

__all__ = ["ensemble_plot", "plot_ensemble", "schedule_plot",
           "design_map_plot", "schedule_search_plot"]


def _one_axes(ax: Any, drawn: list) -> ct.ControlPlot:
    """python-control's ControlPlot of one axes and what was drawn on it."""
    lines = np.empty((1, 1), dtype=object)
    lines[0, 0] = drawn
    return ct.ControlPlot(lines, np.array([[ax]], dtype=object), ax.figure,
                          legend=np.full((1, 1), None, dtype=object))


class _PlainTicks(Formatter):
    """Tick labels as plain numbers, no offset and no multiplier."""

    def __init__(self) -> None:
        self._ticks = np.zeros(0)

    def set_locs(self, locs: Any) -> None:
        # the axis hands over every tick before labelling one
        self._ticks = np.asarray(locs, float)

    def __call__(self, x: float, pos: int | None = None) -> str:
        locs = self._ticks[np.isfinite(self._ticks)]
        if locs.size < 2:
            return f"{x:.6g}"
        step = np.min(np.diff(np.unique(locs)))
        big = np.max(np.abs(locs))
        if big >= 1e6 or step < 1e-10:
            digits = int(np.ceil(np.log10(big / step))) + 1
            return f"{x:.{max(digits, 2)}g}"
        # the fewest decimals that write every tick exactly (to a thousandth
        # of the spacing): neighbours never read alike
        decimals = next(d for d in range(11) if np.all(
            np.abs(np.round(locs, d) - locs) <= 1e-3 * step))
        text = f"{x:.{decimals}f}"
        return "0" if float(text) == 0 else text


def plain_ticks() -> Formatter:
    """A tick formatter that writes plain numbers, no offset.

    matplotlib's default writes ticks that differ in the fifth digit as
    an offset and small differences (``1e-8`` and ``-3e-4`` above the
    axis); this one writes each tick in full with the fewest decimals that
    tell neighbours apart (``-0.00030004``), in scientific notation only
    for values of a million or more or spacings below ``1e-10``.

    Returns
    -------
    matplotlib.ticker.Formatter

    Examples
    --------
    >>> from control_ncs.plots import plain_ticks
    >>> f = plain_ticks()
    >>> ticks = [0.47335, 0.4734, 0.47345]
    >>> f.set_locs(ticks)
    >>> [f(x) for x in ticks]
    ['0.47335', '0.47340', '0.47345']
    """
    return _PlainTicks()


def _check_axes(ax: Any) -> None:
    if not isinstance(ax, Axes):
        raise ControlArgument(f"ax: expected a matplotlib Axes, got "
                              f"{type(ax).__name__}")


def ensemble_plot(response: EnsembleResponse, ax: Any = None, paths: int = 5,
                  *, band: bool = True, legend: bool = True,
                  title: str | None = None) -> ct.ControlPlot:
    """Draw an ensemble response: band, paths, sample and exact mean.

    One axes per output, each with ``paths`` thin sample paths, the band
    between the lowest and highest quantile (``fill_between``), the sample
    mean (dashed) and the exact mean of :ref:`theory-moments` (solid, black,
    as in :meth:`EnsembleResponse.plot`) -- so ``paths + 2`` lines and one
    filled band per axes.

    Parameters
    ----------
    response : EnsembleResponse
        From :func:`step_response`, :func:`impulse_response`,
        :func:`initial_response` or :func:`forced_response`.
    ax : matplotlib Axes or array of Axes, optional
        One axes per output; default: a new figure.
    paths : int, optional
        Number of sample paths to draw (at most those kept in
        ``response.paths``; default 5).
    band : bool, optional
        Draw the quantile band (needs at least two quantiles).
    legend : bool, optional
        Legend in the first axes.
    title : str, optional
        Figure title (default: the response's title; only for a new figure).

    Returns
    -------
    control.ControlPlot
        ``lines[i, 0]`` lists the lines of output ``i`` (paths, sample mean,
        exact mean); ``axes`` has shape (p, 1).

    Raises
    ------
    ControlArgument
        ``response`` is not an :class:`EnsembleResponse`, or ``ax`` holds
        something else than matplotlib Axes.
    ControlDimension
        ``ax`` does not hold one axes per output.
    ValueError
        ``paths`` is not an int >= 0.

    Examples
    --------
    >>> from control_ncs import step_response, plot_ensemble
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> cplt = ncs.ensemble_plot(ncs.step_response(sys, 20, trials=200, seed=0), paths=3)
    >>> len(cplt.axes[0, 0].get_lines()), len(cplt.axes[0, 0].collections)
    (5, 1)
    """
    if not isinstance(response, EnsembleResponse):
        raise ControlArgument(f"response: expected an EnsembleResponse (see "
                              f"step_response), got {type(response).__name__}")
    if isinstance(paths, (bool, np.bool_)) or not isinstance(
            paths, (int, np.integer)) or paths < 0:
        raise ValueError(f"paths: expected an int >= 0, got {paths!r}")
    p = len(response.output_labels)
    if ax is None:
        fig, axes = plt.subplots(p, 1, sharex=True, squeeze=False)
        axes = axes[:, 0]
    else:
        axes = np.asarray(ax, dtype=object).reshape(-1)
        if axes.size != p:
            raise ControlDimension(f"ax: expected {p} axes (one per output), "
                                   f"got {axes.size}")
        for a in axes:
            _check_axes(a)
        fig = axes[0].figure
    shown = min(int(paths), response.paths.ntraces)
    t = response.time
    lines = np.empty((p, 1), dtype=object)
    bounds: tuple[np.ndarray, np.ndarray] | None = None
    if band and len(response.quantiles) >= 2:
        bounds = (response.quantile_values[0], response.quantile_values[-1])
        band_label = (f"{100 * response.quantiles[0]:g}–"
                      f"{100 * response.quantiles[-1]:g}% band")
    for i, a in enumerate(axes):
        drawn = []
        if shown:
            drawn += a.plot(t, response.paths.y[i, :shown].T, color="0.55",
                            linewidth=0.7, alpha=0.8)
            drawn[0].set_label("sample paths")
        if bounds is not None:
            a.fill_between(t, bounds[0][i], bounds[1][i], color="C0",
                           alpha=0.25, linewidth=0, label=band_label)
        drawn += a.plot(t, response.sample_mean[i], color="C0", linewidth=1.8,
                        linestyle="--",
                        label=f"sample mean ({response.trials} trials)")
        drawn += a.plot(t, response.exact_mean[i], color="k", linewidth=1.2,
                        label="exact mean")
        a.set_ylabel(response.output_labels[i])
        lines[i, 0] = drawn
    axes[-1].set_xlabel("Time [s]")
    legends = np.full((p, 1), None, dtype=object)
    if legend:
        legends[0, 0] = axes[0].legend(loc="best", fontsize="small")
    if ax is None:
        fig.suptitle(title if title is not None else response.title)
    return ct.ControlPlot(lines, axes.reshape(p, 1), fig, legend=legends)


#: The former name of :func:`ensemble_plot` (python-control names its plot
#: functions ``*_plot``).
plot_ensemble = ensemble_plot


def schedule_plot(P: NetworkedStateSpace, steps: int | None = None, *,
                  ax: Any = None, title: str | None = None) -> ct.ControlPlot:
    """Plot the sensor and actuator schedules of ``P`` as a timeline.

    One row per sensor and per actuator; a filled cell at step ``t`` means
    that node may send at ``t`` (:ref:`theory-network`).

    Parameters
    ----------
    P : NetworkedStateSpace
    steps : int, optional
        Number of steps to draw (an int >= 1; default: two periods, at
        least 8).
    ax : matplotlib.axes.Axes, optional
        Axes to draw in; default: a new figure.
    title : str, optional
        Axes title (default: the period and the loss probabilities).

    Returns
    -------
    control.ControlPlot
        ``axes`` has shape (1, 1); ``lines[0, 0]`` lists the filled cells
        of each row (one ``broken_barh`` collection per node).

    Raises
    ------
    ControlArgument
        ``P`` is not a :class:`NetworkedStateSpace`, or ``ax`` not a
        matplotlib Axes.
    ValueError
        ``steps`` is not an int >= 1.

    Examples
    --------
    >>> P = ncs.nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
    ...         np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    >>> cplt = ncs.schedule_plot(P)
    >>> len(cplt.axes[0, 0].get_yticklabels())
    3
    """
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if steps is None:
        steps = max(8, 2 * P.period)
    # positive_int without allow_none never returns None
    steps = positive_int(steps, "steps")
    if ax is None:
        # constrained layout: the signal names on the left stay inside the
        # figure with a plain savefig (no bbox_inches needed)
        _, ax = plt.subplots(figsize=(min(12, 3 + 0.35 * steps),
                                      1.0 + 0.35 * (P.nmeas + P.ncon)),
                             layout="constrained")
    else:
        _check_axes(ax)
    ys = P.output_labels[-P.nmeas:]
    us = P.input_labels[-P.ncon:]
    rows = [(f"sensor {s}", P.sensor_schedule, i, "tab:blue")
            for i, s in enumerate(ys)]
    rows += [(f"actuator {s}", P.actuator_schedule, j, "tab:orange")
             for j, s in enumerate(us)]
    drawn = []
    for r, (_, sched, node, color) in enumerate(rows):
        on = [t for t in range(steps) if sched.pattern[t % sched.period, node]]
        drawn.append(ax.broken_barh([(t, 0.9) for t in on], (r - 0.4, 0.8),
                                    color=color))
    ax.set_yticks(np.arange(len(rows)), [r[0] for r in rows])
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.set_xlim(0, steps)
    ax.invert_yaxis()
    ax.set_xlabel("time step t")
    for t in range(0, steps + 1, P.period):
        ax.axvline(t, color="0.8", lw=0.8, zorder=0)
    ax.set_title(title or (f"Schedule, period N = {P.period}, losses "
                           f"α1 = {P.sensor_loss:g}, α2 = {P.actuator_loss:g}"))
    return _one_axes(ax, drawn)


def design_map_plot(dmap: Any, quantity: str | None = None, *,
                    ax: Any = None, title: str | None = None
                    ) -> ct.ControlPlot:
    """Heat map of a design map's figure or ``ms_radius``.

    The cells the map certified are coloured; the red line is the
    feasibility boundary (where the grid has two points or more on each
    axis). :meth:`control_ncs.DesignMap.plot` calls this.

    Parameters
    ----------
    dmap : DesignMap
        The result of :func:`control_ncs.design_map`.
    quantity : {'eta', 'h2', 'hinf', 'ms_radius'}, optional
        The map's own figure (its ``objective``, the default) or the
        certified loops' mean-square rate.
    ax : matplotlib.axes.Axes, optional
    title : str, optional

    Returns
    -------
    control.ControlPlot
        ``lines[0, 0]`` holds the image and, when drawn, the boundary.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
    >>> dm = ncs.design_map(P, [0.0, 0.2], [0.0, 0.2], decay=0.95,
    ...                     progress=False)
    >>> cp = ncs.design_map_plot(dm)
    >>> cp.axes[0, 0].get_xlabel(), bool(min(cp.axes[0, 0].get_xlim()) >= 0)
    ('actuator_loss', True)
    """
    objective = getattr(dmap, "objective", "eta")
    quantity = objective if quantity is None else quantity
    choice(quantity, "quantity", (objective, "ms_radius"))
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4.5), layout="constrained")
    else:
        _check_axes(ax)
    data = np.ma.masked_invalid(dmap.ms_radius if quantity == "ms_radius"
                                else dmap.value)
    x, y = dmap.values[1], dmap.values[0]
    mesh = ax.pcolormesh(_edges(x, dmap.axes[1]), _edges(y, dmap.axes[0]), data, shading="flat",
                         cmap="viridis")
    drawn: list = [mesh]
    label = {"h2": "H2 norm", "hinf": "ℓ2-gain bound"}.get(quantity, quantity)
    # plain ticks: the default's offset made a map of η ≈ -0.0003 read
    # "1e-8 - 3e-4" above ticks of -0.5 ... -4
    ax.figure.colorbar(mesh, ax=ax, label=label, format=plain_ticks())
    if min(dmap.shape) >= 2 and dmap.feasible.any() \
            and not dmap.feasible.all():
        drawn.append(ax.contour(x, y, dmap.feasible.astype(float),
                                levels=[0.5], colors="red",
                                linewidths=1.5))
    ax.set_xlabel(dmap.axes[1])
    ax.set_ylabel(dmap.axes[0])
    ax.set_title(title or (f"{label} of the certified design\n"
                           f"(blank: none; red: feasibility boundary)"),
                 fontsize="medium")
    return _one_axes(ax, drawn)


def _edges(v: np.ndarray, axis: str) -> np.ndarray:
    """Cell edges around grid points (midpoints; a lone point gets ±0.5,
    or a tenth of its value): a probability axis stays within [0, 1]."""
    if v.size == 1:
        half = 0.5 if not axis.endswith("loss") else max(0.05, 0.1 * v[0])
        e = np.array([v[0] - half, v[0] + half])
    else:
        mid = (v[1:] + v[:-1]) / 2
        e = np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
    if axis.endswith("loss"):
        e = np.clip(e, 0.0, 1.0)
    return e


def schedule_search_plot(search: Any, count: int | None = None, *,
                         title: str | None = None) -> ct.ControlPlot:
    """The best schedules of a search as timelines, one row each.

    :meth:`control_ncs.ScheduleSearch.plot` calls this.

    Parameters
    ----------
    search : ScheduleSearch
        The result of :func:`control_ncs.schedule_search`.
    count : int, optional
        Number of schedules to draw (default: the ranking, at most 6).
    title : str, optional
        Figure title.

    Returns
    -------
    control.ControlPlot
        ``axes`` has shape (count, 1); ``lines[i, 0]`` lists the cells
        drawn for schedule ``i`` (one ``broken_barh`` per node).

    Raises
    ------
    ValueError
        Nothing was certified, or ``count`` is not an int >= 1.

    Examples
    --------
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
    >>> res = ncs.schedule_search(P, 2, decay=0.98, progress=False)
    >>> ncs.schedule_search_plot(res, 1).axes.shape
    (1, 1)
    """
    ranked = search.ranking
    if not ranked:
        raise ValueError("plot: no schedule was certified; nothing to draw")
    count = min(len(ranked), 6) if count is None else min(
        len(ranked), positive_int(count, "count"))
    p2 = max(1, int(search.sensor_schedules.max(initial=0)))
    m2 = max(1, int(search.actuator_schedules.max(initial=0)))
    rows = p2 + m2
    fig, axs = plt.subplots(count, 1, squeeze=False, sharex=True,
                            figsize=(7, 0.5 + count * (0.3 * rows + 0.5)))
    N = search.period
    lines = np.empty((count, 1), dtype=object)
    for r, s in enumerate(ranked[:count]):
        ax = axs[r, 0]
        drawn = []
        labels: list[str] = []
        for i in range(1, p2 + 1):
            on = [k for k in range(N) if s.sensor_schedule[k] == i]
            drawn.append(ax.broken_barh([(k, 0.9) for k in on],
                                        (len(labels) - 0.4, 0.8),
                                        color="tab:blue"))
            labels.append(f"sensor {i}")
        for j in range(1, m2 + 1):
            on = [k for k in range(N) if s.actuator_schedule[k] == j]
            drawn.append(ax.broken_barh([(k, 0.9) for k in on],
                                        (len(labels) - 0.4, 0.8),
                                        color="tab:orange"))
            labels.append(f"actuator {j}")
        ax.set_yticks(np.arange(len(labels)), labels)
        ax.set_ylim(-0.6, len(labels) - 0.4)
        ax.invert_yaxis()
        ax.set_xlim(0, N)
        label = {"h2": "H2", "hinf": "ℓ2 gain"}.get(search.objective, "")
        figure = (f"{label} = {s.value:.4g}" if s.value is not None
                  else f"η = {s.eta:.4g}")
        ax.set_title(f"#{r + 1}: {figure}, ms_radius = "
                     f"{s.ms_radius:.4g}", fontsize="small")
        lines[r, 0] = drawn
    # one labelled tick per phase, at the middle of its bar
    axs[-1, 0].set_xticks(np.arange(N) + 0.45, [str(k) for k in range(N)])
    axs[-1, 0].set_xlabel("phase k")
    fig.suptitle(title or f"Best schedules of period {N}"
                 + (" (shared channel)" if search.shared_channel else ""))
    fig.tight_layout()
    return ct.ControlPlot(lines, axs, fig,
                          legend=np.full((count, 1), None, dtype=object))
