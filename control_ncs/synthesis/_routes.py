"""The routes of :func:`control_ncs.passivesyn`, and the proofs before them.

A route designs a gain and has it certified exactly: the synthesis LMI of
:mod:`control_ncs.lmi` (in balanced coordinates, with a fixed-``η`` search
when maximising stalls), the Riccati iteration of
:mod:`control_ncs.riccati` (full information), or the local refinement of
:mod:`control_ncs.refine` where the LMI is only sufficient. Proofs that no
gain exists (the modes no gain acts in) come before any solve. Routes never
import the dispatcher.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from control.exception import ControlDimension

from .._checks import (positive_int, positive_real)
from ..jump import JumpStateSpace
from ..modes import entered_modes
from ..stability import ms_radius
from ..openloop import JumpPlant
from ..driver import RETRIES, drive
from ..lmi import (SolveReport, balancing_scale,
                  data_scale, gain_kinds,
                  read_gains, solve, synthesis_model)
from ._local import autonomous_rate
from .refine import _refine
from ..riccati import riccati_synthesis
from ..exceptions import (INFEASIBLE, NOT_FOUND,
                         NOT_VERIFIED, SOLVER_FAILED, SUFFICIENT_FAILED,
                         TIME_LIMIT, SynthesisError)
from ..verify import (certify_index, check_certificate,
                     feedthrough_bound)
from ._result import passive_design


#: A maximised η below -ETA_FLOOR × the data's scale is a solver failure:
#: there 2ηI swamps the LMI and no certificate verifies in double precision.
ETA_FLOOR = 1e8

#: Above this many states (structure 'full', no solver options) the default
#: call takes the Riccati iteration: it wins from n = 10 on (benchmarks §2).
RICCATI_THRESHOLD = 8


#: Up to this many states an inconclusive automatic Riccati iteration is
#: followed by the LMI, still affordable there (benchmarks §1).
RICCATI_FALLBACK_MAX = 16


#: Options of the Riccati route (``solver='riccati'``), passed in
#: ``options['solver_options']``; any other raises TypeError.
RICCATI_OPTIONS = ("rtol", "max_sweeps", "probe_sweeps")


#: Balance the state (powers of two, exact) before the LMI only when the
#: scales found spread by at least this factor.
BALANCE_FROM = 16.0


#: The default call's fixed-η search: decades below the feedthrough bound,
#: then bisection steps after the first verified level.
ETA_SEARCH_DECADES = 10


ETA_SEARCH_STEPS = 12


#: The synthesis (``passivesyn(method='auto'|'refine')``) tries the
#: sufficient LMI first, as a starting point, up to this many states: above,
#: it took 8.7-14.5 s at 16-18 states, at most 1.1 s up to 10
#: (docs/benchmarks.md, structured refinement).
LMI_START_MAX_STATES = 10




def _plant_arrays(plant: JumpPlant) -> None:
    """ControlDimension unless a JumpPlant's arrays fit together."""
    N, M = plant.probabilities.shape if plant.probabilities.ndim == 2 \
        else (None, None)
    if N is None or plant.A.ndim != 4:
        raise ControlDimension(
            f"P: a JumpPlant needs probabilities of shape (N, M) and A of "
            f"shape (N, M, nx, nx), got {plant.probabilities.shape} and "
            f"{plant.A.shape}")
    s = plant.shape
    nx, nu, nw, nz, nk = s["nx"], s["nu"], s["nw"], s["nz"], s["nk"]
    want = dict(A=(nx, nx), Bu=(nx, nu), Bw=(nx, nw), Cz=(nz, nx),
                Du=(nz, nu), Dw=(nz, nw))
    for name, tail in want.items():
        got = getattr(plant, name).shape
        if got != (N, M) + tail:
            raise ControlDimension(f"P: JumpPlant.{name} must have shape "
                                   f"{(N, M) + tail}, got {got}")
    if plant.E.shape not in ((N, nk, nx), (N, M, nk, nx)) or \
            min(nx, nu) == 0:
        raise ControlDimension(
            f"P: JumpPlant.E must have shape (N, nk, nx) = {(N, nk, nx)} "
            f"(or (N, M, nk, nx) per mode) with nx, nu > 0, got E "
            f"{plant.E.shape}, nu = {nu}")
    p = plant.probabilities
    if not (np.all(np.isfinite(p)) and np.all(p >= 0)
            and np.allclose(p.sum(axis=1), 1.0)):
        raise ValueError("P: JumpPlant.probabilities must be nonnegative "
                         "with rows summing to 1")
    if not all(np.all(np.isfinite(getattr(plant, f))) for f in want):
        raise ValueError("P: JumpPlant matrices must be finite")
    T = plant.transition
    if T is not None and (T.shape != (N, M, M) or not (
            np.all(np.isfinite(T)) and np.all(T >= 0)
            and np.allclose(T.sum(axis=2), 1.0))):
        raise ValueError(f"P: JumpPlant.transition must have shape "
                         f"{(N, M, M)}, entries >= 0 and rows summing to 1, "
                         f"got shape {T.shape}")


def _feedthrough(plant: JumpPlant) -> tuple[float, int]:
    """The feedthrough bound on ``η`` (:ref:`theory-passivity`); Markov modes:
    per phase
    and previous mode, with the laws ``T_{k-1}[ℓ]`` (:ref:`theory-markov`)."""
    if plant.transition is None:
        return feedthrough_bound(plant.probabilities, plant.Dw)
    N, M = plant.probabilities.shape
    laws = np.roll(plant.transitions(), 1, axis=0)   # [k, ℓ] = T_{k-1}[ℓ]
    D = np.repeat(plant.Dw[:, None], M, axis=1)
    bound, j = feedthrough_bound(laws.reshape(N * M, M),
                                 D.reshape((N * M,) + plant.Dw.shape[1:]))
    return bound, j // M


def _refine_route(plant: JumpPlant, eta: float | None, decay: float,
                  deadline: float | None, lmi_start: dict | None,
                  initial: np.ndarray | None = None):
    """The refinement route (checked arguments): proof first, then the
    local search of :mod:`control_ncs.refine`, certified by analysis.

    ``lmi_start`` holds the arguments of :func:`_routes` for the sufficient
    LMI, whose gain (if it certifies one) is the first start; None skips it
    and starts from ``initial`` (gains per phase). A gain the LMI certifies
    at a given ``eta`` is returned as is. Returns the :class:`Design` whose
    ``method`` names what certified it.
    """
    rate, states = autonomous_rate(plant, min(1.0, decay ** 2))
    if rate >= min(1.0, decay ** 2) * (1 + 1e-9):
        raise SynthesisError(
            f"passivesyn: infeasible: the states {states.tolist()} evolve "
            f"on their own, reached by no input and driven by no other "
            f"state, with a second-moment rate of {rate:.6g} >= "
            f"{min(1.0, decay ** 2):.6g} per step; every closed loop's rate "
            f"is at least that: no gain makes the loop mean-square stable"
            + (f" with decay {decay}" if decay < 1 else ""), INFEASIBLE,
            dict(ms_radius_without_control=rate, states=states.tolist(),
                 bound=min(1.0, decay ** 2), proof="autonomous subsystem"))
    given = found = None
    if lmi_start is not None and plant.shape["nx"] <= LMI_START_MAX_STATES \
            and not plant.reads_per_mode:
        left = None if deadline is None else deadline - time.perf_counter()
        share = None if left is None else 0.5 * left
        try:
            found = _routes(plant, eta, decay, deadline=None if share is None
                            else time.perf_counter() + share, **lmi_start)
        except SynthesisError:
            found = None
        if found is not None:
            if eta is not None:
                return found
            # gains on the previous mode (Markov links) compete as they
            # are; a gain per phase is the refinement's first start
            given = found.gains if found.gains.ndim == 3 else None
    if given is None and initial is not None:
        given = initial
    left = None if deadline is None else max(deadline - time.perf_counter(),
                                              1e-3)
    rng = np.random.default_rng(0)
    res = _refine(plant, eta, decay, given, rng,
                  None if left is None else time.perf_counter() + left, 200)
    if found is not None and not (res.verified and res.eta > found.value):
        return found.with_fields(refinement=res, start="lmi")
    if not res.verified:
        raise SynthesisError(
            f"passivesyn: {res.message}", TIME_LIMIT
            if res.stopped == TIME_LIMIT else NOT_FOUND,
            dict(ms_radius=res.ms_radius, starts=res.starts,
                 iterations=res.iterations, method="refine"))
    cert = res.certificate
    assert cert is not None  # verified
    X = np.linalg.inv(cert.P)
    X = 0.5 * (X + np.swapaxes(X, -1, -2))
    E = np.abs(plant.readings()[0]).max(axis=1)     # all the gain reads
    if X.ndim == 4:
        # Markov links: storage per phase and previous mode, P_{k,ℓ}
        Y = np.einsum("kuj,kjx,klxy->kluy", res.gains, E, X)
    else:
        Y = np.einsum("kuj,kjx,kxy->kuy", res.gains, E, X)
    s = plant.shape
    report = SolveReport("optimal", "REFINE", 0.0, res.time, res.time,
                         res.iterations, res.eta)
    if found is not None:
        structure = found.fields["structure"]
    elif plant.reads_per_mode:
        structure = "per_mode"
    else:
        structure = "extended" if any(
            plant.known_coordinates(k).size < s["nx"]
            for k in range(plant.period)) else "full"
    design = passive_design(plant, X, Y, res.gains, plant.close(res.gains),
                            cert, cert.eta, cert.eta, decay, "merged",
                            structure, s["nx"] + s["nw"], report, [report],
                            route="local", method="refine")
    return design.with_fields(
        start="lmi" if res.start == "given" else res.start, refinement=res)


def _routes(plant, eta, decay, margin, structure, structure0, form, solver,
            solver_options, deadline, riccati, gain="mode"):
    """The solve-and-verify routes of :func:`passivesyn` (checked input)."""
    if riccati:
        return _riccati(plant, eta, decay, margin, solver_options)
    # the Riccati iteration designs K_k (i.i.d.) or K_{k,ℓ} (Markov)
    fits = plant.transition is None or "phase" not in gain_kinds(plant, gain)
    chosen = (solver is None and not solver_options and structure0 == "full"
              and plant.shape["nx"] > RICCATI_THRESHOLD and fits)
    if chosen:
        try:
            return _riccati(plant, eta, decay, margin, solver_options)
        except SynthesisError as err:
            # Chosen for the caller, not by them: an inconclusive iteration
            # (out of sweeps, e.g. a tight decay bound) falls back to the LMI
            # while the LMI is still affordable; a divergence is a proof of
            # infeasibility and stands.
            if (err.reason != SOLVER_FAILED
                    or plant.shape["nx"] > RICCATI_FALLBACK_MAX):
                raise
    # Under structure='auto' the sufficient 'extended' LMI is followed by
    # 'block' when it certifies nothing: in exact arithmetic 'extended'
    # contains 'block' (G = X), but solved numerically 'block' once
    # certified a gain where 'extended' failed (1 of 80
    # structured cases; not reproduced on 760 seeded plants, n = 2-3,
    # N = 2-3, since the fixed-η search below). Trying both keeps the
    # README's "never more conservative" true of what is returned.
    order = [structure0] + (["block"] if structure == "auto"
                            and structure0 == "extended" else [])
    first = None
    for struct in order:
        out, finish = _lmi_route(plant, eta, decay, margin, struct, form,
                                 solver, solver_options, deadline,
                                 gain=gain)
        if out.ok:
            return finish()
        first = first or (out, struct)
        if out.reason == TIME_LIMIT:
            break
    assert first is not None  # the loop over `order` ran at least once
    out, struct = first
    if (solver is None and eta is None and out.reason not in
            (INFEASIBLE, TIME_LIMIT)):
        for struct2 in order:
            found = _eta_search(plant, decay, margin, struct2, form, solver,
                                solver_options, deadline, gain)
            if found is not None:
                return found
    if (solver is None and structure0 == "full" and not chosen and fits
            and out.reason != TIME_LIMIT
            and (deadline is None or time.perf_counter() < deadline)):
        # The default call: the Riccati iteration solves the same exact
        # condition, and its divergence proves infeasibility, where an
        # interior-point method ends inaccurate or fails near the edge of
        # mean-square stability (the batch reactor at 0.97-0.9999 of the
        # critical loss, tests/test_synthesis_robustness.py).
        try:
            return _riccati(plant, eta, decay, margin, {})
        except SynthesisError as err:
            if err.reason == INFEASIBLE:
                err.figures.update(lmi_statuses=out.figures()["statuses"])
                raise
    reason = out.reason
    if reason == INFEASIBLE:
        # what the solver's status proves: the LMI *with its strictness
        # margin* has no solution; levels within about that margin of the
        # supremum may still have a certificate (the LMI is not homogeneous).
        # Only the exact LMI (structure 'full', gains on all the controller
        # observes) proves that no gain exists; a sufficient one proves
        # nothing about existence.
        exact = struct == "full" and fits
        if not exact:
            reason = SUFFICIENT_FAILED
        what = (f"{out.message}: no gain of this kind "
                + ("has a certificate" if exact else
                   f"passes the sufficient '{struct}' condition"
                   + ("" if fits else " with one gain for every previous "
                      "mode") + " (nothing is proven about other gains)")
                + f" with the strictness margin {margin:g} (relative) for "
                f"eta={'max' if eta is None else eta}, decay={decay}")
    else:
        what = (f"no verified gain ({out.message}, (margin, back-off) = "
                f"{[(margin * m, b) for m, b in RETRIES]})")
    raise SynthesisError(f"passivesyn: {what}", reason,
                         dict(out.figures(), structure=struct, margin=margin))


def _eta_search(plant, decay, margin, structure, form, solver, options,
                deadline, gain="mode"):
    """``η`` maximised by fixed-``η`` LMIs: the default call's fallback.

    Near the edge of mean-square stability the maximisation's optimum lies
    where interior-point answers are least accurate (the batch reactor at
    0.97 of the critical loss ends 'inaccurate'), while a fixed ``η``
    strictly below it is an interior problem. Levels ``u - 10^j / 100``
    below the feedthrough bound ``u = min_k λmin(D̄w + D̄wᵀ)/2`` are tried
    until one verifies, then the gap to the last refused level is bisected
    (``ETA_SEARCH_STEPS`` times). Every level's answer is verified exactly
    (``certify_index``: the returned ``η`` is what its ``P`` proves).
    Returns the result of the best verified level, or None.
    """
    u, _ = _feedthrough(plant)
    unit = max(1.0, abs(u))
    found = high = None

    def level(target):
        if deadline is not None and time.perf_counter() >= deadline:
            return None
        out, finish = _lmi_route(plant, target, decay, margin, structure,
                                 form, solver, options, deadline,
                                 supremum=True, gain=gain)
        return finish if out.ok else None

    for j in range(ETA_SEARCH_DECADES):
        target = u - unit * 10.0 ** (j - 2)
        finish = level(target)
        if finish is not None:
            found = (target, finish())
            break
        high = target
    if found is None:
        return None
    low, best = found
    for _ in range(ETA_SEARCH_STEPS if high is not None else 0):
        low = max(low, best.value)
        if high - low <= 1e-4 * max(1.0, abs(low)):
            break
        mid = 0.5 * (low + high)
        finish = level(mid)
        if finish is None:
            high = mid
        else:
            result = finish()
            if result.value > best.value:
                best = result
            low = mid
    return best


def _open_loop_bound(plant: JumpPlant, decay: float,
                     who: str = "passivesyn") -> None:
    """``SynthesisError('infeasible')`` when the modes no gain acts in
    already make the loop mean-square unstable (within ``r²``).

    In a mode with ``Bu_ki = 0`` (the loss took every input) or a phase
    with ``E_k = 0`` (nothing known), ``A_ki + Bu_ki K_k E_k = A_ki`` for
    every gain. The second-moment operator of any closed loop,
    ``X ↦ Σ_i p_ki Ā_ki X Ā_kiᵀ`` per phase, dominates the sum over those
    modes alone in the positive-semidefinite order, so its spectral radius
    (:ref:`theory-mss`) is at least that of the gain-independent part
    (monotonicity of the spectral radius of cone-preserving maps). When that
    part's per-step radius is ``≥ min(1, r²)`` no gain can be certified: a
    proof, with the figure on the error. A loss of exactly 1 on an unstable
    plant is the special case where every mode is gain-independent.
    """
    # the gain-independent part as a jump system of its own: the modes a
    # gain acts in contribute nothing to it (zero matrices), the law of the
    # modes is the plant's, so the one second-moment kernel measures it
    E = plant.readings()[0]
    acts = np.array([[bool(np.any(E[k, i]) and np.any(plant.Bu[k, i]))
                      for i in range(plant.probabilities.shape[1])]
                     for k in range(plant.period)])
    # a mode never drawn (probability 0; Markov: no transition enters it
    # at any phase) adds nothing to the second moments after the first
    # step: the operator is block triangular with a zero block there, and
    # the rate is the same without it
    drawn = plant.probabilities > 0 if plant.transition is None else \
        entered_modes(plant.transition)
    A = np.where((acts | ~drawn)[:, :, None, None], 0.0, plant.A)
    if not np.any(A):
        # a gain acts in every mode drawn: the part is zero, its rate 0
        # (ARPACK and GMRES on the nilpotent operator of a delayed loop
        # took minutes to say so)
        return
    n = plant.shape["nx"]
    alone = JumpStateSpace(A, np.zeros(A.shape[:3] + (1,)),
                           np.zeros(A.shape[:2] + (1, n)),
                           np.zeros(A.shape[:2] + (1, 1)),
                           None if plant.transition is not None
                           else plant.probabilities, plant.dt,
                           transition=plant.transition)
    rho = ms_radius(alone)
    bound = min(1.0, decay ** 2)
    # a clear margin over rounding (eigvals is backward stable)
    if rho >= bound * (1 + 1e-9):
        raise SynthesisError(
            f"{who}: infeasible: the network modes in which no gain "
            f"acts (every input lost, or nothing known) alone give a "
            f"second-moment rate of {rho:.6g} >= {bound:.6g} per step, and "
            f"every closed loop's rate is at least that: no gain makes the "
            f"loop mean-square stable"
            + (f" with decay {decay}" if decay < 1 else ""),
            INFEASIBLE, dict(ms_radius_without_control=rho, bound=bound,
                               proof="gain-independent modes"))


def _pair_certificate(P: np.ndarray, plant: JumpPlant, gains: np.ndarray,
                      CL: JumpStateSpace) -> np.ndarray:
    """``P_{k,ℓ}`` (shape (N, M, n, n)) as the certificate of the closed
    loop of gains ``K_{k,ℓ}`` on (lumped) pair modes (``JumpPlant.close``):
    a previous pair mode whose current plant mode was ``ℓ`` gets
    ``P_{k,ℓ}`` (:ref:`theory-markov`: ``P_{k,(ℓ',ℓ)} = P_{k,ℓ}``)."""
    if CL.modes.is_iid:
        # lumped to i.i.d. modes: a single class of ℓ at every phase
        return P[:, 0]
    cur = np.roll(plant.pair_modes(gains), 1, axis=0)   # [k] = modes at k-1
    return np.array([P[k][cur[k]] for k in range(P.shape[0])])


@dataclass(frozen=True)
class Balancing:
    """The state scaling ``x = T x̃``, ``T = diag(t)``, as an apply/invert
    pair: :meth:`apply` maps the plant into balanced coordinates, where the
    LMI is solved and its answer verified; :meth:`invert` maps the design
    back. ``t`` holds powers of two, so both ways are exact in floating
    point; ``t = None`` is the identity.
    """

    t: np.ndarray | None

    @classmethod
    def of(cls, plant: JumpPlant) -> "Balancing":
        """Balance ``Σ |A_ki|`` (plus the input and output matrices'
        weights on each state) like :func:`scipy.linalg.matrix_balance`: a
        similarity by powers of two keeps every zero pattern. Only for
        coordinate-selection ``E_k`` (then ``K = K̃ diag(E_k t)⁻¹``);
        otherwise the identity."""
        if not plant.is_selection():
            return cls(None)
        A = np.abs(plant.A).sum(axis=(0, 1))
        b = np.abs(np.concatenate([plant.Bu, plant.Bw], axis=-1)).sum(
            axis=(0, 1)).sum(axis=1)
        c = np.abs(plant.Cz).sum(axis=(0, 1)).sum(axis=0)
        return cls(balancing_scale(A, b, c, BALANCE_FROM))

    def apply(self, plant: JumpPlant) -> JumpPlant:
        """The plant in the coordinates ``x̃ = T⁻¹ x``."""
        if self.t is None:
            return plant
        t, inv = self.t, 1.0 / self.t
        return replace(plant, A=plant.A * inv[:, None] * t[None, :],
                       Bu=plant.Bu * inv[:, None], Bw=plant.Bw * inv[:, None],
                       Cz=plant.Cz * t[None, :])

    def invert(self, work: JumpPlant, gains: np.ndarray, X: np.ndarray,
               Y: np.ndarray, cert: Any) -> tuple:
        """A design found on ``apply(plant) = work``, for the plant:
        ``K_k = K̃_k diag(E_k t)⁻¹``, ``X_k = T X̃_k T``, ``Y_k = Ỹ_k T``,
        ``P_k = T⁻¹ P̃_k T⁻¹``."""
        t = self.t
        if t is None:
            return gains, X, Y, cert
        d = np.einsum("kjx,x->kj", work.E, t)
        d[d == 0] = 1.0
        if gains.ndim == 4:
            d = d[:, None]
        P = cert.P
        P = ([np.asarray(Pk) / t[:, None] / t[None, :] for Pk in P]
             if isinstance(P, list) else np.asarray(P) / t[:, None] / t[None, :])
        return (gains / d[..., None, :], X * t[:, None] * t[None, :], Y * t,
                replace(cert, P=P))


def _lmi_route(plant, eta, decay, margin, structure, form, solver, options,
               deadline, supremum=False, gain="mode"):
    """The LMI of ``structure``, through the one driver (``driver.drive``).

    Returns the driver's outcome and a function building the result. The
    LMI is solved in balanced coordinates (:class:`Balancing`); gains and
    certificates are mapped back by its inverse and verified exactly on the
    original plant.
    """
    balancing = Balancing.of(plant)
    work = balancing.apply(plant)
    scale_of_data = data_scale(work.A, work.Bu, work.Bw, work.Cz, work.Du,
                               work.Dw)

    def attempt(scale, target, name, left):
        model = synthesis_model(work, target, decay, margin * scale,
                                structure, form, gain)
        extra = {} if left is None else dict(time_limit=left)
        # the caller's options are for the solver the caller chose
        report = solve(model.problem, name,
                       **(options if name == solver else {}), **extra)
        if report.status not in ("optimal", "optimal_inaccurate"):
            return report, None
        level = report.value if target is None else target
        if level is not None and level < -ETA_FLOOR * scale_of_data:
            report.message = (f"eta = {level:.3g} lies below -ETA_FLOOR x "
                              f"the data's scale ({-ETA_FLOOR * scale_of_data:.3g}"
                              "): not a verifiable answer")
            return report, None
        try:
            gains, Pc = read_gains(model, work)
            X, Y = _variables(model, work)
        except (np.linalg.LinAlgError, TypeError, ValueError):
            return report, None  # no usable values (e.g. X singular)
        if not (np.all(np.isfinite(gains)) and np.all(np.isfinite(Pc))):
            return report, None
        return report, dict(gains=gains, P=Pc, X=X, Y=Y, width=model.width)

    def verify(c):
        # Verified where it was solved: with T = diag(t) of powers of two,
        # every product and sum of work.close() is the original's times
        # t_j / t_i exactly (scaling by 2^k commutes with rounding, barring
        # over/underflow), so Θ̃_k = diag(T, I) Θ_k diag(T, I) exactly: a
        # congruence (same inertia, Sylvester), the same Schur complement in
        # w (same certified η), and a similar second-moment operator (same
        # ms_radius). In the original coordinates the eigenvalue test's
        # rounding bound grows with ‖P‖ and can refuse a true certificate.
        CL = work.close(c["gains"])
        P = c["P"]
        if c["gains"].ndim == 4:
            P = _pair_certificate(P, work, c["gains"], CL)  # the pair loop's
        elif P.ndim == 4 and CL.modes.is_iid:
            # equal rows: one class per phase, and the loop is i.i.d.
            P = P[:, 0]
        if eta is None or supremum:
            cert = certify_index(CL, P, decay=decay)
            if eta is None or cert.verified:
                return cert
        return check_certificate(CL, P, eta, decay=decay)

    out = drive(attempt, verify, eta=eta, solver=solver, deadline=deadline,
                label=f"passivesyn LMI ({structure})")

    def finish():
        c, cert = out.candidate, out.certificate
        gains, X, Y, cert = balancing.invert(work, c["gains"], c["X"],
                                             c["Y"], cert)
        return passive_design(plant, X, Y, gains, plant.close(gains), cert,
                              cert.eta, out.eta_solver, decay, form,
                              structure, c["width"], out.report,
                              out.attempts, route="program", method="lmi")

    return out, finish


def _variables(model, plant):
    """The LMI's ``X`` and ``Y`` (zero-padded to ``nu × nx``): shape
    ``(N, ., .)``, or ``(N, M, ., .)`` per previous mode (Markov)."""
    model.check_current()
    s = plant.shape
    N = plant.period
    Ys = np.zeros((N, max(map(len, model.X_classes)), s["nu"], s["nx"]))
    Xs = np.zeros((N, Ys.shape[1], s["nx"], s["nx"]))
    for k in range(N):
        for c, Xv in enumerate(model.X_classes[k]):
            Xs[k, c] = np.asarray(Xv.value, float)
            Yv = model.Y_classes[k][c]
            if Yv is not None:
                known, active, _ = model.blocks_classes[k][c]
                Ys[k, c][np.ix_(active, known)] = Yv.value
    if not model.markov:
        return Xs[:, 0], Ys[:, 0]
    idx = np.array(model.classes)
    rows = np.arange(N)[:, None]
    return Xs[rows, idx], Ys[rows, idx]


def _riccati_options(options):
    """The Riccati iteration's options, checked at the boundary: unknown
    names (TypeError) and bad values (ValueError naming them)."""
    unknown = set(options) - set(RICCATI_OPTIONS)
    if unknown:
        raise TypeError(
            f"passivesyn() got solver option(s) {sorted(unknown)} not "
            f"accepted by options['solver'] = 'riccati' (known: "
            f"{list(RICCATI_OPTIONS)})")
    for name in ("max_sweeps", "probe_sweeps"):
        if name in options:
            positive_int(options[name], name)
    if "rtol" in options:
        positive_real(options["rtol"], "rtol")


def _riccati(plant, eta, decay, margin, options):
    """The Riccati route (``structure='full'``), checked like the LMI's."""
    _riccati_options(options)
    res = riccati_synthesis(plant, eta, decay=decay, margin=margin, **options)
    report = SolveReport("optimal", "RICCATI", 0.0, res.time, res.time,
                         res.sweeps, res.eta, options=dict(options))
    CL = plant.close(res.gains)
    # Markov modes: K_{k,ℓ}, checked on the pair-mode loop (theory: Markov
    # losses)
    Pv = (_pair_certificate(res.P, plant, res.gains, CL)
          if res.gains.ndim == 4 else res.P)
    cert = (certify_index(CL, Pv, decay=decay) if eta is None
            else check_certificate(CL, Pv, eta, decay=decay))
    if not cert.verified:
        raise SynthesisError(
            "passivesyn: no verified gain (the Riccati gain fails the exact "
            "check: " + "; ".join(cert.failures) + ")", NOT_VERIFIED,
            dict(status=report.status, solver=report.solver,
                 statuses=[report.status], **cert.figures()))
    s = plant.shape
    X = np.linalg.inv(res.P)
    X = 0.5 * (X + np.swapaxes(X, -1, -2))
    # K_k E_k is the full gain (E_k selects every coordinate)
    if res.gains.ndim == 4:
        Y = np.einsum("kluj,kjx,klxy->kluy", res.gains, plant.E, X)
    else:
        Y = np.einsum("kuj,kjx,kxy->kuy", res.gains, plant.E, X)
    return passive_design(plant, X, Y, res.gains, CL, cert, cert.eta,
                          res.eta if eta is None else eta, decay, "merged",
                          "full", s["nx"] + s["nw"], report, [report],
                          route="riccati", method="riccati")
