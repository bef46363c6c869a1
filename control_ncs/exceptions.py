"""Errors raised when nothing can be certified, and their named reasons.

Every :class:`CertificationError` (and :class:`SynthesisError`) carries a
``reason``, one of the constants below (one word per case), and the
``figures`` that were measured. Both survive pickling, so an error raised in
a worker process (``concurrent.futures.ProcessPoolExecutor``) reaches the
caller intact.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CertificationError", "SynthesisError", "ScheduleWarning"]

#: A certificate passed the exact checks (a verdict, never an error reason).
CERTIFIED = "certified"
#: Not mean-square stable (``ms_radius ≥ 1``, or ``≥ r²`` with a decay
#: bound ``r``): no certificate, no index exists.
NOT_MSS = "not_mss"
#: A necessary feedthrough condition fails (theory: passivity, e.g.
#: ``D̄ + D̄ᵀ ⊁ 2ηI``).
FEEDTHROUGH = "feedthrough"
#: Proven: no certificate exists (the LMI with its margin is infeasible, a
#: Riccati iteration diverged, or a KYP frequency refutes the level).
INFEASIBLE = "infeasible"
#: The solver (or an iteration) failed or was inconclusive.
SOLVER_FAILED = "solver_failed"
#: The solver's status stayed inaccurate.
INACCURATE = "inaccurate"
#: The answer found fails the exact checks of :mod:`control_ncs.verify`.
NOT_VERIFIED = "not_verified"
#: The time budget ran out (between attempts, or the solver's own limit).
TIME_LIMIT = "time_limit"

#: Every reason an error may carry.
REASONS = (NOT_MSS, FEEDTHROUGH, INFEASIBLE, SOLVER_FAILED, INACCURATE,
           NOT_VERIFIED, TIME_LIMIT)

#: One sentence per verdict, the ``message`` of a result with that ``status``.
MESSAGES = {
    CERTIFIED: "certified: a certificate passed the exact checks",
    NOT_MSS: "not mean-square stable: no certificate, no index exists",
    FEEDTHROUGH: "a necessary feedthrough condition fails: no certificate "
                 "exists at this level",
    INFEASIBLE: "proven: no certificate exists at this level",
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
    >>> issubclass(ScheduleWarning, UserWarning)
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
        One of :data:`REASONS`: ``'not_mss'``, ``'feedthrough'``,
        ``'infeasible'``, ``'solver_failed'``, ``'inaccurate'``,
        ``'not_verified'``, ``'time_limit'``.
    figures : dict, optional
        Whatever was measured (solver status, eigenvalues, ``ms_radius``).

    Attributes
    ----------
    reason : str
    figures : dict

    Examples
    --------
    >>> import pickle
    >>> err = CertificationError("no certificate", NOT_MSS, {"ms_radius": 1.2})
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
    >>> err = SynthesisError("no gain", INFEASIBLE, {"status": "infeasible"})
    >>> isinstance(err, CertificationError), err.reason
    (True, 'infeasible')
    """
