"""Running many independent tasks: executors and the one progress policy.

Sweeps and simulations run many independent pieces of work (cells of a
map, schedules of a search, chunks of sample paths). They run here, on any
``concurrent.futures.Executor`` (a thread or process pool, a Dask
``client.get_executor()``) or sequentially, with results placed by index so
that the order of completion never shows.

Progress bars follow one policy: ``progress=True`` shows one (and needs the
optional ``tqdm``: a clear ImportError otherwise), ``False`` never, and
``None`` (the default of the long jobs) shows one only where a person is
watching: an interactive terminal or a Jupyter kernel, with tqdm
installed. Scripts, logs and CI runs stay quiet.
"""

from __future__ import annotations

import contextlib
import functools
import sys
from concurrent.futures import Executor, as_completed
from typing import Any, Callable

import numpy as np
from control.exception import ControlArgument


@functools.cache
def tqdm_check() -> bool:
    """True when the optional package ``tqdm`` (progress bars) is installed.

    Cached: the import is tried once per process.

    Returns
    -------
    bool

    Examples
    --------
    >>> from control_ncs._tasks import tqdm_check
    >>> import importlib.util
    >>> tqdm_check() == (importlib.util.find_spec("tqdm") is not None)
    True
    """
    try:
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def _watched() -> bool:
    """True where a person watches the output: a terminal or a notebook."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    if type(shell).__name__ == "ZMQInteractiveShell":      # a Jupyter kernel
        return True
    stream = sys.stderr
    return bool(getattr(stream, "isatty", lambda: False)())


def progress_check(progress: Any) -> bool:
    """``progress`` (True, False or None: where watched) as a bool.

    Checked before any work is done: anything else is a ControlArgument,
    and True without tqdm an ImportError naming the package.
    """
    if progress is None:
        return tqdm_check() and _watched()
    if not isinstance(progress, (bool, np.bool_)):
        raise ControlArgument(f"progress: expected True, False or None, got "
                              f"{progress!r}")
    if progress and not tqdm_check():
        raise ImportError("progress=True needs the optional package tqdm: "
                          "pip install tqdm (or control_ncs[progress])")
    return bool(progress)


def progress_bar(show: bool, total: int, desc: str, unit: str = "it"):
    """A tqdm bar of ``total`` steps when ``show``, else a null context."""
    if not show:
        return contextlib.nullcontext(None)
    from tqdm.auto import tqdm
    return tqdm(total=total, desc=desc, unit=unit)


def check_executor(executor: Any) -> Executor | None:
    """``executor`` as given, or a ControlArgument naming what it accepts."""
    if executor is not None and not isinstance(executor, Executor):
        raise ControlArgument(
            f"executor: expected None or a concurrent.futures.Executor (a "
            f"ThreadPoolExecutor, ProcessPoolExecutor or a Dask "
            f"client.get_executor()), got {type(executor).__name__}")
    return executor


def run_tasks(func: Callable, tasks: list, executor: Executor | None,
              show: bool, desc: str) -> list:
    """``[func(*t) for t in tasks]``, sequentially or on ``executor``.

    Results are placed by index, so the order of completion never shows.
    On any exception (KeyboardInterrupt included) pending futures are
    cancelled before it propagates.
    """
    results: list = [None] * len(tasks)
    with progress_bar(show and len(tasks) > 1, len(tasks), desc) as bar:
        if executor is None:
            for i, args in enumerate(tasks):
                results[i] = func(*args)
                if bar is not None:
                    bar.update()
            return results
        futures = {}
        try:
            for i, args in enumerate(tasks):
                futures[executor.submit(func, *args)] = i
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                if bar is not None:
                    bar.update()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
        return results
