"""Errors raised when nothing can be certified, and their named reasons.

Every :class:`CertificationError` (and :class:`SynthesisError`) carries a
``reason``, one of the constants below (one word per case), and the
``figures`` that were measured. Both survive pickling, so an error raised in
a worker process (``concurrent.futures.ProcessPoolExecutor``) reaches the
caller intact.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CertificationError", "SynthesisError", "ScheduleWarning",
           "NotPassiveWarning"]

#: A certificate passed the exact checks (a verdict, never an error reason).
CERTIFIED = "certified"
#: Not mean-square stable (``ms_radius ≥ 1``, or ``≥ r²`` with a decay
#: bound ``r``): no certificate, no index exists.
NOT_MSS = "not_mss"
#: A necessary feedthrough condition fails (theory: passivity, e.g.
#: ``D̄ + D̄ᵀ ⊁ 2ηI``).
FEEDTHROUGH = "feedthrough"
#: Proven: no certificate exists (an exact LMI with its margin is
#: infeasible, a Riccati iteration diverged, a KYP frequency refutes the
#: level, or states no input reaches are too slow on their own).
INFEASIBLE = "infeasible"
#: A sufficient (conservative) condition has no solution: a structured or
#: phase-common gain, a hold actuator, the predictor or the estimator
#: controller, where the LMI is not necessary. Nothing is proven about
#: whether a gain exists.
SUFFICIENT_FAILED = "sufficient_failed"
#: A local search (the refinement) found no certified answer within its
#: starts, iterations or time: nothing is proven either way.
NOT_FOUND = "not_found"
#: Certified, but the certified level is an input-feedforward *shortage*
#: (``η < 0``): mean-square stable and dissipative, not passive.
CERTIFIED_SHORTAGE = "certified_shortage"
#: The solver (or an iteration) failed or was inconclusive.
SOLVER_FAILED = "solver_failed"
#: The solver's status stayed inaccurate.
INACCURATE = "inaccurate"
#: The answer found fails the exact checks of :mod:`control_ncs.verify`.
NOT_VERIFIED = "not_verified"
#: The time budget ran out (between attempts, or the solver's own limit).
TIME_LIMIT = "time_limit"

#: Every reason an error may carry.
REASONS = (NOT_MSS, FEEDTHROUGH, INFEASIBLE, SUFFICIENT_FAILED, NOT_FOUND,
           SOLVER_FAILED, INACCURATE, NOT_VERIFIED, TIME_LIMIT)

#: Reasons that prove no certificate (no gain) exists at the level asked;
#: every other reason leaves the question open.
PROOFS = (NOT_MSS, FEEDTHROUGH, INFEASIBLE)

#: One sentence per verdict, the ``message`` of a result with that ``status``.
MESSAGES = {
    CERTIFIED: "certified: a certificate passed the exact checks",
    NOT_MSS: "not mean-square stable: no certificate, no index exists",
    FEEDTHROUGH: "a necessary feedthrough condition fails: no certificate "
                 "exists at this level",
    CERTIFIED_SHORTAGE: "certified, but not passive: mean-square stable and "
                        "dissipative with an input-feedforward shortage "
                        "(eta < 0)",
    INFEASIBLE: "proven: no certificate exists at this level",
    SUFFICIENT_FAILED: "a sufficient condition has no solution: nothing is "
                       "proven about whether a certificate exists",
    NOT_FOUND: "no certified answer was found within the search's limits "
               "(a local method): nothing is proven either way",
    SOLVER_FAILED: "the solver failed or was inconclusive: nothing is "
                   "proven either way",
    INACCURATE: "the solver's answer stayed inaccurate and no certificate "
                "passed the exact checks: nothing is proven either way",
    NOT_VERIFIED: "the answer found fails the exact checks: nothing is "
                  "proven either way",
    TIME_LIMIT: "the time limit was reached: nothing is proven either way",
}


class ScheduleWarning(UserWarning):
    """A schedule never lets some sensor or actuator send.

    Raised as a warning (``warnings.warn``), not an error: a node that never
    sends may be intended, but an index vector such as ``[0, 1, 2, 3]``
    reads ``0`` as "nobody", so with four sensors sensor 4 never sends.
    Silence it with :func:`warnings.filterwarnings` on this class.

    Parameters
    ----------
    message : str
        Names the schedule and the nodes that never send.

    Examples
    --------
    >>> import warnings
    >>> issubclass(ncs.ScheduleWarning, UserWarning)
    True
    """

    def __init__(self, message: str) -> None:
        super().__init__(message)


class NotPassiveWarning(UserWarning):
    """A certified design is not passive: its level ``η`` is negative.

    :func:`control_ncs.passivesyn` maximises ``η``; when the best level it
    certifies is negative, the loop is mean-square stable and dissipative
    with an input-feedforward shortage ``|η|``, which is a true statement,
    but not passivity. The warning says what would help.

    Parameters
    ----------
    message : str
        The certified level and what would help.

    Examples
    --------
    >>> issubclass(ncs.NotPassiveWarning, UserWarning)
    True
    """

    def __init__(self, message: str) -> None:
        super().__init__(message)


class CertificationError(RuntimeError):
    """A passivity or stability result could not be certified.

    Parameters
    ----------
    message : str
    reason : str
        One of :data:`REASONS`: ``'not_mss'``, ``'feedthrough'`` and
        ``'infeasible'`` are proofs that nothing can be certified;
        ``'sufficient_failed'`` (a conservative condition failed),
        ``'not_found'`` (a local search ran out), ``'solver_failed'``,
        ``'inaccurate'``, ``'not_verified'`` and ``'time_limit'`` leave the
        question open.
    figures : dict, optional
        Whatever was measured (solver status, eigenvalues, ``ms_radius``).

    Attributes
    ----------
    reason : str
    figures : dict

    Examples
    --------
    >>> import pickle
    >>> err = ncs.CertificationError("no certificate", "not_mss",
    ...                              {"ms_radius": 1.2})
    >>> again = pickle.loads(pickle.dumps(err))
    >>> again.reason, again.figures
    ('not_mss', {'ms_radius': 1.2})
    """

    def __init__(self, message: str, reason: str,
                 figures: dict | None = None) -> None:
        super().__init__(message)
        self.reason = reason
        self.figures = dict(figures or {})

    def __reduce__(self) -> tuple[Any, ...]:
        # BaseException pickles as cls(*self.args), and args holds only the
        # message: without this, unpickling calls __init__ without `reason`
        # and fails (e.g. in a ProcessPoolExecutor's result queue).
        return (type(self), (str(self), self.reason, self.figures),
                self.__dict__)


class SynthesisError(CertificationError):
    """:func:`control_ncs.passivesyn` found no gain it could certify.

    A :class:`CertificationError`: ``except CertificationError`` catches it.

    Parameters
    ----------
    message : str
    reason : str
        One of :data:`REASONS`.
    figures : dict, optional
        Whatever was measured (solver status, eigenvalues, ``ms_radius``).

    Attributes
    ----------
    reason : str
    figures : dict

    Examples
    --------
    >>> err = ncs.SynthesisError("no gain", "infeasible",
    ...                          {"status": "infeasible"})
    >>> isinstance(err, ncs.CertificationError), err.reason
    (True, 'infeasible')
    """
