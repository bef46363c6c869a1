"""The grid a design map runs over: loss probabilities, burst lengths, and
the plant of each cell (:func:`control_ncs.design_map`).

A cell's plant is the map's plant with its links replaced: a loss grid sets
a link's stationary loss (a bursty link keeps its mean burst length, so a
map over a bursty link stays bursty), and a burst grid makes the link a
Gilbert–Elliott chain of that loss and that mean burst length
(:ref:`theory-markov`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from control.exception import ControlArgument

from ._checks import finite_real
from .network import GilbertElliott, gilbert_elliott
from .plant import NetworkedStateSpace

__all__: list[str] = []

LINKS = ("sensor", "actuator")


def loss(value: Any, name: str) -> float:
    """A loss probability in ``[0, 1)`` (1: nothing arrives, no loop)."""
    try:
        alpha = finite_real(value, name)
    except ValueError:
        raise ValueError(f"{name}: expected a loss probability in [0, 1), "
                         f"got {value!r}") from None
    if not 0.0 <= alpha < 1.0:
        raise ValueError(f"{name}: expected a loss probability in [0, 1), "
                         f"got {value!r}")
    return alpha


def _grid(values: Any, name: str, what: str) -> np.ndarray:
    if isinstance(values, (str, bytes)):
        raise ValueError(f"{name}: expected a 1-D grid of {what}, got "
                         f"{values!r}")
    arr = np.asarray(values, dtype=object)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D grid of {what}, got an "
                         f"array of shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name}: the grid is empty (give at least one)")
    return arr


def loss_grid(values: Any, name: str) -> np.ndarray:
    """A 1-D grid of loss probabilities in ``[0, 1)``."""
    arr = _grid(values, name, "loss probabilities in [0, 1)")
    return np.array([loss(v, f"{name}[{i}]") for i, v in enumerate(arr)])


def burst_grid(values: Any, name: str) -> np.ndarray:
    """A 1-D grid of mean burst lengths (steps, ``≥ 1``)."""
    arr = _grid(values, name, "mean burst lengths (steps, >= 1)")
    out = []
    for i, v in enumerate(arr):
        try:
            b = finite_real(v, f"{name}[{i}]")
        except ValueError:
            b = float("nan")
        if not b >= 1.0:
            raise ValueError(f"{name}[{i}]: expected a mean burst length "
                             f">= 1 step, got {v!r}")
        out.append(b)
    return np.array(out)


def at_loss(link: Any, value: float, burst: float | None = None) -> Any:
    """The link at another stationary loss: with ``burst``, the
    Gilbert–Elliott link of that mean burst length; otherwise a bursty link
    keeps its own. A loss of 0 is a link that never fails."""
    if burst is None and isinstance(link, GilbertElliott) and \
            not link.is_bernoulli:
        burst = link.burst
    if burst is None or value == 0.0:
        return value
    try:
        return gilbert_elliott(loss=value, burst=burst)
    except ValueError as err:
        raise ValueError(
            f"loss: {value:g} cannot be reached on a bursty link with mean "
            f"bursts of {burst:g} steps ({err})") from None


def map_cells(P: NetworkedStateSpace, sensor_loss: Any, actuator_loss: Any,
              sensor_burst: Any, actuator_burst: Any
              ) -> tuple[tuple[str, str], tuple[np.ndarray, np.ndarray],
                         list[NetworkedStateSpace]]:
    """``(axes, values, cells)`` of a map, cells row-major.

    Without a burst grid the axes are the two links' losses. With one
    (``sensor_burst`` or ``actuator_burst``) they are that link's loss and
    mean burst length, and the other link takes its one given loss.
    """
    a1 = loss_grid(sensor_loss, "sensor_loss")
    a2 = loss_grid(actuator_loss, "actuator_loss")
    bursts = {link: grid for link, grid in
              (("sensor", sensor_burst), ("actuator", actuator_burst))
              if grid is not None}
    if not bursts:
        return (("sensor_loss", "actuator_loss"), (a1, a2),
                [P.with_network(sensor_loss=at_loss(P.sensor_link, x),
                                actuator_loss=at_loss(P.actuator_link, y))
                 for x in a1 for y in a2])
    if len(bursts) > 1:
        raise ControlArgument(
            "sensor_burst, actuator_burst: a map has two axes; give the "
            "burst grid of one link")
    (link, grid), = bursts.items()
    other = "actuator" if link == "sensor" else "sensor"
    b = burst_grid(grid, f"{link}_burst")
    losses, fixed = (a1, a2) if link == "sensor" else (a2, a1)
    if fixed.size != 1:
        raise ControlArgument(
            f"{other}_loss: with {link}_burst the map's axes are {link}_loss "
            f"and {link}_burst; give one {other} loss, got {fixed.size}")
    kept = at_loss(getattr(P, f"{other}_link"), float(fixed[0]))
    cells = [P.with_network(**{f"{link}_loss": at_loss(None, x, y),
                               f"{other}_loss": kept})
             for x in losses for y in b]
    return (f"{link}_loss", f"{link}_burst"), (losses, b), cells
