"""control_ncs: networked control systems for python-control.

A plant talks to its controller over a shared, lossy, scheduled network;
the closed loop is a periodic jump linear system. The package models it
(:func:`nss`, :func:`feedback`, :func:`jss`), analyses it exactly
(:func:`ms_radius`, :func:`moments`, :func:`ispassive`, :func:`simulate`) and
designs verified passive controllers (:func:`passivesyn`). See the README and
the theory pages in ``docs/``.

The public names are those of the modules below, each owning one idea; the
package's ``__all__`` is the union of theirs less the exact checks and
kernels that a design or an analysis runs for the user (``verify``'s
certificate checks, the second-moment operator, the network's mode chain,
a graph's lift): those are documented and imported from their module,
``control_ncs.verify.check_certificate`` for instance. Engine modules
(``lmi``, ``riccati``, ``kyp``, ``driver``, ``montecarlo``) and the
independent reference simulator (``protocol``) export nothing here.
"""

from importlib.metadata import PackageNotFoundError, version as _version
from typing import Any as _Any

from . import (automata, budgets, connect, constrained, critical, delays,
               estimation, estimator, exceptions, gain, intersample,
               joint_spectral, jump, loop, lq, meancov, modes,
               network, openloop, passivity, performance, plant, plots,
               responses, stability, stationary, strategies, sweeps, switching,
               synthesis,
               verify, worstcase, worstcase_synthesis)
from ._lifting import lift
from .automata import *  # noqa: F403
from .budgets import *  # noqa: F403
from .constrained import *  # noqa: F403
from .connect import *  # noqa: F403
from .critical import *  # noqa: F403
from .delays import *  # noqa: F403
from .estimation import *  # noqa: F403
from .estimator import *  # noqa: F403
from .exceptions import *  # noqa: F403
from .gain import *  # noqa: F403
from .intersample import *  # noqa: F403
from .joint_spectral import *  # noqa: F403
from .jump import *  # noqa: F403
from .loop import *  # noqa: F403
from .lq import *  # noqa: F403
from .meancov import *  # noqa: F403
from .modes import *  # noqa: F403
from .network import *  # noqa: F403
from .openloop import *  # noqa: F403
from .passivity import *  # noqa: F403
from .performance import *  # noqa: F403
from .plant import *  # noqa: F403
from .plots import *  # noqa: F403
from .responses import *  # noqa: F403
from .stability import *  # noqa: F403
from .stationary import *  # noqa: F403
from .strategies import *  # noqa: F403
from .sweeps import *  # noqa: F403
from .switching import *  # noqa: F403
from .synthesis import *  # noqa: F403
from .verify import *  # noqa: F403
from .worstcase import *  # noqa: F403
from .worstcase_synthesis import *  # noqa: F403

#: Public in their module, not at the top level: the exact checks and
#: kernels the analyses and designs run for the user.
_IN_SUBMODULE = {name: module.__name__ for module, names in (
    (verify, verify.__all__),
    (stability, ["second_moment_operator"]),
    (strategies, ["require_state_measured"]),
    (network, ["mode_transition"]),
    (switching, ["GraphLift"]),
) for name in names}

__all__ = [name for module in (
    network, delays, modes, jump, openloop, plant, gain, strategies, loop,
    stability, stationary,
    meancov, exceptions, verify, passivity, performance, lq, synthesis,
    estimator, responses, plots,
    connect, sweeps, critical, automata, joint_spectral, switching,
    worstcase, worstcase_synthesis, intersample, estimation, constrained,
    budgets)
    for name in module.__all__ if name not in _IN_SUBMODULE] + ["lift"]

for _name in _IN_SUBMODULE:
    del globals()[_name]


def __getattr__(name: str) -> _Any:
    """Resolve a name that lives in its submodule (earlier code's spelling).

    ``control_ncs.check_certificate`` keeps working as
    ``control_ncs.verify.check_certificate``, with a
    :class:`DeprecationWarning` naming the submodule; it is not listed in
    ``__all__`` or ``dir(control_ncs)``.
    """
    if name in _IN_SUBMODULE:
        import importlib
        import warnings
        where = _IN_SUBMODULE[name]
        warnings.warn(f"control_ncs.{name} is deprecated: it lives in its "
                      f"module, {where}.{name}", DeprecationWarning,
                      stacklevel=2)
        return getattr(importlib.import_module(where), name)
    raise AttributeError(f"module 'control_ncs' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) - set(_IN_SUBMODULE))


try:
    __version__ = _version("control_ncs")
except PackageNotFoundError:  # imported from a source tree without install
    __version__ = "0+unknown"
