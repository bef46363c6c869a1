"""One cell of a sweep: a design run in a thread of its own, by passivesyn,
h2syn or hinfsyn, reported as plain numbers (:mod:`control_ncs.sweeps`).

Each cell is a module-level function, so that a process pool (or a Dask
cluster) can pickle it; :func:`design_cells` runs a list of them in the two passes
of ``method='auto'``.
"""

from __future__ import annotations

import math
import threading
import warnings
from concurrent.futures import Executor
from typing import Any, Callable, Mapping

from .exceptions import (PROOFS, TIME_LIMIT, CertificationError,
                         NotPassiveWarning, ScheduleWarning, SynthesisError)
from .synthesis import h2syn, hinfsyn
from .plant import NetworkedStateSpace
from .stability import ms_radius as _ms_radius
from .strategies import build
from .synthesis import passivesyn
from .synthesis._options import resolved_options
from .synthesis.norms import DEFAULTS as NORM_OPTIONS, _not_exact
from .synthesis.passive import DEFAULTS as PASSIVE_OPTIONS
from ._tasks import run_tasks

__all__: list[str] = []


def sweep_options(who: str, objective: str,
                   options: Mapping[str, Any] | None) -> dict | None:
    """A sweep's ``options``, checked once before any cell runs against
    the keys of the cells' design (its values are checked by the design,
    in the first cell)."""
    if options is None:
        return None
    passive = objective in ("eta", "rate")
    resolved_options(who, options, {}, PASSIVE_OPTIONS if passive
                     else NORM_OPTIONS)
    given = dict(options)
    if "solver_options" in given:
        given["solver_options"] = dict(given["solver_options"])
    return given


def in_own_thread(func: Callable, *args: Any) -> Any:
    """``func(*args)`` in a thread of its own, its exception re-raised here.

    The compiled LMIs are cached per thread (``lmi/_core.py``), and a solve
    through a freshly compiled problem and one through a cached compilation
    differ in the last bits (measured: 4e-11 relative in η). A new thread
    starts with an empty cache, so every cell is computed the same way
    whichever worker runs it and whatever it ran before: the results do not
    depend on the executor.
    """
    box: dict = {}

    def target() -> None:
        try:
            box["value"] = func(*args)
        except BaseException as err:  # re-raised in the caller's thread
            box["error"] = err

    worker = threading.Thread(target=target, name="control_ncs-sweep",
                              daemon=True)
    worker.start()
    worker.join()
    if "error" in box:
        raise box["error"]
    return box["value"]


#: The options a cell searched locally takes (the others are the exact
#: program's or the LMI's: a sweep gives them to the cells that solve one).
LOCAL_OPTIONS = ("time_limit", "margin")


def synthesise(P: NetworkedStateSpace, eta: float | None,
                decay: float | None, controller: str, actuator: str,
                method: str = "lmi", initial_gain: Any = None,
                options: dict | None = None) -> tuple:
    """One cell: ``(eta, ms_radius, feasible, reason, gains, exact)`` from
    passivesyn (``gains`` None where nothing is certified; ``exact``: the
    certified level is the best of its kind).

    Module level, so that a process pool or a Dask worker can unpickle it;
    run in its own thread (:func:`in_own_thread`).
    """
    return in_own_thread(_synthesise_here, P, eta, decay, controller,
                          actuator, method, initial_gain, options)


def perform(P: NetworkedStateSpace, objective: str,
             controller: str = "static", actuator: str = "zero",
             options: dict | None = None) -> tuple:
    """One cell of an H2 or H∞ map: ``(value, ms_radius, feasible, reason,
    gains, exact)`` from h2syn or hinfsyn, the value the exact analysis of
    the designed loop (never the solver's). Module level and in its own
    thread, as :func:`synthesise`."""
    return in_own_thread(_perform_here, P, objective, controller, actuator,
                         options)


def _perform_here(P: NetworkedStateSpace, objective: str,
                  controller: str = "static", actuator: str = "zero",
                  options: dict | None = None) -> tuple:
    design = h2syn if objective == "h2" else hinfsyn
    if options and not _exact_program(P, controller, actuator):
        options = _local_options(options)
    try:
        with warnings.catch_warnings():
            # a search enumerates schedules that leave nodes silent on
            # purpose; the warning is for schedules a user writes
            warnings.simplefilter("ignore", ScheduleWarning)
            K, CL, value = design(P, controller=controller,
                                  actuator=actuator, options=options)
    except CertificationError as err:
        return math.nan, math.nan, False, err.reason, None, False
    # "exact": the program's global optimum, not a local search's
    return (float(value), float(_ms_radius(CL)), True, "certified", K.gains,
            K.result.route == "program")


def _local_options(options: dict) -> dict:
    """The options a local search takes, of a sweep's."""
    return {k: v for k, v in options.items() if k in LOCAL_OPTIONS}


def _exact_program(P: NetworkedStateSpace, controller: str,
                   actuator: str) -> bool:
    """Whether h2syn / hinfsyn design this cell by their exact program
    (else by a local search, which takes no solver options)."""
    try:
        plant = build(P, controller, actuator)
    except (ValueError, TypeError):     # the design itself will say why
        return True
    return _not_exact(P, plant, controller, actuator, "design") is None


def _local_only(P: NetworkedStateSpace, controller: str,
                actuator: str) -> bool:
    """Whether a cell's loop reads a different measurement in each mode
    (:attr:`JumpPlant.reads_per_mode`): no synthesis LMI expresses it, so
    passivesyn searches it locally, with no method and no start from other
    cells."""
    try:
        return build(P, controller, actuator).reads_per_mode
    except (ValueError, TypeError):     # passivesyn itself will say why
        return False


def _synthesise_here(P: NetworkedStateSpace, eta: float | None,
                     decay: float | None, controller: str, actuator: str,
                     method: str = "lmi", initial_gain: Any = None,
                     options: dict | None = None) -> tuple:
    local = _local_only(P, controller, actuator)
    keywords = dict(options=_local_options(options or {})) if local else \
        dict(method=method, initial_gain=initial_gain, options=options)
    try:
        with warnings.catch_warnings():
            # a map shows negative levels as they are; one warning per cell
            # would only repeat the colour scale
            warnings.simplefilter("ignore", NotPassiveWarning)
            K, _, eta_c = passivesyn(P, eta, decay=decay,
                                     controller=controller,
                                     actuator=actuator, **keywords)
    except SynthesisError as err:
        return math.nan, math.nan, False, err.reason, None, False
    gains = K.gains if K.gains.ndim == 3 else None    # per phase: a start
    # the certificate's ms_radius is the exact one of the returned loop
    if local:           # the local search's certificate; no LMI to share
        return (float(eta_c), float(K.result.ms_radius), True, "certified",
                None, False)
    return (float(eta_c), float(K.result.ms_radius), True, "certified",
            gains, K.result.exact)


def design_cells(tasks: list, method: str, executor: Executor | None,
           progress: bool, desc: str, neighbours: Callable | None = None,
           options: dict | None = None) -> list:
    """Every cell designed with ``method``.

    ``'auto'`` in two passes, so that a sweep costs little more than its
    LMIs: every cell by the LMI first (exact where it can be, fast
    everywhere); then every cell where the LMI is only sufficient and no
    proof settled it is refined, started from its own certified LMI gain,
    else from the certified gain of its nearest certified neighbour
    (``neighbours(i)``: cell indices, nearest first), so that the LMI is
    not solved twice; a cell without any start runs passivesyn's own
    'auto'. The better certified level of the two passes is kept. The
    second pass reads only the first pass's results, so the result does not
    depend on the executor or on the order in which cells finish.
    ``options`` are passivesyn's, given to every cell (a cell searched
    locally takes only ``LOCAL_OPTIONS``).
    """
    first = "lmi" if method == "auto" else method
    out = run_tasks(synthesise, [t + (first, None, options) for t in tasks],
                    executor, progress, desc)
    if method != "auto":
        return out
    # a cell read per mode already ran its local search (no LMI applies)
    todo = [i for i, r in enumerate(out)
            if not _local_only(tasks[i][0], tasks[i][3], tasks[i][4]) and (
                (r[2] and not r[5])
                or (not r[2] and r[3] not in PROOFS + (TIME_LIMIT,)))]
    starts = []
    for i in todo:
        near = [i] + (neighbours(i) if neighbours is not None else [])
        starts.append(next((out[j][4] for j in near
                            if out[j][2] and out[j][4] is not None), None))
    again = run_tasks(synthesise, [tasks[i] + ("auto", s, options)
                               for i, s in zip(todo, starts)],
                 executor, progress, desc)
    for i, r in zip(todo, again):
        if r[2] and (not out[i][2] or r[0] > out[i][0]):
            out[i] = r
    return out


