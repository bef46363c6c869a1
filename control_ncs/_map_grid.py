"""The grid a design map runs over: loss probabilities, burst lengths,
delay laws, and the plant of each cell (:func:`control_ncs.design_map`).

A cell's plant is the map's plant with its links replaced: a loss grid sets
a link's stationary loss (a bursty link keeps its mean burst length, so a
map over a bursty link stays bursty), and a burst grid makes the link a
Gilbert–Elliott chain of that loss and that mean burst length
(:ref:`theory-markov`); a grid of delay laws gives the sensor link each
law, scaled to the cell's loss (:ref:`theory-delays`); a grid of loss
budgets (misses, window) gives one link ``weakly_hard(misses, window)``
(:ref:`theory-worst-case`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from control.exception import ControlArgument

from ._checks import finite_real
from .automata import LossAutomaton, weakly_hard
from .delays import RandomDelay, random_delay
from .network import GilbertElliott, gilbert_elliott
from .plant import NetworkedStateSpace

__all__: list[str] = []


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


def delay_grid(values: Any, name: str) -> list[RandomDelay]:
    """A 1-D grid of delay laws (pmfs or :func:`random_delay` links)."""
    if isinstance(values, RandomDelay):
        values = [values]
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") \
            or len(values) == 0:
        raise ValueError(f"{name}: expected a non-empty list of delay laws "
                         f"(pmfs, or random_delay links), got {values!r}")
    out = []
    for i, v in enumerate(values):
        try:
            out.append(v if isinstance(v, RandomDelay) else random_delay(v))
        except (ValueError, TypeError) as err:
            raise ValueError(f"{name}[{i}]: {err}") from None
    return out


def mean_delay(link: RandomDelay) -> float:
    """The mean delay of a delivered packet, ``Σ c q_c / Σ q_c``."""
    q = np.asarray(link.pmf, float)
    return float(np.arange(q.size) @ q / q.sum())


def at_delay(link: RandomDelay, value: float) -> RandomDelay:
    """The delay law scaled to the loss ``value`` (its shape and buffer
    kept): ``q (1 - value) / Σ q``."""
    q = np.asarray(link.pmf, float)
    return random_delay(q * (1.0 - value) / q.sum(), link.buffer)


def count_grid(values: Any, name: str, least: int) -> np.ndarray:
    """A 1-D grid of integers ``>= least``."""
    arr = _grid(values, name, f"integers >= {least}")
    out = []
    for i, v in enumerate(arr):
        if isinstance(v, (bool, np.bool_)) or not isinstance(
                v, (int, np.integer)) or v < least:
            raise ValueError(f"{name}[{i}]: expected an integer >= {least}, "
                             f"got {v!r}")
        out.append(int(v))
    return np.array(out)


def budget_grid(value: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """``(misses, window)``: two 1-D grids, of losses allowed (``>= 0``)
    and of window lengths (``>= 1``)."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError(f"{name}: expected (misses, window), two grids of "
                         f"integers (losses allowed in a window, window "
                         f"lengths), got {value!r}")
    return (count_grid(value[0], f"{name} misses", 0),
            count_grid(value[1], f"{name} window", 1))


def at_budget(misses: int, window: int) -> LossAutomaton:
    """At most ``misses`` lost in any ``window``; ``misses >= window``
    allows every pattern (``weakly_hard(window, window)``)."""
    return weakly_hard(min(misses, window), window)


def _budget_cells(P: NetworkedStateSpace, a1: np.ndarray, a2: np.ndarray,
                  budgets: dict) -> tuple:
    """The cells of a map over one link's (misses, window) budget; the
    other link keeps its one given loss, the budget link's loss grid is
    not used (it must be the default 0)."""
    (link, grid), = budgets.items()
    other = "actuator" if link == "sensor" else "sensor"
    misses, windows = budget_grid(grid, f"{link}_budget")
    own, fixed = (a1, a2) if link == "sensor" else (a2, a1)
    if own.size != 1 or own[0] != 0.0:
        raise ControlArgument(
            f"{link}_loss: with {link}_budget the {link} link is the budget "
            f"of each cell; give no {link}_loss grid")
    if fixed.size != 1:
        raise ControlArgument(
            f"{other}_loss: with {link}_budget the map's axes are the "
            f"budget's misses and window; give one {other} loss, got "
            f"{fixed.size}")
    kept = at_loss(getattr(P, f"{other}_link"), float(fixed[0]))
    cells = [P.with_network(**{f"{link}_loss": at_budget(m, K),
                               f"{other}_loss": kept})
             for m in misses for K in windows]
    return ((f"{link}_misses", f"{link}_window"), (misses, windows), cells)


def map_cells(P: NetworkedStateSpace, sensor_loss: Any, actuator_loss: Any,
              sensor_burst: Any, actuator_burst: Any,
              sensor_delay: Any = None, budgets: dict | None = None
              ) -> tuple[tuple[str, str], tuple[np.ndarray, np.ndarray],
                         list[NetworkedStateSpace]]:
    """``(axes, values, cells)`` of a map, cells row-major.

    Without a burst or delay grid the axes are the two links' losses. With
    a burst grid (``sensor_burst`` or ``actuator_burst``) they are that
    link's loss and mean burst length; with ``sensor_delay`` (delay laws)
    the sensor link's loss and the laws, valued by their mean delay, each
    law scaled to the cell's loss. With ``budgets`` (``{link: (misses,
    window)}``) the axes are that link's losses allowed and window
    lengths, the cell's link ``weakly_hard(misses, window)``. The other
    link takes its one given loss.
    """
    a1 = loss_grid(sensor_loss, "sensor_loss")
    a2 = loss_grid(actuator_loss, "actuator_loss")
    if budgets:
        given = [name for name, value in (
            ("sensor_burst", sensor_burst), ("actuator_burst", actuator_burst),
            ("sensor_delay", sensor_delay)) if value is not None]
        if given or len(budgets) > 1:
            what = ", ".join(given + [f"{k}_budget" for k in budgets])
            raise ControlArgument(f"{what}: a map has two axes; a budget's "
                                  f"(misses, window) are both of them")
        return _budget_cells(P, a1, a2, budgets)
    bursts = {link: grid for link, grid in
              (("sensor", sensor_burst), ("actuator", actuator_burst))
              if grid is not None}
    if sensor_delay is not None:
        if bursts:
            raise ControlArgument(
                f"sensor_delay, {next(iter(bursts))}_burst: a map has two "
                f"axes; give one grid besides the loss")
        laws = delay_grid(sensor_delay, "sensor_delay")
        if a2.size != 1:
            raise ControlArgument(
                f"actuator_loss: with sensor_delay the map's axes are "
                f"sensor_loss and sensor_delay; give one actuator loss, got "
                f"{a2.size}")
        kept = at_loss(P.actuator_link, float(a2[0]))
        cells = [P.with_network(sensor_loss=0.0,
                                sensor_delay=at_delay(law, x),
                                actuator_loss=kept)
                 for x in a1 for law in laws]
        return (("sensor_loss", "sensor_delay"),
                (a1, np.array([mean_delay(law) for law in laws])), cells)
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
