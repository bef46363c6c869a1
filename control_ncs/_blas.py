"""One BLAS thread for the iterative second-moment kernels.

The kernels of :mod:`control_ncs.stability` and :mod:`control_ncs.meancov`
apply the second-moment map by sequences of small and medium matrix
products (ARPACK, GMRES, the probes' residuals, the moment recursion).
OpenBLAS runs each product above ``m·n·k = 2**18`` on all its threads and
waits for every thread at its end; on a machine whose cores are busy with
other work a product then stalls for whole scheduler slices, and a call
that takes 2.7 s on one thread took 22–46 s with the default threads
(``ms_radius``, n = 200, N = 10, 2 cores; docs/benchmarks.md measures both
ways). :func:`serial_blas` runs a block on one BLAS thread and restores the
previous thread counts when the outermost block exits, also on an exception,
so the process's BLAS state is never left changed.

The limit is process-wide (BLAS has no per-thread setting), and only the
main thread sets it: OpenBLAS 0.3.30 ignores ``openblas_set_num_threads``
called from any other thread, and older releases would apply it process-wide
from whichever thread called, so that two threads entering and leaving in
turn could restore each other's limit. Blocks nest; the outermost one in the
main thread sets the limit and restores the saved counts. A kernel run in
another thread (a thread pool of the caller's) runs on the BLAS's threads,
or on one if the main thread has a block open.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Any, Iterator

__all__: list[str] = []

#: The iterative kernels run on one BLAS thread from this state dimension
#: on (below it every product is under OpenBLAS's threading threshold,
#: ``n³ < 2**18``, and the ~10 µs of switching would be the only effect).
#: Set to a huge value to run them on the BLAS's default threads (the
#: benchmark measures both ways).
SERIAL_MIN_STATES = 48

_lock = threading.Lock()
_open = 0
_saved: list[tuple[Any, int]] = []
_libraries: list[Any] | None = None


def _blas_libraries() -> list[Any]:
    """The loaded BLAS libraries' controllers (threadpoolctl), found once."""
    global _libraries
    if _libraries is None:
        from threadpoolctl import (  # type: ignore[import-untyped]
            ThreadpoolController)
        _libraries = [lib for lib in ThreadpoolController().lib_controllers
                      if lib.user_api == "blas"]
    return _libraries


@contextmanager
def serial_blas(states: int = SERIAL_MIN_STATES) -> Iterator[None]:
    """Run the block on one BLAS thread when ``states`` (the kernel's
    state dimension) is at least :data:`SERIAL_MIN_STATES` and this is the
    main thread; the outermost block restores the thread counts on exit."""
    global _open
    if states < SERIAL_MIN_STATES or \
            threading.current_thread() is not threading.main_thread():
        yield
        return
    with _lock:
        if _open == 0:
            _saved.clear()
            for lib in _blas_libraries():
                count = lib.get_num_threads()
                _saved.append((lib, count))
                if count != 1:
                    lib.set_num_threads(1)
        _open += 1
    try:
        yield
    finally:
        with _lock:
            _open -= 1
            if _open == 0:
                for lib, count in _saved:
                    if count != 1:
                        lib.set_num_threads(count)
                _saved.clear()
