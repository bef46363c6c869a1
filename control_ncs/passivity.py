"""Stochastic passivity analysis of jump systems (MATH §6), certified.

Names mirror :mod:`control.passivity`: :func:`ispassive` and
:func:`get_input_ff_index`, with the same supply-rate convention
(``wᵀz - ν wᵀw``, equivalently MATH's ``2wᵀz - 2η wᵀw``), so that for a
loss-free, time-invariant loop the numbers coincide with python-control's.

Two different indices exist for a lossy loop, and they are named apart:

* :func:`get_input_ff_index` -- the *stochastic* (certified) index: the
  supply inequality holds in expectation for every input adapted to the past,
  as in a feedback interconnection. Certified by ``P_k`` with ``Θ_k ≺ 0``.
* :func:`mean_input_ff_index` -- the index of the *mean system* (the
  StateSpace face, MATH §7): a statement about ``E z`` for deterministic
  inputs only. It is never smaller than the stochastic one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from control.exception import ControlDimension
from scipy.optimize import minimize_scalar

from ._checks import no_extra_kwargs
from .jump import as_jump
from .lmi import (DEFAULT_MARGIN, SolveReport, analysis_model,
                  fallback_solver, solve)
from .stability import ms_radius
from .verify import (Certificate, CertificationError, certify_index,
                     check_certificate)

__all__ = ["ispassive", "get_input_ff_index", "mean_input_ff_index",
           "frequency_ff_index", "passivity_certificate", "PassivityResult"]

#: Attempts, in turn, until an answer passes the exact checks, as
#: (margin multiplier, relative back-off of η or None). For an index: the
#: maximisation, then feasibility problems a little below its optimum (a
#: maximum sits on the boundary, where interior-point answers end
#: 'optimal_inaccurate'; measured on periodic lossy loops: at 1e-6 below,
#: Clarabel says 'optimal'), then a 100× larger margin.
INDEX_ATTEMPTS = ((1.0, None), (1.0, 1e-6), (1.0, 1e-4), (1.0, 1e-3),
                  (1e2, None))
#: For a given η: the LMI with its margin, a 100× larger one, and last the
#: LMI that maximises its own margin (multiplier None), for an η so close to
#: the index that a fixed margin makes the LMI infeasible; its answer is the
#: most interior certificate and is checked exactly like any other.
#: Measured: needed to re-certify the η that passivesyn returns (1e-6
#: below what its certificate proves); the non-strict LMI (margin 0)
#: instead returns boundary points that fail the exact check.
LEVEL_ATTEMPTS = ((1.0, None), (1e2, None), (None, None))


@dataclass
class PassivityResult:
    """A verified (or refuted) passivity certificate of a jump system.

    Attributes
    ----------
    passive : bool
        True: certified by ``certificate``. False: ``reason`` says why.
    eta : float
        Dissipation level certified (for an index: a relative 1e-6 below
        the supremum ``certificate.eta_sup`` the certificate proves, see
        :func:`control_ncs.verify.certify_index`).
    certificate : Certificate or None
        Exact verification figures (``P_k``, ``λmax(Θ_k)``, ``ms_radius``).
    report : SolveReport or None
        The solver's status and timings.
    reason : str
        ``'certified'``, ``'not_mss'``, ``'feedthrough'`` (``D̄ + D̄ᵀ ≻ 2ηI``
        fails, a necessary condition), ``'infeasible'`` (the LMI has no
        solution with its margin, and the margin-maximising LMI gives no
        certificate that passes the exact check).
    """

    passive: bool
    eta: float
    certificate: Certificate | None
    report: SolveReport | None
    reason: str


def _square(sys) -> None:
    m, p = sys.modes.B.shape[-1], sys.modes.C.shape[-2]
    if m != p:
        raise ControlDimension(f"sys: passivity needs as many inputs as outputs "
                               f"(w and z of equal size), got {m} inputs and "
                               f"{p} outputs")


def passivity_certificate(sys: Any, ifp_index: float | None = None, *,
                          decay: float = 1.0, solver: str | None = None,
                          margin: float = DEFAULT_MARGIN,
                          **solver_options: Any) -> PassivityResult:
    """Search for and exactly verify a stochastic passivity certificate.

    Solves the LMI ``Θ_k(P, η) ≺ 0`` of MATH §6 (maximising ``η`` when
    ``ifp_index`` is None), then checks the answer with
    :func:`control_ncs.verify.check_certificate`. Necessary conditions that
    fail (``ms_radius ≥ 1``, ``D̄ + D̄ᵀ ⊁ 2ηI``) give an exact "no" without a
    solve.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
        Square (``w`` and ``z`` of equal size).
    ifp_index : float, optional
        Dissipation ``η`` to certify; None: the largest certifiable one.
    decay : float, optional
        Also certify ``E V`` decaying like ``r^(2t)`` (``r = decay``).
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver (e.g. Clarabel's ``tol_gap_rel``).

    Returns
    -------
    PassivityResult

    Raises
    ------
    CertificationError
        If no attempt (``INDEX_ATTEMPTS`` or ``LEVEL_ATTEMPTS``, then the
        fallback solver) gives an answer that passes the exact checks:
        ``reason`` is ``'solver_failed'``, ``'inaccurate'``,
        ``'not_verified'`` or, for an index, ``'infeasible'`` (a retry was
        reported infeasible); the figures are on the exception.
    """
    sys = as_jump(sys)
    _square(sys)
    rho = ms_radius(sys)
    if not rho < min(1.0, decay ** 2):
        return PassivityResult(False, np.nan, None, None, "not_mss")
    _, _, _, Dbar = sys.modes.mean()
    sym_min = min(np.linalg.eigvalsh(D + D.T).min() for D in Dbar)
    if ifp_index is not None and not sym_min > 2 * ifp_index:
        return PassivityResult(False, float(ifp_index), None, None,
                               "feedthrough")
    fixed = ifp_index is not None
    plan = [(scale, backoff, solver) for scale, backoff in
            (LEVEL_ATTEMPTS if fixed else INDEX_ATTEMPTS)]
    if fallback_solver(solver):
        plan.append(((None if fixed else 1.0), None, fallback_solver(solver)))
    attempts, last, best, refuted = [], None, None, False
    while plan:
        scale, backoff, name = plan.pop(0)
        target = ifp_index
        if backoff is not None:
            if best is None:
                continue  # the first solve gave no optimum to back off from
            target = best - backoff * max(1.0, abs(best))
        level = None if scale is None else margin * scale
        model = analysis_model(sys, target, level, decay)
        # the caller's options are for the solver the caller chose
        report = solve(model.problem, name,
                       **(solver_options if name == solver else {}))
        attempts.append((level, target, report.solver, report.status))
        if len(attempts) == 1:
            best = report.value
        if report.infeasible:
            last = (report, None, "infeasible")
            if fixed:
                refuted = True
                # a larger margin is infeasible too; a smaller one may not be
                plan = [a for a in plan if a[0] is None]
                continue
            if len(attempts) == 1:
                break
            continue  # e.g. a backed-off target still above the index
        if report.status not in ("optimal", "optimal_inaccurate"):
            last = (report, None, "solver_failed")
            continue
        if scale is None and report.value is not None and report.value <= 0:
            # the largest margin is not positive: no strict certificate
            # (unless another solver's answer verifies after all)
            last, refuted = (report, None, "infeasible"), True
            continue
        P = np.array([Pk.value for Pk in model.P])
        cert = (check_certificate(sys, P, float(ifp_index), decay=decay)
                if fixed else certify_index(sys, P, decay=decay))
        # For a given η the exact check is the proof, whatever the solver's
        # status; an index also claims optimality, which needs 'optimal'.
        if cert.verified and (report.ok or fixed):
            return PassivityResult(True, cert.eta, cert, report, "certified")
        last = (report, cert, "not_verified" if report.ok else "inaccurate")
    report, cert, reason = last
    if refuted:
        # No certificate with a margin exists, and without one none verified.
        return PassivityResult(False, float(ifp_index), None, report,
                               "infeasible")
    if reason == "infeasible" and len(attempts) == 1:
        return PassivityResult(False, np.nan, None, report, "infeasible")
    figures = dict(status=report.status, solver=report.solver,
                   attempts=attempts,
                   **(cert.figures() if cert is not None else {}))
    what = {"solver_failed": "the solver failed",
            "inaccurate": "the solver's status stayed inaccurate",
            "infeasible": "a retry was reported infeasible",
            "not_verified": "the solver's answer fails the exact check: "
            + ("; ".join(cert.failures) if cert is not None else "")}[reason]
    raise CertificationError(
        f"passivity: no certificate could be verified ({what}; attempts "
        f"(margin, eta, solver, status): {attempts})", reason, figures)


def ispassive(sys: Any, ifp_index: float = 0.0, **kwargs: Any) -> bool:
    """True if ``sys`` is certified strictly passive with dissipation ``η``.

    Stochastic strict passivity (MATH §6): there is ``ε > 0`` such that
    ``E Σ_t (wᵀz - η wᵀw) ≥ ε E Σ_t wᵀw`` from rest, for every input adapted
    to the past. True only with a certificate that passed the exact checks
    (see :func:`passivity_certificate`, which also returns the figures).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    ifp_index : float, optional
        Input-feedforward index ``η`` to certify (default 0: passivity).
    **kwargs
        ``decay``, ``solver``, ``margin`` and solver options, as for
        :func:`passivity_certificate`.

    Returns
    -------
    bool
        False means: a necessary condition fails, or no certificate was
        found (the LMI is infeasible with its margin, and the LMI that
        maximises its margin gives none that passes the exact check).

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> ispassive(G), ispassive(G, ifp_index=0.4)
    (True, False)
    """
    return passivity_certificate(sys, ifp_index, **kwargs).passive


def get_input_ff_index(sys: Any, **kwargs: Any) -> float:
    """Largest certified input-feedforward passivity index (stochastic).

    The supremum of ``η`` for which a certificate ``P_k`` with ``Θ_k ≺ 0``
    exists (MATH §6); the value returned is certified exactly, a relative
    1e-6 below the supremum the solver's ``P_k`` proves (room for any later
    check, e.g. :func:`ispassive`, to re-certify it). For a loss-free
    ``N = 1`` loop
    it equals :func:`control.get_input_ff_index` and, for a stable system,
    :func:`frequency_ff_index`.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    **kwargs
        As for :func:`passivity_certificate`.

    Returns
    -------
    float

    Raises
    ------
    CertificationError
        ``reason='not_stable'`` if ``sys`` is not mean-square stable (no
        index exists); see :func:`passivity_certificate` for the others.

    Examples
    --------
    ``G(z) = 1 + 1/(z - 0.5)`` has ``min Re G = 1/3`` on the unit circle:

    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(get_input_ff_index(G), 5)
    0.33333
    """
    result = passivity_certificate(sys, None, **kwargs)
    if result.reason == "not_mss":
        raise CertificationError(
            "get_input_ff_index: sys is not mean-square stable "
            "(ms_radius ≥ 1, or ≥ r² with a decay bound); no passivity "
            "index exists", "not_stable", dict(ms_radius=ms_radius(sys)))
    if not result.passive:
        # sys is mean-square stable, so some η is certifiable (MATH §6: the
        # (1,1) block is Lemma 1); an infeasible LMI here is numerical.
        raise CertificationError(
            "get_input_ff_index: the LMI was reported infeasible although "
            f"sys is mean-square stable (status {result.report.status!r})",
            "infeasible", dict(status=result.report.status))
    return result.eta


def mean_input_ff_index(sys: Any, **kwargs: Any) -> float:
    """Input-feedforward index of the *mean* system (deterministic inputs).

    The StateSpace face of a :class:`~control_ncs.JumpStateSpace` (its exact
    mean, lifted over the period if ``N > 1``) is an ordinary LTI system;
    this is its passivity index, certified the same way. It bounds ``E z``
    for deterministic ``w`` only, and is never below
    :func:`get_input_ff_index` (MATH §6-§7).
    """
    sys = as_jump(sys)
    return get_input_ff_index(sys.mean(), **kwargs)


def frequency_ff_index(sys: Any, omega: Any = None, *, points: int = 2000,
                       **kwargs: Any) -> float:
    """KYP frequency test: ``min_ω λmin(G(e^{jω}) + G(e^{jω})ᴴ) / 2``.

    For a Schur-stable LTI system this equals its input-feedforward index
    (KYP lemma); an independent route to check the LMIs. A grid over
    ``[0, π/dt]`` (or ``omega``) is refined around its minimum with a
    bounded scalar search.

    Parameters
    ----------
    sys : discrete-time StateSpace (for a jump system: its mean system)
    omega : array_like, optional
        Frequencies (rad per time unit) of the grid.
    points : int
        Grid size when ``omega`` is None.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If the system is not Schur stable (the test does not apply).
    """
    no_extra_kwargs("frequency_ff_index", kwargs)
    J = as_jump(sys)
    lti = J.mean()
    A, B, C, D = (np.asarray(M, float) for M in (lti.A, lti.B, lti.C, lti.D))
    if B.shape[1] != C.shape[0]:
        raise ControlDimension("sys: the frequency test needs a square system")
    if A.size and np.max(np.abs(np.linalg.eigvals(A))) >= 1:
        raise ValueError("sys: frequency_ff_index needs a Schur-stable system")
    dt = 1.0 if lti.dt is True else float(lti.dt)
    n = A.shape[0]

    def lam(theta: float) -> float:
        z = np.exp(1j * theta)
        G = D + C @ np.linalg.solve(z * np.eye(n) - A, B) if n else D + 0j
        return float(np.linalg.eigvalsh(0.5 * (G + G.conj().T)).min())

    thetas = (np.linspace(0.0, np.pi, points) if omega is None
              else np.asarray(omega, float) * dt)
    values = np.array([lam(t) for t in thetas])
    best = float(values.min())
    step = np.pi / max(points - 1, 1) if omega is None else 0.0
    for i in np.argsort(values)[:3]:
        if step:
            lo, hi = max(thetas[i] - step, 0.0), min(thetas[i] + step, np.pi)
            r = minimize_scalar(lam, bounds=(lo, hi), method="bounded",
                                options=dict(xatol=1e-12))
            best = min(best, float(r.fun))
    return best
