"""Draw a network schedule as a timeline (who may send at each step)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .plant import NetworkedStateSpace

__all__ = ["schedule_plot"]


def schedule_plot(P: NetworkedStateSpace, steps: int | None = None, *,
                  ax: Any = None, title: str | None = None) -> Any:
    """Plot the sensor and actuator schedules of ``P`` as a timeline.

    One row per sensor and per actuator; a filled cell at step ``t`` means
    that node may send at ``t`` (MATH §3).

    Parameters
    ----------
    P : NetworkedStateSpace
    steps : int, optional
        Number of steps to draw (default: two periods, at least 8).
    ax : matplotlib.axes.Axes, optional
    title : str, optional

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> P = nss(np.eye(2), np.eye(2), np.vstack([np.eye(2)[:1], np.eye(2)]),
    ...         np.zeros((3, 2)), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2])
    >>> ax = schedule_plot(P)
    >>> len(ax.get_yticklabels())
    3
    """
    import matplotlib.pyplot as plt
    from control.exception import ControlArgument

    from ._checks import positive_int

    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if steps is None:
        steps = max(8, 2 * P.period)
    steps = positive_int(steps, "steps")
    if ax is None:
        _, ax = plt.subplots(figsize=(min(12, 2 + 0.35 * steps),
                                      0.6 + 0.35 * (P.nmeas + P.ncon)))
    ys = P.output_labels[-P.nmeas:]
    us = P.input_labels[-P.ncon:]
    rows = [(f"sensor {s}", P.sensor_schedule, i, "tab:blue")
            for i, s in enumerate(ys)]
    rows += [(f"actuator {s}", P.actuator_schedule, j, "tab:orange")
             for j, s in enumerate(us)]
    for r, (_, sched, node, color) in enumerate(rows):
        on = [t for t in range(steps) if sched.pattern[t % sched.period, node]]
        ax.broken_barh([(t, 0.9) for t in on], (r - 0.4, 0.8), color=color)
    ax.set_yticks(np.arange(len(rows)), [r[0] for r in rows])
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.set_xlim(0, steps)
    ax.invert_yaxis()
    ax.set_xlabel("time step t")
    for t in range(0, steps + 1, P.period):
        ax.axvline(t, color="0.8", lw=0.8, zorder=0)
    ax.set_title(title or (f"Schedule, period N = {P.period}, losses "
                           f"α1 = {P.sensor_loss:g}, α2 = {P.actuator_loss:g}"))
    return ax
