"""control_ncs: networked control systems for python-control.

A plant talks to its controller over a shared, lossy, scheduled network;
the closed loop is a periodic jump linear system. See ``../README.md`` and
the mathematics in ``docs/`` (MATH §-references in docstrings).
"""

from .network import Schedule, schedule, mode_probabilities
from .jump import JumpStateSpace, JumpPlant, Modes, jss, lift
from .plant import NetworkedStateSpace, nss
from .gain import PeriodicGain
from .strategies import build, feedback
from .stability import ms_radius, is_mss, second_moment_operator
from .moments import moments, MomentsResponse

__all__ = [
    "Schedule", "schedule", "mode_probabilities",
    "JumpStateSpace", "JumpPlant", "Modes", "jss", "lift",
    "NetworkedStateSpace", "nss", "PeriodicGain", "build", "feedback",
    "ms_radius", "is_mss", "second_moment_operator",
    "moments", "MomentsResponse",
]

__version__ = "0.1.0"
