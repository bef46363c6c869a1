"""The only code that imports cvxpy: LMIs, built and solved.

Models are built as functions of the data (cvxpy's idiom: build, then solve
in one place). Strictness margins are relative to the scale of the data, so
that a problem and its rescaled copy are treated alike
(:ref:`theory-synthesis`). Nothing here decides whether a result is *true*:
:mod:`control_ncs.verify` does that exactly.

* ``_core``: solving (statuses, options, fallback) and the compile cache;
* ``analysis``: certificates of a fixed closed loop;
* ``synthesis``: gains with their certificates;
* ``estimator``: estimator gains.
"""

from ._core import (balancing_scale, cache_clear, cache_info, CACHE_SIZE,
                    check_options, check_solver, CLARABEL_DEFAULTS,
                    COO_BACKEND, COO_FROM, data_scale, DEFAULT_MARGIN,
                    FALLBACK_SOLVER, fallback_solver, installed_solvers, solve,
                    SolveReport)
from .analysis import (AnalysisModel, QuadraticSupplyModel, SupplyModel,
                       analysis_model, quadratic_supply_model, supply_model)
from .estimator import (EstimatorModel, estimator_model,
                        markov_estimator_model)
from .synthesis import (GAINS, H2Model, HinfModel, SynthesisModel,
                        gain_kinds, h2_model, hinf_model, read_gains,
                        synthesis_model)

#: The LMI layer's interface (the package's flat namespace exports none of
#: it: ``control_ncs.lmi.solve`` and so on).
__all__ = [
    "AnalysisModel",
    "CACHE_SIZE",
    "CLARABEL_DEFAULTS",
    "COO_BACKEND",
    "COO_FROM",
    "DEFAULT_MARGIN",
    "EstimatorModel",
    "QuadraticSupplyModel",
    "H2Model",
    "HinfModel",
    "FALLBACK_SOLVER",
    "GAINS",
    "SolveReport",
    "SupplyModel",
    "SynthesisModel",
    "analysis_model",
    "balancing_scale",
    "cache_clear",
    "cache_info",
    "check_options",
    "check_solver",
    "data_scale",
    "estimator_model",
    "quadratic_supply_model",
    "h2_model",
    "hinf_model",
    "fallback_solver",
    "gain_kinds",
    "installed_solvers",
    "markov_estimator_model",
    "read_gains",
    "solve",
    "supply_model",
    "synthesis_model",
]
