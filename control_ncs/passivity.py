"""Stochastic passivity analysis of jump systems (:ref:`theory-passivity`),
certified.

Names and signatures mirror :mod:`control.passivity`:
``ispassive(sys, ofp_index=0, ifp_index=0)``, :func:`get_input_ff_index`
and :func:`get_output_fb_index`, with the supply rate
``wᵀz - ρ zᵀz - ν wᵀw`` (:ref:`theory-conventions`:
``2wᵀz - 2ρ zᵀz - 2η wᵀw``), so that for a loss-free, time-invariant loop the
numbers coincide with python-control's. When *both* indices are nonzero,
python-control weights ``wᵀz`` by ``1 + ρν`` (Kottenstette & Antsaklis'
IF-OFP); here the weight stays 1, the rate whose expectation
:ref:`theory-passivity` takes. With either index 0 (every index computation,
and ``ispassive``'s defaults) the two conventions agree.

Two different indices exist for a lossy loop, and they are named apart:

* :func:`get_input_ff_index` -- the *stochastic* (certified) index: the
  supply inequality holds in expectation for every input adapted to the past,
  as in a feedback interconnection. Certified by ``P_k`` with ``Θ_k ≺ 0``;
  for Markov (bursty) modes by ``P_{k,ℓ}`` per previous mode with
  ``Θ_{k,ℓ} ≺ 0`` (:ref:`theory-markov`, the seed's Lemma 2 in full).
* :func:`mean_input_ff_index` -- the index of the *mean system* (the
  StateSpace face, :ref:`theory-moments`): a statement about ``E z`` for
  deterministic inputs only. It is never smaller than the stochastic one.

Two routes produce a certificate, both checked exactly by
:mod:`control_ncs.verify`:

* ``'lmi'`` -- the LMI of :ref:`theory-passivity` (:ref:`theory-markov` for
  Markov modes) solved by an interior-point solver (any jump system);
* ``'riccati'`` -- for a deterministic system (one mode, period 1): the KYP
  frequency test gives the index from above, and one discrete algebraic
  Riccati equation just below it gives ``P`` (see :func:`control_ncs.riccati.dare_storage`);
  no solver, ``O(n³)`` work against the LMI's ``n(n+1)/2`` dense unknowns.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
from control.exception import ControlArgument, ControlDimension

from . import kyp
from ._positive_real import (lti_ofp_index, lti_index_exists, nonstrict,
                             nonstrict_system, resolve_strict)
from ._checks import (choice, decay_bound, finite_real, no_extra_kwargs,
                      positive_int, positive_real, real_array)
from .exceptions import (CERTIFIED, FEEDTHROUGH, INFEASIBLE,
                         MESSAGES, NOT_MSS, NOT_VERIFIED, SOLVER_FAILED,
                         CertificationError)
from .driver import drive
from .riccati import COUPLED_THRESHOLD, coupled_certificate, dare_certificate
from ._results import Result
from .lmi import (DEFAULT_MARGIN, AnalysisModel, SolveReport, SupplyModel,
                  analysis_model, check_options, check_solver, solve,
                  supply_model)
from .jump import JumpStateSpace
from .stability import ms_radius, radius_memo
from .verify import (Certificate, certify_index, certify_ofp_index,
                     check_certificate, level_floor, square_system,
                     supply_feedthrough_bound)

__all__ = ["ispassive", "get_input_ff_index", "get_output_fb_index",
           "mean_input_ff_index", "frequency_ff_index",
           "passivity_certificate", "PassivityResult"]

#: Routes of :func:`passivity_certificate`; 'auto' takes the Riccati route
#: for every deterministic system (faster at every size, benchmarks).
METHODS = ("auto", "riccati", "lmi")

#: (margin multiplier, back-off) of ``driver.drive`` for an index: the
#: maximum, feasibility problems just below it, then a 100× margin.
INDEX_ATTEMPTS = ((1.0, 0.0), (1.0, 1e-6), (1.0, 1e-4), (1.0, 1e-3),
                  (1e2, 0.0))
#: For a given η: margin 1, 100×, then the margin maximised (None), whose
#: most interior answer re-certifies a level close to the index.
LEVEL_ATTEMPTS = ((1.0, 0.0), (1e2, 0.0), (None, 0.0))


@dataclass(repr=False)
class PassivityResult(Result):
    """A verified (or refuted) passivity certificate of a jump system.

    Attributes
    ----------
    passive : bool
        True: certified by ``certificate``. False: ``reason`` says why.
    eta : float
        Input-feedforward level ``η`` certified. For an index: below the
        supremum ``certificate.eta_sup`` that the certificate proves by the
        first back-off of ``verify.INDEX_BACKOFFS`` that passes the exact
        check, ``1e-6``, ``1e-5`` or ``1e-4`` times ``max(1, |sup|)``
        (absolute below 1), see :func:`control_ncs.verify.certify_index`.
        When ``ρ`` is maximised: the given ``ifp_index``.
    certificate : Certificate or None
        Exact verification figures (``P_k``, ``λmax(Θ_k)``, ``ms_radius``).
    report : SolveReport or None
        The solver's status and timings.
    reason : str
        One of the constants of :mod:`control_ncs.exceptions`:
        ``'certified'``, ``'not_mss'``, ``'feedthrough'``
        (``D̄ + D̄ᵀ - 2ρ Σ p_i D_iᵀD_i ≻ 2ηI`` fails, a necessary
        condition), ``'infeasible'`` (the LMI has no solution with its
        margin, and the margin-maximising LMI gives no
        certificate that passes the exact check; on the Riccati route: a
        frequency with ``λmin(G + Gᴴ)/2 ≤ η`` was found, so by the KYP
        lemma no certificate exists, see ``eta_upper``).
    method : str
        Route that decided: ``'lmi'`` or ``'riccati'``.
    eta_upper : float
        Riccati route: ``ν̂ = λmin(G + Gᴴ)/2`` at the lowest frequency found,
        an upper bound on the index (``ν ∈ (eta, eta_upper]`` for an index).
        NaN on the LMI route.
    ofp_index : float
        Output-feedback level ``ρ`` certified (0 unless asked for): the
        given one, or, when maximised, the level the certificate passes at
        (see :func:`control_ncs.verify.certify_ofp_index`).

    Notes
    -----
    On the Riccati route ``report`` is filled in the same terms:
    ``solver='scipy.linalg.solve_discrete_are'``, ``compile_time`` is the
    frequency search, ``solve_time`` the Riccati solves, pencil corrections
    and exact checks, ``iterations`` the number of Riccati solves, ``value``
    the level ``η`` of the last one and ``options`` its ``level`` and ``eps``.

    Examples
    --------
    ``G(z) = 1 + 1/(z - 0.5)`` has input-feedforward index
    ``min Re G = 1/3``; a deterministic system takes the Riccati route:

    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> result = ncs.passivity_certificate(G)      # ifp_index=None: the index
    >>> result.passive, result.reason, result.method
    (True, 'certified', 'riccati')
    >>> round(result.eta, 5), round(result.eta_upper, 10)
    (0.33333, 0.3333333333)
    >>> refuted = ncs.passivity_certificate(G, 0.4)
    >>> refuted.passive, refuted.reason, refuted.certificate is None
    (False, 'infeasible', True)
    """

    passive: bool
    eta: float
    certificate: Certificate | None
    report: SolveReport | None
    reason: str
    method: str = "lmi"
    eta_upper: float = np.nan
    ofp_index: float = 0.0

    _repr_fields = ("eta", "ofp_index", "method")

    @property
    def success(self) -> bool:
        """``passive``: a certificate passed the exact checks."""
        return self.passive

    @property
    def status(self) -> str:
        """``reason``: ``'certified'`` or why not."""
        return self.reason

    @property
    def message(self) -> str:
        """One sentence: the verdict and what it rests on."""
        text = MESSAGES.get(self.reason, self.reason)
        if self.passive:
            level = f"eta = {self.eta:.6g}"
            if self.ofp_index:
                level += f", ofp_index = {self.ofp_index:.6g}"
            return f"{text} ({level}, {self.method} route)"
        if self.report is not None and self.report.message:
            text += f" ({self.report.message})"
        return text

    def _details(self) -> list[str]:
        lines = [f"eta = {self.eta:.6g}, ofp_index = {self.ofp_index:.6g}, "
                 f"method {self.method}"
                 + ("" if np.isnan(self.eta_upper)
                    else f", eta_upper = {self.eta_upper:.6g}")]
        if self.report is not None:
            r = self.report
            lines.append(f"solver {r.solver}: {r.status}, "
                         f"{r.total_time:.3f} s")
        if self.certificate is not None:
            lines += self.certificate.summary().splitlines()
        return lines


def _feedthrough_refutes(sys, ifp_index, ofp_index=0.0) -> bool:
    """The necessary feedthrough condition fails for ``(ρ, η)``: no
    certificate (:ref:`theory-passivity`,
    :func:`control_ncs.verify.supply_feedthrough_bound`)."""
    if ifp_index is None or ofp_index is None:
        return False
    return not supply_feedthrough_bound(sys, ofp_index) > ifp_index


def _deterministic(sys: JumpStateSpace) -> tuple[np.ndarray, ...] | None:
    """``(A, B, C, D)`` of a deterministic system of period 1 with at least
    one state (:meth:`JumpStateSpace.deterministic`), else None: the
    frequency-domain and DARE routes need an LTI system."""
    if sys.period != 1 or sys.nstates == 0:
        return None
    mats = sys.deterministic()
    return None if mats is None else tuple(np.asarray(X[0], float)
                                           for X in mats)


def passivity_certificate(sys: Any, ifp_index: float | None = None, *,
                          ofp_index: float | None = 0.0, decay: float = 1.0,
                          method: str = "auto", solver: str | None = None,
                          margin: float = DEFAULT_MARGIN,
                          **solver_options: Any) -> PassivityResult:
    """Find and exactly verify a stochastic passivity certificate.

    Finds ``P_k`` with ``Θ_k(P; ρ, η) ≺ 0`` (:ref:`theory-passivity`, supply
    rate ``2wᵀz - 2ρ zᵀz - 2η wᵀw``, see
    :func:`control_ncs.verify.dissipation_blocks`; ``η`` maximised when
    ``ifp_index`` is None, ``ρ`` when ``ofp_index`` is None), then checks
    it with :func:`control_ncs.verify.check_certificate`. Necessary
    conditions that fail (``ms_radius ≥ 1``, the feedthrough bound
    ``D̄ + D̄ᵀ - 2ρ Σ p_i D_iᵀD_i ≻ 2ηI``) give an exact "no" without a
    solve. Two routes find ``P`` (``method``): the LMI, solved by cvxpy,
    for any jump system; and, with ``ρ = 0``, a Riccati route without a
    solver: for a deterministic system (one mode, period 1) the KYP
    frequency test and one Riccati equation (see Notes), for a jump
    system the coupled Riccati iteration (fast for large loops).

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
        Square (``w`` and ``z`` of equal size).
    ifp_index : float, optional
        Input-feedforward level ``η`` to certify; None: the largest
        certifiable one. A level below :func:`control_ncs.verify.level_floor`
        (``verify.LEVEL_FLOOR`` data scales below the feedthrough bound) is
        solved and checked at that floor ``η0``: as ``Θ(η) ≼ Θ(η0)``, the
        certificate at ``η0`` (``result.certificate.eta``) certifies the
        requested ``η`` (``result.eta``) exactly.
    ofp_index : float, optional
        Output-feedback level ``ρ`` to certify (default 0); None: the
        largest certifiable one (then ``ifp_index`` must be given).
    decay : float, optional
        Also certify ``E V`` decaying like ``r^(2t)`` (``r = decay`` in
        (0, 1]).
    method : {'auto', 'riccati', 'lmi'}, optional
        ``'auto'``: with ``ρ = 0`` and neither ``solver`` nor solver options
        given, the Riccati route for a deterministic system, and for a
        jump system of more than ``riccati.COUPLED_THRESHOLD`` (8) states,
        falling back to the LMI if it cannot certify; the LMI otherwise.
        ``'riccati'``: the Riccati route only (``ρ = 0``): one DARE for a
        deterministic system; for a jump system the coupled Riccati
        iteration of :func:`passivesyn`'s Riccati route, on the loop with
        no control input (its bisection stops within a relative ``1e-4``
        of the supremum, so an index may lie that much below the LMI's).
        ``'lmi'``: the LMI only.
    solver : str, optional
        LMI route: any installed cvxpy solver (default Clarabel).
    margin : float, optional
        LMI route: relative strictness margin of the LMI.
    **solver_options
        LMI route: passed to the solver (e.g. Clarabel's ``tol_gap_rel``).

    Returns
    -------
    PassivityResult
        ``method`` says which route decided.

    Raises
    ------
    ControlArgument
        If ``sys`` is not a system, ``method`` is not one of the above, or
        is ``'riccati'`` for a system that is not deterministic (or has no
        state) or with ``ρ ≠ 0``.
    ControlDimension
        If ``sys`` is not square or has no state.
    ValueError
        If ``ifp_index``, ``ofp_index`` or ``margin`` is not a finite
        number (``margin > 0``), or ``decay`` is not in (0, 1].
    ControlArgument
        If both indices are None (as python-control's
        ``solve_passivity_LMI``).
    CertificationError
        If no attempt (``INDEX_ATTEMPTS`` or ``LEVEL_ATTEMPTS``, then the
        fallback solver) gives an answer that passes the exact checks:
        ``reason`` is ``'solver_failed'``, ``'inaccurate'``,
        ``'not_verified'`` or, for an index, ``'infeasible'`` (a retry was
        reported infeasible); the figures are on the exception. With
        ``method='riccati'``: ``'not_verified'`` when no Riccati level
        gives a certificate that passes.

    Notes
    -----
    The Riccati route (derivation at :func:`control_ncs.riccati.dare_storage`): the KYP
    frequency test on a grid of ``kyp.KYP_POINTS`` points, refined by
    local grids, gives ``ν̂ ≥ ν`` (a value of ``λmin(G + Gᴴ)/2`` at one
    frequency). Just below ``ν̂`` (``riccati.RICCATI_BACKOFFS``: ``1e-7`` up to
    ``1e-3`` times ``max(1, |ν̂|)``) one discrete algebraic Riccati
    equation gives ``P ≻ 0``, and :func:`control_ncs.verify.certify_index`
    certifies the largest ``η`` it proves (another back-off of ``1e-6``
    to ``1e-4`` times ``max(1, |sup|)``), so ``ν`` lies in
    ``(eta, eta_upper]``: about ``1e-6·max(1, |ν|)`` wide when the first
    back-offs verify, up to about ``1e-3·max(1, |ν|)`` when only the last
    do. If the Riccati equation fails or its ``P`` does not verify, the
    symplectic pencil at that level locates any dip the grid missed
    (its unit-circle eigenvalues are the frequencies where
    ``G + Gᴴ - 2ηI`` is singular), ``ν̂`` is lowered and the levels are
    tried again; then larger back-offs.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [3] A. Rantzer, "On the Kalman-Yakubovich-Popov lemma", *Systems &
           Control Letters* 28(1), 1996.

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> result = ncs.passivity_certificate(G, 0.3)
    >>> result.passive, result.reason, result.certificate.verified
    (True, 'certified', True)
    """
    ifp_index = finite_real(ifp_index, "ifp_index", allow_none=True)
    ofp_index = finite_real(ofp_index, "ofp_index", allow_none=True)
    if ifp_index is None and ofp_index is None:
        raise ControlArgument("ifp_index, ofp_index: at most one may be None "
                              "(the index maximised); the other must be a "
                              "number")
    sys = square_system(sys)
    choice(method, "method", METHODS)
    # unknown keywords are refused here, not only when a solver runs (a
    # loop that is not mean-square stable never reaches one)
    check_options(check_solver(solver), solver_options)
    margin = positive_real(margin, "margin")
    decay = decay_bound(decay)
    if sys.modes.A.shape[-1] == 0:
        raise ControlDimension(
            "sys: a passivity certificate needs at least one state (a static "
            "system's index is λmin(D + Dᵀ)/2)")
    requested = ifp_index
    if ifp_index is not None:
        # the floor sits below the feedthrough bound of the level asked
        # (with its output-feedback term), so the floor problem is never
        # refused for feedthrough where the requested one is not
        bound = supply_feedthrough_bound(sys, ofp_index or 0.0)
        ifp_index = max(ifp_index, level_floor(
            bound, sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D))
    with radius_memo():     # the necessary condition and the check share it
        result = _certificate(sys, ifp_index, ofp_index, decay, method,
                              solver, margin, solver_options)
    if requested is None or requested == ifp_index:
        return result
    # certified at the floor: every lower level is certified exactly; a
    # refutation at the floor proves nothing about the level asked
    if result.passive or result.reason == NOT_MSS:
        # passive at the floor holds a fortiori; not mean-square stable
        # refutes every level
        return replace(result, eta=requested)
    report = result.report
    if report is not None:
        report = replace(report, message=(
            f"refuted only at the floor eta0 = {ifp_index:.6g} "
            f"(verify.level_floor), not at eta = {requested:.6g}"))
    return replace(result, eta=requested, reason=SOLVER_FAILED,
                   report=report)


def _certificate(sys, ifp_index, ofp_index, decay, method, solver, margin,
                 solver_options) -> PassivityResult:
    """:func:`passivity_certificate` on checked arguments."""
    mats = _deterministic(sys)
    if method == "riccati" and (ofp_index != 0.0 or
                                sys.modes.A.shape[-1] == 0):
        raise ControlArgument(
            "method: 'riccati' needs ofp_index=0 and at least one state; "
            f"got ofp_index={ofp_index} and {sys.modes.A.shape[-1]} "
            "state(s); use method='lmi' or 'auto'")
    # under 'auto', a named solver or solver options ask for the LMI
    lmi_asked = solver is not None or bool(solver_options)
    if mats is None and ofp_index == 0.0 and (
            method == "riccati" or (
                method == "auto" and not lmi_asked
                and sys.modes.A.shape[-1] > COUPLED_THRESHOLD)):
        # a jump system: the coupled Riccati iteration (no solver), exact
        # check; the necessary conditions first, as on the LMI route
        unstable = _not_mss(sys, decay)
        if unstable is not None:
            return PassivityResult(False, np.nan, None, None, unstable)
        if _feedthrough_refutes(sys, ifp_index, 0.0):
            return PassivityResult(False, float(ifp_index), None, None,
                                   FEEDTHROUGH)
        reason, eta, cert, fields, figures = coupled_certificate(
            sys, ifp_index, decay)
        if reason is not None:
            return PassivityResult(True, eta, cert, SolveReport(**fields),
                                   reason, "riccati")
        if method == "riccati":
            raise CertificationError(
                "passivity: the coupled Riccati iteration found no "
                "certificate that passes the exact check; try method='lmi'",
                NOT_VERIFIED, figures)
    if mats is not None and ofp_index == 0.0 and (
            method == "riccati" or (method == "auto" and not lmi_asked)):
        reason, eta, cert, fields, upper, figures = dare_certificate(
            sys, mats, ifp_index, decay)
        if reason is not None:
            return PassivityResult(
                reason == CERTIFIED, eta, cert,
                None if fields is None else SolveReport(**fields), reason,
                "riccati", upper)
        if method == "riccati":
            raise CertificationError(
                "passivity: the Riccati route found no certificate that "
                f"passes the exact check (levels tried: {figures['levels']}; "
                f"upper bound {figures['eta_upper']:.10g}); try "
                "method='lmi'", NOT_VERIFIED, figures)
    return _lmi_certificate(sys, ifp_index, ofp_index, decay, solver, margin,
                            solver_options)


#: A zero-dynamics eigenvalue refutes every ρ only if its modulus exceeds
#: the decay bound by this relative amount (the eigenvalues carry rounding).
ZERO_DYNAMICS_TOL = 1e-8

#: ... and only if D is this well conditioned (w = -D⁻¹Cξ is formed).
ZERO_DYNAMICS_MAX_COND = 1e8


def _zero_dynamics_refute(sys, ifp_index, decay) -> SolveReport | None:
    """An exact "no ρ works" for a deterministic system, or None.

    With ``D`` invertible, the inputs ``w = -D⁻¹Cξ`` keep ``z = 0``, so the
    supply is ``-2η‖w‖² ≤ 0`` (``η ≥ 0``) whatever ``ρ``, and on them
    ``Θ ≺ 0`` reads ``ξᵀ(A_zᵀPA_z - r²P)ξ < -2η‖w‖² ≤ 0`` with
    ``A_z = A - BD⁻¹C``: the zero dynamics must have spectral radius below
    ``r``. If they do not, no output-feedback level has a certificate.
    """
    mats = _deterministic(sys)
    if mats is None or ifp_index < 0:
        return None
    A, B, C, D = mats
    if not np.linalg.cond(D) < ZERO_DYNAMICS_MAX_COND:
        return None
    radius = float(np.abs(np.linalg.eigvals(A - B @ np.linalg.solve(D, C)))
                   .max())
    if not radius > decay * (1 + ZERO_DYNAMICS_TOL):
        return None
    return SolveReport(
        "infeasible", "numpy.linalg.eigvals", 0.0, 0.0, 0.0,
        message=f"the zero dynamics A - BD⁻¹C have spectral radius "
        f"{radius:.10g} ≥ r = {decay:g}: on the inputs that keep z = 0 no "
        "output-feedback level ρ can be certified")


def _not_mss(sys: Any, decay: float) -> str | None:
    """None when ``ms_radius < min(1, r²)`` is proven (certified bracket),
    ``'not_mss'`` when the opposite is, ``'not_verified'`` when the
    bracket straddles the bound."""
    below = ms_radius(sys, bracket=True).below(min(1.0, decay ** 2))
    return None if below else NOT_MSS if below is False else NOT_VERIFIED


def _lmi_certificate(sys, ifp_index, ofp_index, decay, solver, margin,
                     solver_options) -> PassivityResult:
    """The LMI route of :func:`passivity_certificate` (any jump system).

    At most one of ``ifp_index`` (``η``) and ``ofp_index`` (``ρ``) is None:
    that index is maximised; with both given, the level is certified.
    """
    unstable = _not_mss(sys, decay)
    if unstable is not None:
        return PassivityResult(False, np.nan, None, None, unstable)
    if _feedthrough_refutes(sys, ifp_index, ofp_index):
        return PassivityResult(False, float(ifp_index), None, None,
                               FEEDTHROUGH, ofp_index=float(ofp_index))
    free = ("eta" if ifp_index is None else
            "rho" if ofp_index is None else None)
    if free == "rho":
        refutation = _zero_dynamics_refute(sys, ifp_index, decay)
        if refutation is not None:
            return PassivityResult(False, float(ifp_index), None, refutation,
                                   INFEASIBLE, ofp_index=np.nan)
    fixed = free is None
    log: list[tuple] = []  # (margin, level, solver, status) per attempt

    def attempt(scale, target, name, left):
        eta = target if free == "eta" else ifp_index
        level_rho = target if free == "rho" else ofp_index
        level = None if scale is None else margin * scale
        model: AnalysisModel | SupplyModel
        if level_rho == 0.0 and sys.modes.is_iid:
            model = analysis_model(sys, eta, level, decay)
        else:
            # zᵀz needs every mode's output matrices (theory: passivity);
            # Markov modes need P_{k,ℓ} per previous mode (theory: Markov
            # losses)
            model = supply_model(sys, eta, level_rho, level, decay)
        # the caller's options are for the solver the caller chose
        report = solve(model.problem, name,
                       **(solver_options if name == solver else {}))
        log.append((level, eta if free != "rho" else level_rho,
                    report.solver, report.status))
        if report.status not in ("optimal", "optimal_inaccurate"):
            return report, None
        model.check_current()
        # the solver's ρ is only where to start: certify_ofp_index
        # computes the certified level from P (an 'optimal' status comes
        # with a value, lmi.solve)
        guess = report.value if target is None else target
        return report, (model.values(), guess)

    def verify(candidate):
        P, guess = candidate
        if fixed:
            return check_certificate(sys, P, ifp_index, decay=decay,
                                     ofp_index=ofp_index)
        if free == "eta":
            return certify_index(sys, P, decay=decay, ofp_index=ofp_index)
        return certify_ofp_index(sys, P, cast(float, guess), eta=ifp_index,
                                 decay=decay)

    out = drive(attempt, verify, eta=ifp_index if fixed else None,
                solver=solver,
                retries=LEVEL_ATTEMPTS if fixed else INDEX_ATTEMPTS,
                fallback=(None if fixed else 1.0, 0.0),
                refute_margins=fixed, spare=False,
                label=f"passivity LMI ({'level' if fixed else free})")
    if out.ok:
        cert = out.certificate
        return PassivityResult(True, cert.eta, cert, out.report, CERTIFIED,
                               ofp_index=cert.ofp_index)
    if out.reason == INFEASIBLE:
        return PassivityResult(
            False, np.nan if free == "eta" else float(ifp_index), None,
            out.report, INFEASIBLE,
            ofp_index=np.nan if free == "rho" else float(ofp_index))
    raise CertificationError(
        f"passivity: no certificate could be verified ({out.message}; "
        f"attempts (margin, level, solver, status): {log})",
        cast(str, out.reason),
        dict(out.figures(), attempts=log))


def ispassive(sys: Any, ofp_index: float = 0.0, ifp_index: float = 0.0,
              *, strict: bool | None = None, **kwargs: Any) -> bool:
    """True if ``sys`` is passive at these indices.

    Same signature as :func:`control.ispassive`, with two meanings
    (``strict``):

    * ``strict=True`` (the default for a jump system): stochastic strict
      passivity (:ref:`theory-passivity`): mean-square stability and an
      ``ε > 0`` such that ``E Σ_t (wᵀz - ρ zᵀz - ν wᵀw) ≥ ε E Σ_t wᵀw``
      from rest, for every input adapted to the past (``ρ = ofp_index``,
      ``ν = ifp_index``). True only with a certificate that passed the
      exact checks (see :func:`passivity_certificate`, which also returns
      the figures). Discrete time only.
    * ``strict=False`` (the default for a deterministic LTI system, as
      python-control means it): the transfer function is positive real
      for python-control's supply ``(1 + ρν) yᵀu - ρ yᵀy - ν uᵀu``, in
      continuous or discrete time: no pole outside the stability region,
      simple boundary poles (integrators) with positive semidefinite
      residues, and ``Φ(ω) ⪰ 0`` at every frequency (within a relative
      ``kyp.POPOV_TOL``). Exact up to rounding and without a solver: the
      Popov function on a refined grid, and with ``ρ = 0`` the
      Hamiltonian pencil's crossings. ``ρ`` alone is decided on the loop
      ``G (I - ρG)⁻¹``.

    Parameters
    ----------
    sys : JumpStateSpace, StateSpace or TransferFunction
    ofp_index : float, optional
        Output-feedback index ``ρ`` to certify (default 0).
    ifp_index : float, optional
        Input-feedforward index ``ν`` to certify (default 0: passivity).
    strict : bool, optional
        See above; default: True for a jump system, False for a
        deterministic LTI system unless a keyword of the certified test
        is given.
    **kwargs
        ``strict=True`` only: ``decay``, ``method``, ``solver``, ``margin``
        and solver options, as for :func:`passivity_certificate`.

    Returns
    -------
    bool
        False means: a necessary condition fails, or no certificate was
        found (the LMI is infeasible with its margin, and the LMI that
        maximises its margin gives none that passes the exact check).

    Raises
    ------
    ValueError
        If ``ofp_index`` or ``ifp_index`` is not a finite number; see
        :func:`passivity_certificate` for the others.
    ControlDimension
        If ``sys`` is not square.
    ControlArgument
        ``strict=False`` for a jump system with more than one mode or
        phase, or with keywords of the strict test.

    Notes
    -----
    With both indices nonzero, :func:`control.ispassive` weights ``wᵀz``
    by ``1 + ρν``; ``strict=False`` does too, ``strict=True`` keeps the
    weight 1 (see the module's docstring). python-control decides its
    meaning with an LMI whose storage ``xᵀPx`` must be ``⪰ 0`` on every
    state, so a realisation's hidden modes can change its answer;
    ``strict=False`` decides the input-output map from rest, the same
    for every realisation (equal answers for minimal ones).

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [3] A. Rantzer, "On the Kalman-Yakubovich-Popov lemma", *Systems &
           Control Letters* 28(1), 1996.

    Examples
    --------
    ``G(z) = 2z/(z - 0.5)`` has output-feedback index 1/4 and
    input-feedforward index 4/3:

    >>> import control as ct
    >>> import control_ncs as ncs
    >>> G = ct.tf([2, 0], [1, -0.5], True)
    >>> ncs.ispassive(G), ncs.ispassive(G, 0.2), ncs.ispassive(G, 0.3)
    (True, True, False)
    >>> ncs.ispassive(G, ifp_index=1.3), ncs.ispassive(G, ifp_index=1.4)
    (True, False)

    An integrator is passive, not strictly, and in continuous time too:

    >>> ncs.ispassive(ct.tf([1], [1, 0]))
    True
    >>> ncs.ispassive(ct.tf([1], [1, 0]).sample(0.1, method="bilinear"),
    ...               strict=True)
    False
    """
    # finite_real without allow_none never returns None
    ofp_index = finite_real(ofp_index, "ofp_index")
    ifp_index = finite_real(ifp_index, "ifp_index")
    if not resolve_strict(sys, strict, kwargs):
        return nonstrict(nonstrict_system(sys, "ispassive", kwargs),
                          ofp_index, ifp_index)
    return passivity_certificate(sys, ifp_index, ofp_index=ofp_index,
                                 **kwargs).passive


def _index(sys: Any, result: PassivityResult, name: str) -> None:
    """Raise for an index that could not be certified (``result``)."""
    if result.reason == NOT_MSS:
        raise CertificationError(
            f"{name}: sys is not mean-square stable (ms_radius ≥ 1, or ≥ r² "
            "with a decay bound); no passivity index exists", NOT_MSS,
            dict(ms_radius=ms_radius(square_system(sys))))
    if not result.passive:
        # sys is mean-square stable, so for ρ = 0 some η is certifiable
        # (theory: passivity: the (1,1) block is Lemma 1); an infeasible LMI
        # here is numerical, or, for ρ, the level of η held fixed is too high.
        report = result.report
        status = None if report is None else report.status
        why = f": {report.message}" if report is not None and \
            report.message else ""
        raise CertificationError(
            f"{name}: no index could be certified (reason {result.reason!r},"
            f" status {status!r}) although sys is mean-square stable{why}",
            result.reason, dict(status=status))


def get_input_ff_index(sys: Any, *, strict: bool | None = None,
                       **kwargs: Any) -> float:
    """Largest certified input-feedforward passivity index.

    The supremum of ``η`` for which a certificate ``P_k`` with ``Θ_k ≺ 0``
    exists (:ref:`theory-passivity`). The value returned is certified exactly:
    it lies below the supremum that the found ``P_k`` proves by the first
    back-off of ``verify.INDEX_BACKOFFS`` that passes the exact check
    (``1e-6``, else ``1e-5`` or ``1e-4``, times ``max(1, |sup|)``: absolute
    below 1, relative above), which leaves room for a later check, e.g.
    :func:`ispassive`, to re-certify it. For a loss-free ``N = 1`` loop
    it equals :func:`control.get_input_ff_index` and, for a stable system,
    :func:`frequency_ff_index`; such a deterministic system takes the
    Riccati route by default (no cvxpy solve, see
    :func:`passivity_certificate`).

    With ``strict=False`` (the default for a deterministic LTI system,
    python-control's meaning) the index is the exact
    ``min_ω λmin(G + Gᴴ)/2`` of the positive-real test of
    :func:`ispassive`, in continuous or discrete time, without a solver.

    Parameters
    ----------
    sys : JumpStateSpace, StateSpace or TransferFunction
    strict : bool, optional
        As for :func:`ispassive`: default True for a jump system, False
        for a deterministic LTI system unless ``**kwargs`` are given.
    **kwargs
        ``strict=True`` only: as for :func:`passivity_certificate`
        (``method``, ``decay``, ``ofp_index`` held fixed, ``solver``,
        ``margin``, solver options).

    Returns
    -------
    float

    Raises
    ------
    CertificationError
        ``reason='not_mss'`` if ``sys`` is not mean-square stable (no
        index exists); see :func:`passivity_certificate` for the others.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [3] A. Rantzer, "On the Kalman-Yakubovich-Popov lemma", *Systems &
           Control Letters* 28(1), 1996.

    Examples
    --------
    ``G(z) = 1 + 1/(z - 0.5)`` has ``min Re G = 1/3`` on the unit circle:

    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(ncs.get_input_ff_index(G), 5)
    0.33333
    """
    if not resolve_strict(sys, strict, kwargs):
        test = nonstrict_system(sys, "get_input_ff_index", kwargs)
        lti_index_exists(test, "get_input_ff_index")
        return float(test.minimum()[0])
    result = passivity_certificate(sys, None, **kwargs)
    _index(sys, result, "get_input_ff_index")
    return result.eta


def get_output_fb_index(sys: Any, *, strict: bool | None = None,
                        **kwargs: Any) -> float:
    """Largest certified output-feedback passivity index (stochastic).

    The supremum of ``ρ`` for which a certificate ``P_k`` exists with the
    supply rate ``2wᵀz - 2ρ zᵀz`` (:ref:`theory-passivity` with ``η = 0``): the
    largest gain that can be put in positive feedback around ``sys`` leaving it
    passive. ``E zᵀz`` takes every mode's output matrices, not their
    mean, so for a lossy loop this is not the mean system's index. The
    value is computed from the found ``P_k`` exactly and certified by
    :func:`control_ncs.verify.certify_ofp_index` (a back-off of
    ``1e-6``, else ``1e-5`` or ``1e-4``, times ``max(1, |sup|)`` below the
    supremum it proves); the solver's optimum is never the number
    returned. For a deterministic system it equals
    :func:`control.get_output_fb_index`. Always by the LMI.

    With ``strict=False`` (the default for a deterministic LTI system,
    python-control's meaning) the index is the largest ``ρ`` for which
    ``G (I - ρG)⁻¹`` is positive real (:func:`ispassive`), continuous or
    discrete time, without a solver: the frequency bound
    ``min_ω λmin(G⁻¹ + G⁻ᴴ)/2``, or below it by bisection where that loop
    is unstable; it can be negative for an unstable ``G``.

    Parameters
    ----------
    sys : JumpStateSpace, StateSpace or TransferFunction
    strict : bool, optional
        As for :func:`ispassive`: default True for a jump system, False
        for a deterministic LTI system unless ``**kwargs`` are given.
    **kwargs
        ``strict=True`` only: as for :func:`passivity_certificate`
        (``decay``, ``solver``, ``margin``, solver options).

    Returns
    -------
    float

    Raises
    ------
    CertificationError
        ``reason='not_mss'`` if ``sys`` is not mean-square stable;
        ``reason='infeasible'`` without a solve if ``sys`` is deterministic
        and its zero dynamics ``A - BD⁻¹C`` are not Schur stable (no ``ρ``
        works); see :func:`passivity_certificate` for the others.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    ``G(z) = 2z/(z - 0.5)``: ``Re 1/G = 0.5 - 0.25 cos θ ≥ 1/4``:

    >>> import control as ct
    >>> G = ct.tf([2, 0], [1, -0.5], True)
    >>> round(ncs.get_output_fb_index(G), 4)
    0.25
    """
    if not resolve_strict(sys, strict, kwargs):
        return lti_ofp_index(nonstrict_system(sys, "get_output_fb_index",
                                                kwargs))
    result = passivity_certificate(sys, 0.0, ofp_index=None, **kwargs)
    _index(sys, result, "get_output_fb_index")
    return result.ofp_index


def mean_input_ff_index(sys: Any, **kwargs: Any) -> float:
    """Input-feedforward index of the *mean* system.

    The StateSpace face of a :class:`~control_ncs.JumpStateSpace` (its exact
    mean, lifted over the period if ``N > 1``) is an ordinary LTI system;
    this is its passivity index, certified the same way. It bounds ``E z``
    for deterministic ``w`` only, and is never below
    :func:`get_input_ff_index` (:ref:`theory-passivity`,
    :ref:`theory-moments`).

    Parameters
    ----------
    sys : JumpStateSpace, discrete-time StateSpace or TransferFunction
        Square (``w`` and ``z`` of equal size).
    **kwargs
        As for :func:`get_input_ff_index` (``method``, ``decay``,
        ``ofp_index`` held fixed, ``solver``, ``margin``, solver options);
        unknown keywords raise ``TypeError``.

    Returns
    -------
    float
        The certified index of ``sys.mean()``.

    Raises
    ------
    CertificationError
        ``reason='not_mss'`` if the mean system is not Schur stable; see
        :func:`passivity_certificate` for the others.

    See Also
    --------
    get_input_ff_index : the stochastic index, for inputs adapted to the
        past (feedback).

    Examples
    --------
    ``x⁺ = a x + w``, ``z = x + w`` with ``a`` 0.5 or 0 (probability 1/2
    each): the mean system has ``a = 0.25`` and index ``1 - 1/1.25 = 0.2``;
    the stochastic index is smaller.

    >>> sys = ncs.jss([[[0.5]], [[0.0]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])
    >>> round(ncs.mean_input_ff_index(sys), 4), round(ncs.get_input_ff_index(sys), 4)
    (0.2, 0.1791)
    """
    sys = square_system(sys)   # the mean face is exact (theory: Markov losses)
    return get_input_ff_index(sys.mean(), **kwargs)


def frequency_ff_index(sys: Any, omega: Any = None, *,
                       points: int = kyp.KYP_POINTS, **kwargs: Any) -> float:
    """KYP frequency test: ``min_ω λmin(G(e^{jω}) + G(e^{jω})ᴴ) / 2``.

    For a Schur-stable LTI system this equals its input-feedforward index
    (KYP lemma); an independent route to check the LMIs. A grid over
    ``[0, π/dt]`` (or ``omega``) is refined around its three lowest local
    minima by successively finer local grids, down to a spacing of
    ``1e-12`` rad/sample (not when ``omega`` is given). The
    value is attained at a frequency, so it is an upper bound on the index,
    up to the rounding of ``G``; a dip narrower than the grid's spacing can
    be missed (:func:`get_input_ff_index` also checks the Riccati pencil).

    ``G`` is evaluated at all frequencies at once from one complex Schur
    form of ``A`` (``O(n³)`` once, then ``O(n² m)`` per frequency).

    Parameters
    ----------
    sys : discrete-time StateSpace (for a jump system: its mean system)
    omega : array_like, optional
        Frequencies (rad per time unit) of the grid.
    points : int, optional
        Grid size when ``omega`` is None (default ``kyp.KYP_POINTS``).
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword).

    Returns
    -------
    float
        ``min λmin(G + Gᴴ)/2`` over the frequencies searched.

    Raises
    ------
    TypeError
        Unknown keyword.
    ValueError
        If the system is not Schur stable (the test does not apply), or
        ``omega`` is empty, complex or not finite.

    References
    ----------
    .. [1] A. Rantzer, "On the Kalman-Yakubovich-Popov lemma", *Systems &
           Control Letters* 28(1), 1996.

    Examples
    --------
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(ncs.frequency_ff_index(G), 10)  # min Re(1 + 1/(z - 0.5)) = 1/3
    0.3333333333
    """
    no_extra_kwargs("frequency_ff_index", kwargs)
    lti = square_system(sys).mean()
    A, B, C, D = (np.asarray(M, float) for M in (lti.A, lti.B, lti.C, lti.D))
    resp = kyp.FrequencyResponse(A, B, C, D)
    if resp.radius >= 1:
        raise ValueError("sys: frequency_ff_index needs a Schur-stable system")
    dt = 1.0 if lti.dt is True else float(lti.dt)
    if omega is None:
        return kyp.frequency_minimum(resp, None, positive_int(points,
                                                              "points"))
    thetas = np.sort(real_array(omega, "omega", ndim=(0, 1)).ravel() * dt)
    if thetas.size == 0:
        raise ValueError("omega: expected at least one frequency")
    return kyp.frequency_minimum(resp, thetas)


def _ispassive_method(self: JumpStateSpace, ofp_index: float = 0.0,
                      ifp_index: float = 0.0, **kwargs: Any) -> bool:
    """True if the jump system is certified strictly passive.

    ``sys.ispassive()`` is :func:`control_ncs.ispassive` ``(sys, ...)``,
    as :meth:`control.LTI.ispassive` is :func:`control.ispassive`: the
    stochastic, certified meaning (python-control's own method would test
    the mean system with an LMI).

    Parameters
    ----------
    ofp_index, ifp_index : float, optional
        The indices to certify (default 0).
    **kwargs
        As for :func:`control_ncs.ispassive`.

    Returns
    -------
    bool

    Examples
    --------
    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.3, 0.7])
    >>> sys.ispassive()
    True
    """
    return ispassive(self, ofp_index, ifp_index, **kwargs)


# python-control's LTI.ispassive imports control.passivity; a jump system
# answers with its own, certified test (attached here, where it lives, so
# that jump.py needs no import of the analysis layer)
JumpStateSpace.ispassive = _ispassive_method
