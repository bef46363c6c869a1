"""The one solve-and-verify loop: retries, back-off, fallback, verdict.

An LMI answer is a candidate, never a result: :func:`drive` asks a caller's
``attempt(scale, target, solver, time_left)`` to build and solve the model
for a margin scale and a target ``η`` (None: maximised) and to read a
candidate from it, asks ``verify(candidate)`` for the exact certificate,
and decides the next attempt. The strictness, back-off and fallback rules,
and the classification of a failure into one of the named reasons
(``'infeasible'``, ``'solver_failed'``, ``'inaccurate'``,
``'not_verified'``, ``'time_limit'``), live here and nowhere else;
:func:`control_ncs.passivesyn` uses it, and an analysis retry loop (a
certificate ``P`` for a given system) fits the same two callbacks.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any, Callable


from .exceptions import (INACCURATE, INFEASIBLE, NOT_VERIFIED,
                         SOLVER_FAILED, TIME_LIMIT)
from .lmi import SolveReport, fallback_solver

#: The solver's word for a proven-infeasible problem (cvxpy's status string).
SOLVER_INFEASIBLE = "infeasible"

__all__: list[str] = []

_log = logging.getLogger("control_ncs")

#: (margin multiplier, relative back-off of η): a maximum sits on the boundary,
#: where answers are least accurate, so retries solve a little below it.
RETRIES = ((1.0, 0.0), (1.0, 1e-3), (1e2, 1e-2))


@dataclass
class Outcome:
    """What :func:`drive` found.

    Attributes
    ----------
    candidate : object or None
        The verified candidate (None on failure).
    certificate : object or None
        Its certificate (or, on failure, the last refused one).
    report : SolveReport or None
        The solve that produced it (on failure, the one that says why).
    eta_solver : float or None
        The first solve's optimum (``η`` maximised), or the target.
    attempts : list of SolveReport
    reason : str or None
        On failure: ``'infeasible'``, ``'solver_failed'``, ``'inaccurate'``,
        ``'not_verified'`` or ``'time_limit'``.
    message : str
        On failure, what happened, for humans.
    """

    candidate: Any = None
    certificate: Any = None
    report: SolveReport | None = None
    eta_solver: float | None = None
    attempts: list = field(default_factory=list)
    reason: str | None = None
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.reason is None

    def figures(self) -> dict:
        """The figures a :class:`~control_ncs.exceptions.SynthesisError` carries."""
        report = self.report or (self.attempts[-1] if self.attempts else None)
        out: dict[str, Any] = dict(statuses=[a.status for a in self.attempts])
        if report is not None:
            out.update(status=report.status, solver=report.solver)
        if self.certificate is not None:
            out.update(self.certificate.figures())
        return out


def drive(attempt: Callable[[float, float | None, str | None, float | None],
                            tuple[SolveReport, Any]],
          verify: Callable[[Any], Any], *, eta: float | None,
          solver: str | None, deadline: float | None = None,
          retries: tuple = RETRIES, fallback: tuple = (1.0, 0.0),
          refute_margins: bool = False, spare: bool = True,
          label: str = "LMI") -> Outcome:
    """Solve, read, verify and retry until a candidate passes the exact check.

    Parameters
    ----------
    attempt : callable
        ``attempt(scale, target, solver, time_left) -> (report, candidate)``:
        build the model with the margin multiplied by ``scale`` and ``η``
        fixed at ``target`` (None: maximised), solve it with ``solver``
        (None: the default) within ``time_left`` seconds (None: no limit),
        and read a candidate (None when the status gives no answer).
    verify : callable
        ``verify(candidate) -> certificate`` with ``.verified``,
        ``.failures`` and ``.figures()``: the exact check.
    eta : float or None
        The requested ``η`` (None: maximised).
    solver : str or None
        The caller's solver; None lets the fallback solver be asked once.
    deadline : float, optional
        ``time.perf_counter()`` value after which no attempt starts.
    retries : tuple of (float, float)
        (margin multiplier, relative back-off of ``η``), in turn. The
        multiplier is passed to ``attempt`` as is (an analysis may use
        None for "margin maximised").
    fallback : (float, float)
        The attempt asked of ``lmi.FALLBACK_SOLVER`` (only when ``solver``
        is None): by default the problem as posed.
    refute_margins : bool
        For a fixed ``eta`` (an analysis): an exact 'infeasible' at any
        margin also rules out every larger one, so the remaining attempts
        with a numeric margin are skipped (those with None, margin
        maximised, still run). The reason is 'infeasible' when nothing
        verifies afterwards. A maximised margin that is not positive refutes
        nothing (it is the solver's number, within its tolerance of 0). Without it only the problem as
        posed (margin 1, the requested ``eta``) proves infeasibility.
    spare : bool
        Keep a verified candidate of an inaccurate solve, returned only
        when no accurate one verifies (synthesis). False: for a fixed
        ``eta`` such a candidate is returned at once (the exact check is
        the proof), for a maximised index it is refused (an index also
        claims optimality, which needs 'optimal').
    label : str
        Named in progress messages (logger ``'control_ncs'``, level INFO).

    Returns
    -------
    Outcome
    """
    out = Outcome()
    tried = set()
    best = None
    # a verified gain from an inaccurate solve: returned only when no
    # accurate answer verifies (the gain is proved; its η may lie further
    # below the supremum)
    kept = None
    plan = [(scale, backoff, solver) for scale, backoff in retries]
    if fallback_solver(solver):
        plan.append((*fallback, fallback_solver(solver)))
    refute = refute_margins and eta is not None
    refuted = None  # the report that refuted the level (refute_margins)
    for scale, backoff, name in plan:
        if refuted is not None and scale is not None:
            continue  # a larger margin is infeasible too
        target = eta
        if eta is None and backoff:
            if best is None:
                continue  # the first solve gave no optimum to back off from
            target = best - backoff * max(1.0, abs(best))
        if (scale, target, name) in tried:
            continue  # a fixed η has nothing to back off from
        tried.add((scale, target, name))
        left = None if deadline is None else deadline - time.perf_counter()
        if left is not None and left <= 0:
            out.reason = TIME_LIMIT
            out.message = "the time limit was reached between attempts"
            return out
        original = scale == 1.0 and target == eta
        _log.info("%s attempt %d: solver %s, margin x%g, eta %s", label,
                  len(out.attempts) + 1, name or "default", scale,
                  "max" if target is None else f"{target:.6g}")
        report, candidate = attempt(scale, target, name, left)
        out.attempts.append(report)
        if original and best is None and eta is None:
            best = report.value
        if report.status == TIME_LIMIT:
            out.reason, out.report = TIME_LIMIT, report
            out.message = f"solver {report.solver} reached the time limit"
            return out
        if report.status == SOLVER_INFEASIBLE and refute:
            refuted = report
            continue
        if report.status == SOLVER_INFEASIBLE and original:
            out.reason, out.report = INFEASIBLE, report
            out.message = (f"the LMI is infeasible (solver {report.solver}, "
                           f"status {report.status!r})")
            return out
        # A maximised margin that comes out <= 0 is the solver's number,
        # within its tolerance of 0 near the index: no proof (its candidate
        # is checked like any other below).
        if candidate is None:
            continue
        cert = verify(candidate)
        out.certificate, out.report = cert, report
        if cert.verified and (report.ok or (not spare and eta is not None)):
            out.candidate = candidate
            out.eta_solver = eta if eta is not None else (
                best if best is not None else cert.eta)
            return out
        if cert.verified and spare and (
                kept is None or cert.eta > kept[1].eta):
            kept = (candidate, cert, report)
    if kept is not None:
        out.candidate, out.certificate, out.report = kept
        out.eta_solver = eta if eta is not None else (
            best if best is not None else out.certificate.eta)
        return out
    if refuted is not None:
        out.reason, out.report = INFEASIBLE, refuted
        out.message = (f"no certificate with a margin exists (solver "
                       f"{refuted.solver}, status {refuted.status!r}), and "
                       "without one none verified")
        return out
    if out.certificate is None:
        out.report = out.attempts[-1] if out.attempts else None
        out.reason = SOLVER_FAILED
        out.message = ("the solver failed"
                       + (f" ({out.report.message})" if out.report
                          and out.report.message else ""))
    elif out.report is not None and not out.report.ok:
        out.reason = INACCURATE
        out.message = "the solver's status stayed inaccurate"
    else:
        out.reason = NOT_VERIFIED
        out.message = ("the gain fails the exact check: "
                       + "; ".join(out.certificate.failures))
    out.message += (f"; statuses {[a.status for a in out.attempts]} after "
                    f"{len(out.attempts)} attempts")
    return out
