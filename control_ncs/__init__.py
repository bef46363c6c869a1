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
from .meancov import moments, MomentsResponse
from .exceptions import CertificationError, SynthesisError, ScheduleWarning
from .verify import (Certificate, check_certificate, certified_index,
                     certify_index, certify_ofp_index, dissipation_matrices)
from .passivity import (ispassive, get_input_ff_index, get_output_fb_index,
                        mean_input_ff_index,
                        frequency_ff_index, passivity_certificate,
                        PassivityResult)
from .synthesis import passivesyn, SynthesisResult
from .responses import (simulate, SamplePaths, EnsembleResponse,
                        forced_response, step_response, impulse_response,
                        initial_response)
from .plots import plot_ensemble, schedule_plot
from .connect import jump_feedback, lift_lti, interconnect

__all__ = [
    "Schedule", "schedule", "mode_probabilities",
    "JumpStateSpace", "JumpPlant", "Modes", "jss", "lift",
    "NetworkedStateSpace", "nss", "PeriodicGain", "build", "feedback",
    "ms_radius", "is_mss", "second_moment_operator",
    "moments", "MomentsResponse",
    "Certificate", "CertificationError", "SynthesisError", "ScheduleWarning",
    "check_certificate", "certified_index", "certify_index",
    "certify_ofp_index", "dissipation_matrices",
    "ispassive", "get_input_ff_index", "get_output_fb_index",
    "mean_input_ff_index",
    "frequency_ff_index", "passivity_certificate", "PassivityResult",
    "passivesyn", "SynthesisResult",
    "simulate", "SamplePaths", "EnsembleResponse", "forced_response",
    "step_response", "impulse_response", "initial_response", "plot_ensemble",
    "jump_feedback", "lift_lti", "interconnect", "schedule_plot",
]

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("control_ncs")
except PackageNotFoundError:  # imported from a source tree without install
    __version__ = "0+unknown"
