"""Positive-real (passive) synthesis over a lossy network
(:ref:`theory-synthesis`, :ref:`theory-predictor`, :ref:`theory-markov`).

``K, CL, eta = passivesyn(P, ...)`` in the manner of :func:`control.hinfsyn`.
The LMI is built for the generic plant of :ref:`theory-jump-system`
(``lmi.py``), so every controller kind and schedule goes through one code path;
every gain returned has passed the exact checks of ``verify.py``. Loops whose
gain sees the whole state (``structure='full'``) can instead go through the
monotone Riccati iteration of ``riccati.py`` (``solver='riccati'``, chosen
automatically above ``RICCATI_THRESHOLD`` states); its gains pass the same
checks. Over bursty (Markov) links both routes design gains ``K_{k,ℓ}`` on
the previous network mode (:ref:`theory-markov`), checked on the closed loop on
pair modes (:meth:`control_ncs.jump.JumpPlant.close`).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import (caller_stacklevel, choice, decay_bound, finite_real,
                      positive_int, positive_real, real_array)
from .stability import ms_radius
from .gain import PeriodicGain, actuators, controllers
from .jump import JumpStateSpace
from .openloop import JumpPlant
from .driver import RETRIES, drive
from .lmi import (DEFAULT_MARGIN, GAINS, SolveReport, balancing_scale,
                  check_options, check_solver, data_scale, gain_kinds,
                  read_gains, solve, synthesis_model)
from .plant import NetworkedStateSpace
from .refine import _refine, autonomous_rate
from .riccati import riccati_synthesis
from .strategies import build, require_state_measured
from .exceptions import (CERTIFIED, CERTIFIED_SHORTAGE, INFEASIBLE, MESSAGES,
                         NOT_FOUND,
                         NOT_VERIFIED, SOLVER_FAILED, SUFFICIENT_FAILED,
                         TIME_LIMIT, NotPassiveWarning, SynthesisError)
from .verify import (Certificate, certify_index, check_certificate,
                     feedthrough_bound, level_floor)

__all__ = ["passivesyn", "SynthesisResult"]

#: Above this many states (structure 'full', no solver options) the default
#: call takes the Riccati iteration: it wins from n = 10 on (benchmarks §2).
RICCATI_THRESHOLD = 8

#: Up to this many states an inconclusive automatic Riccati iteration is
#: followed by the LMI, still affordable there (benchmarks §1).
RICCATI_FALLBACK_MAX = 16

#: Options of the Riccati route (``solver='riccati'``), passed through
#: ``**solver_options``; any other raises TypeError.
RICCATI_OPTIONS = ("rtol", "max_sweeps", "probe_sweeps")

#: Default time budget of :func:`passivesyn`, seconds.
TIME_BUDGET = 120.0

#: Balance the state (powers of two, exact) before the LMI only when the
#: scales found spread by at least this factor.
BALANCE_FROM = 16.0

#: A maximised η below -ETA_FLOOR × the data's scale is a solver failure:
#: there 2ηI swamps the LMI and no certificate verifies in double precision.
ETA_FLOOR = 1e8

#: The default call's fixed-η search: decades below the feedthrough bound,
#: then bisection steps after the first verified level.
ETA_SEARCH_DECADES = 10
ETA_SEARCH_STEPS = 12

FORMS = ("merged", "paper")
STRUCTURES = ("auto", "full", "block", "extended")
#: ``passivesyn(method=...)``: 'auto' takes the LMI where it is exact
#: (structure 'full') and the refinement of :mod:`control_ncs.refine` where
#: it is only sufficient (structure left to 'auto' on a structured loop).
METHODS = ("auto", "lmi", "refine")


#: What helps a design whose certified level is negative (see
#: :class:`~control_ncs.exceptions.NotPassiveWarning`).
_SHORTAGE_HELP = ("a larger feedthrough D11 from w to z, a weaker decay "
                  "requirement or less loss on the links would raise eta")


@dataclass
class SynthesisResult:
    """Everything :func:`passivesyn` knows about the gain it returned.

    The gain is applied as is, ``u = K_k ŷ`` (positive feedback; a
    :func:`control.dlqr` gain, for ``u = -K x``, must be negated).

    Attributes
    ----------
    gain : PeriodicGain
        ``K_k``, applied as ``u = K_k ŷ``.
    eta : float
        Certified dissipation (the one returned): the requested one, or the
        supremum the certificate proves less the first back-off of
        ``verify.INDEX_BACKOFFS`` (1e-6, 1e-5, 1e-4, times ``max(1, |sup|)``:
        absolute below 1) that passes the exact check
        (:func:`control_ncs.verify.certify_index`).
    eta_solver : float
        The solver's objective value (``η`` maximised), or the requested one;
        for the Riccati route, the level its bisection reached; for the
        fixed-``η`` search of the default call, the highest level that
        verified (a lower bound, not an optimum).
    decay : float
        Decay bound ``r`` (1 = none); ``ms_radius < r²`` is checked.
    certificate : Certificate
        ``P_k = X_k⁻¹`` (in the plant's coordinates) and the exact figures:
        ``λmax(Θ_k)``, ``λmin(P_k)``, ``ms_radius``, ``eta_sup``. For an LMI
        solved in balanced coordinates ``x = T x̃`` the figures are those
        of the exact check there (``Θ̃_k`` is congruent to ``Θ_k``: same
        signs; ``ms_radius`` is the same).
    X, Y : ndarray
        LMI variables per phase (``Y`` zero-padded to ``(N, nu, nx)``;
        Markov links: per phase and previous mode, ``(N, M, ., .)``); for
        the Riccati route ``X_k = P_k⁻¹`` and ``Y_k = K_k X_k`` (the LMI
        variables its certificate corresponds to).
    form : {'merged', 'paper'}
        The LMI's form; ``'merged'`` for the Riccati route (``form`` is
        ignored there: modes are always merged).
    structure : {'full', 'block', 'extended'}
        Which LMI certified the gain: ``'full'`` is exact (feasible iff a
        certified gain exists); ``'block'`` and ``'extended'`` are sufficient.
    gain_kind : {'phase', 'mode'}
        Which kind of gain was certified: ``K_k`` per phase, or
        ``K_{k,ℓ}`` per phase and previous network mode (Markov links,
        :ref:`theory-markov`; the closed loop is then a jump system on pair
        modes ``(ℓ, i)`` and ``certificate.P`` is ``P_{k,(ℓ',ℓ)} = P_{k,ℓ}``).
        On Markov links ``'phase'`` is sufficient only.
    note : str
        Why the call took another route than asked or than usual (e.g. the
        Riccati iteration is written for i.i.d. modes: Markov links fall
        back to the LMI), or ''.
    width : int
        Side of each LMI block ``Ψ_k``; for the Riccati route, the side
        ``n + m1`` of the matrices ``Θ_k`` it certifies (it works with
        ``n × n`` matrices only).
    report : SolveReport
        Solver, status, compile and solve times of the successful solve.
        Riccati route: solver ``'RICCATI'``, status ``'optimal'``, compile
        time 0, solve time = the iteration's, ``iterations`` = its sweeps.
    attempts : list of SolveReport
        Every solve made, including retries.
    plant : JumpPlant
        The open-loop jump system that was designed for.
    method : {'lmi', 'refine'}
        What certified the gain: ``'lmi'`` the synthesis LMI (or the
        Riccati route, see ``report.solver``); ``'refine'`` the local
        refinement of :func:`control_ncs.refine.refine_gain`, its gain
        certified by the analysis of its closed loop (then ``X_k = P_k⁻¹``,
        ``Y_k = K_k E_k X_k``, ``report.solver`` is ``'REFINE'`` and
        ``structure`` names the loop's sufficient LMI, whose gain was the
        first start when it had one).
    start : str or None
        Refinement only: the starting point that led to the gain
        (``'lmi'``, ``'full'``, ``'zero'``, ``'continuation'``,
        ``'restart'``).
    refinement : RefineResult or None
        Refinement only: how far it moved the gain (``ms_radius_before``,
        ``ms_radius``, ``eta_before``, ``eta``, ``iterations``,
        ``message``).
    exact : bool
        True when the condition that certified the gain is also necessary
        (the LMI with structure ``'full'`` and gains on all the controller
        observes): no gain of this kind certifies a level above ``eta`` by
        more than the LMI's margin. False for sufficient LMIs and for
        the refinement (a local method).

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.1)
    >>> K, CL, eta = ncs.passivesyn(P, eta=0.0, decay=0.9)
    >>> res = K.result
    >>> res.structure, res.certificate.verified, bool(res.ms_radius < 0.81)
    ('full', True, True)
    """

    gain: PeriodicGain
    eta: float
    eta_solver: float
    decay: float
    certificate: Certificate
    X: np.ndarray
    Y: np.ndarray
    form: str
    structure: str
    width: int
    report: SolveReport
    attempts: list = field(default_factory=list)
    plant: JumpPlant | None = None
    gain_kind: str = "phase"
    note: str = ""
    method: str = "lmi"
    start: str | None = None
    refinement: Any = None
    exact: bool = False

    @property
    def ms_radius(self) -> float:
        """The closed loop's exact ``ms_radius`` (from the certificate)."""
        return self.certificate.ms_radius

    @property
    def success(self) -> bool:
        """True: :func:`passivesyn` returns only certified gains."""
        return True

    @property
    def verdict(self) -> bool:
        """``success``, under its older name."""
        return self.success

    @property
    def passive(self) -> bool:
        """True when the certified level is passive (``η ≥ 0``).

        A negative ``η`` is certified too, but it is an input-feedforward
        shortage: the loop is mean-square stable and dissipative, not
        passive.
        """
        return self.eta >= 0.0

    @property
    def status(self) -> str:
        """``'certified'``, or ``'certified_shortage'`` when ``η < 0``."""
        return CERTIFIED if self.passive else CERTIFIED_SHORTAGE

    @property
    def message(self) -> str:
        """One sentence: what the certificate proves."""
        text = (f"{MESSAGES[self.status]} (eta = {self.eta:.6g}, ms_radius = "
                f"{self.ms_radius:.6g}, structure {self.structure}, "
                f"{self.gain_kind} gains)")
        if not self.passive:
            text += f"; the loop is not passive ({_SHORTAGE_HELP})"
        return text

    def __repr__(self) -> str:
        return (f"<SynthesisResult: {self.status}, eta = {self.eta:.6g}, "
                f"N = {self.gain.period}, controller {self.gain.controller}, "
                f"actuator {self.gain.actuator}, structure {self.structure}, "
                f"{self.gain_kind} gains, "
                f"solver {self.report.solver}: {self.report.status}>")

    def summary(self) -> str:
        """A few lines for humans: the figures that prove the result.

        Returns
        -------
        str
        """
        r = self.report
        lines = [f"SynthesisResult: {self.status}",
                 f"  {self.message}",
                 f"  controller={self.gain.controller!r}, "
                 f"actuator={self.gain.actuator!r}, N={self.gain.period}, "
                 f"form={self.form}, structure={self.structure}, "
                 f"gain={self.gain_kind}",
                 f"  certified eta = {self.eta:.6g} (solver "
                 f"{self.eta_solver:.6g})",
                 f"  solver {r.solver}: {r.status}, compile "
                 f"{r.compile_time:.3f} s, solve {r.solve_time:.3f} s, "
                 f"{len(self.attempts)} attempt(s)"]
        if self.gain.estimator_gain is not None:
            # theory: output feedback: the loop's rate is the larger of these
            # two loops'
            lines.append(f"  estimator gain L_k of shape "
                         f"{self.gain.estimator_gain.shape} (N_L, n, nmeas)")
        if self.note:
            lines.append(f"  note: {self.note}")
        lines += ["  " + line for line in
                  self.certificate.summary().splitlines()]
        return "\n".join(lines)


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
    if plant.E.shape != (N, nk, nx) or min(nx, nu) == 0:
        raise ControlDimension(
            f"P: JumpPlant.E must have shape (N, nk, nx) = {(N, nk, nx)} "
            f"with nx, nu > 0, got E {plant.E.shape}, nu = {nu}")
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


def _checks(P, eta, decay, controller, actuator, form, structure, plant,
            gain="mode"):
    if isinstance(P, JumpPlant):
        _plant_arrays(plant)
        if not plant.is_selection():
            raise ControlArgument(
                "P: synthesis needs each E_k to be a coordinate selection "
                "(what the controller knows of the state, theory: jump system)")
    elif not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()) "
                              f"or a JumpPlant (see build()), got "
                              f"{type(P).__name__}")
    m1, p1 = plant.shape["nw"], plant.shape["nz"]
    if m1 != p1 or m1 == 0:
        raise ControlDimension(
            f"P: passivity needs w and z of equal, nonzero size (paper eq. 1 "
            f"with m1 = p1), got {m1} disturbance inputs and {p1} performance "
            "outputs")
    eta = finite_real(eta, "eta", allow_none=True)
    if eta is not None:
        bound, _ = _feedthrough(plant)
        if not bound > eta:
            raise ValueError(
                f"eta: D11 + D11ᵀ ≻ 2·eta·I is necessary (paper's Assumption 1, "
                f"theory: passivity), but λmin(D11 + D11ᵀ)/2 = {bound:.6g} ≤ eta = "
                f"{eta:.6g}")
    decay = decay_bound(decay)
    choice(form, "form", FORMS)
    choice(gain, "gain", GAINS)
    choice(structure, "structure", STRUCTURES)
    # the loop closes where some phase knows a coordinate and can act
    if not any(plant.known_coordinates(k).size and plant.active_inputs(k).size
               for k in range(plant.period)):
        raise ValueError(
            "P: the gain never closes this loop: no phase schedules a sensor "
            "and an actuator together (theory: static-gain loop)"
            + (". Use controller='predictor'." if controller == "static"
               else ""))
    structured = any(plant.known_coordinates(k).size < plant.shape["nx"]
                     for k in range(plant.period))
    if structure == "auto":
        structure = "extended" if structured else "full"
    elif structure == "full" and structured:
        raise ValueError(
            "structure: 'full' needs every state known at every phase; this "
            f"loop (controller={controller!r}, sensor schedule) needs 'block' "
            "or 'extended' (theory: synthesis)")
    return eta, decay, structure


def passivesyn(P: NetworkedStateSpace | JumpPlant, eta: float | None = None, *,
               decay: float | None = None, controller: str = "static",
               actuator: str = "zero", form: str = "merged",
               structure: str = "auto", gain: str = "mode",
               solver: str | None = None,
               margin: float = DEFAULT_MARGIN,
               time_limit: float | None = TIME_BUDGET,
               estimator_gain: Any = None, method: str = "auto",
               initial_gain: Any = None,
               **solver_options: Any
               ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """Periodic feedback making a networked loop strictly passive.

    The gain is applied as is, ``u = K_k x`` (positive feedback: no minus
    sign, unlike :func:`control.dlqr` / :func:`control.lqr`, whose ``K``
    is for ``u = -K x``; negate such a gain before using it here, see the
    Examples).

    Solves the LMI of :ref:`theory-synthesis` (paper Theorem 1, corrected) for
    ``X_k ≻ 0``, ``Y_k`` and, when ``eta`` is None, the largest dissipation
    ``η``; reads ``K_k = Y_k X_k⁻¹`` (or ``Y_k G_k⁻¹`` in the extended form);
    then checks the closed loop exactly: ``λmax(Θ_k) < 0`` with ``P_k = X_k⁻¹``
    for every phase and ``ms_radius < 1`` (``< r²`` with ``decay=r``). A gain
    that fails is never returned. Over Markov (Gilbert–Elliott) links the LMI
    is :ref:`theory-markov`'s, with ``X_{k,ℓ}``, ``Y_{k,ℓ}`` per previous mode
    ``ℓ`` (see ``gain``), and the check is ``Θ_{k,ℓ}`` of the closed loop on
    pair modes with ``P_{k,(ℓ',ℓ)} = X_{k,ℓ}⁻¹``.

    The LMI is solved in balanced coordinates (a diagonal similarity by
    powers of two, exact in floating point) and every solve goes through
    one solve-and-verify loop (:func:`control_ncs.driver.drive`: retries
    ``RETRIES``, then once ``lmi.FALLBACK_SOLVER``). Without ``solver=``
    and with ``eta=None``, when the maximisation gives no verified gain,
    fixed levels of ``η`` are tried (``_eta_search``) and, for structure
    ``'full'``, the Riccati iteration; under ``structure='auto'`` a loop
    that resolves to ``'extended'`` is also tried with ``'block'``.
    Progress (each attempt) is logged on the ``'control_ncs'`` logger at
    level INFO (``logging.basicConfig(level=logging.INFO)`` shows it).

    Parameters
    ----------
    P : NetworkedStateSpace or JumpPlant
        Plant with its network; needs ``dim w = dim z`` and, except for
        ``controller='estimator'``, ``y = x``. Or
        the open-loop jump system a strategy built
        (:func:`control_ncs.build`, or one made by hand with selection
        matrices ``E_k``): then ``controller`` and ``actuator`` only label
        the gain (its ``info`` names them, if it does).
    eta : float, optional
        Dissipation to achieve; None maximises it. Maximising drives the
        mean-square margin towards zero (``ms_radius → 1``); bound it with
        ``decay``. A level below :func:`control_ncs.verify.level_floor`
        (``verify.LEVEL_FLOOR`` data scales below the feedthrough bound) is
        solved and checked at that floor ``η0``: as ``Θ(η) ≼ Θ(η0)``, the
        certificate at ``η0`` (``K.result.certificate.eta``) certifies the
        requested ``η`` exactly, and ``η`` is returned.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r``: ``E‖x_t‖²`` decays at least like
        ``r^(2t)``, i.e. ``ms_radius < r²``.
    controller : {'static', 'predictor', 'estimator'}
        The paper's memoryless gain, the model-based predictor of
        :ref:`theory-predictor` (needed under a shared channel), or the
        estimator-based controller of :ref:`theory-output-feedback` for
        ``y = C2 x`` with any ``C2`` (the predictor corrected through ``L_k``;
        ``K.estimator_gain`` holds ``L_k`` and :func:`control_ncs.feedback`
        closes the same loop). ``'static'`` and ``'predictor'`` need ``y = x``.
    actuator : {'zero', 'hold'}
        What actuators apply when their message is lost or not addressed.
    form : {'merged', 'paper'}
        ``'merged'`` (default): coinciding network modes merged, LMI side
        ``n + m1 + 2n`` for the static gain; ``'paper'``: one row per mode
        (eq. 15), side ``n + m1 + 4n``. Both give the same optimum.
    structure : {'auto', 'full', 'block', 'extended'}
        ``'auto'``: ``'full'`` (exact) when the controller knows every
        coordinate at every phase, else ``'extended'``. ``'block'`` and
        ``'extended'`` are sufficient conditions (:ref:`theory-synthesis`).
    gain : {'mode', 'phase'}
        Markov (bursty) links, :ref:`theory-markov`: ``'mode'`` (default)
        designs gains ``K_{k,ℓ}`` that also use the previous network mode
        ``ℓ = σ_{k-1}`` (known through acknowledgements and arrivals;
        exact with structure ``'full'``), returned as a 4-D
        :class:`PeriodicGain` of shape ``(N, M, m2, nk)``; ``'phase'``
        designs ``K_k`` for every ``ℓ`` (sufficient: a common slack
        ``G_k``, or a common ``X_k`` with ``structure='block'``). For
        i.i.d. links both are the LMI of :ref:`theory-synthesis` and the gain
        is ``K_k``. ``K.result.gain_kind`` says which kind was certified.
    solver : str, optional
        An installed cvxpy solver for the LMI, or ``'riccati'``
        (case-insensitive) for the monotone Riccati iteration of
        :mod:`control_ncs.riccati` (needs ``structure`` to resolve to
        ``'full'``; no cvxpy, memory ``O(N n²)``; ``form`` does not apply to
        it). None (default): the Riccati iteration when the structure
        resolves to ``'full'``, the plant has more than
        ``RICCATI_THRESHOLD`` states and no solver options are given (if
        that iteration is inconclusive and the plant has at most
        ``RICCATI_FALLBACK_MAX`` states, Clarabel after it), else Clarabel.
        Over Markov links the iteration solves the coupled Riccati
        equations (gains ``K_{k,ℓ}``); with ``gain='phase'`` the LMI is
        solved instead (``K.result.note`` says so).
    margin : float, optional
        Relative strictness margin of the LMIs (for the Riccati iteration:
        the ``εI`` added at each step, relative to the data's scale).
    time_limit : float or None, optional
        Time budget in seconds (default ``TIME_BUDGET`` = 120 s; None: no
        limit). The remaining time is passed to Clarabel
        (``time_limit``); the budget is checked between attempts. A
        Riccati iteration already running is not interrupted.
    estimator_gain : array_like or EstimatorGain, optional
        ``controller='estimator'`` only: ``L_k`` of shape ``(n, nmeas)`` or
        ``(N_L, n, nmeas)`` (e.g. from :func:`control.dlqe`); default
        :func:`control_ncs.estimator_gain` ``(P, decay=decay)`` with the
        LMI ``solver`` if one is named.
    method : {'auto', 'lmi', 'refine'}
        ``'lmi'``: the synthesis LMI (or Riccati) routes above.
        ``'refine'``: the local refinement of
        :func:`control_ncs.refine.refine_gain` on the exact ``ms_radius``
        and the analysis LMI's η, started from the sufficient LMI's gain
        when it has one (up to ``synthesis.LMI_START_MAX_STATES`` states),
        the unstructured gain restricted, a continuation in the loss; its
        gain is certified by the analysis of its closed loop, locally
        improved, never globally optimal, and its failure proves nothing.
        ``'auto'`` (default): ``'lmi'`` where the LMI is exact (structure
        ``'full'`` with gains on everything the controller observes) and
        where a structure, a solver or solver options are named;
        ``'refine'`` wherever the LMI is only sufficient, on Bernoulli and
        Markov links alike. On Markov links the refinement designs gains
        per phase ``K_k`` (explicit ``'refine'`` needs ``gain='phase'``);
        under ``'auto'`` the LMI's gains ``K_{k,ℓ}`` compete with it and
        the higher certified η is returned.
    initial_gain : PeriodicGain or array_like, shape (N, m2, nk), optional
        A gain per phase to start the refinement from, in place of the
        sufficient LMI's gain (which is then not solved), e.g. a
        neighbouring design of a map (``design_map`` warm-starts its cells
        so). Used where the refinement runs.
    **solver_options
        Passed to the solver, checked first: an option Clarabel (its
        ``DefaultSettings``), SCS or CVXOPT does not know raises
        ``TypeError``. For ``solver='riccati'``: ``rtol``
        (bisection tolerance on ``η``, default 1e-4), ``max_sweeps``
        (default 20000), ``probe_sweeps`` (per bisection level, default
        3000); see :func:`control_ncs.riccati.riccati_synthesis`.

    Returns
    -------
    K : PeriodicGain
        ``K.gains`` has shape ``(N, m2, nk)``, or ``(N, M, m2, nk)`` for
        gains on the previous mode (Markov links, ``gain='mode'``), applied
        as ``u = K_k ŷ`` (no minus sign); ``K.result`` is the
        :class:`SynthesisResult`.
    CL : JumpStateSpace
        The closed loop ``w → z``; ``CL.info['synthesis']`` is the result.
    eta : float
        The certified dissipation (the requested one, or the certified
        maximum).

    Raises
    ------
    SynthesisError
        ``reason`` and ``figures`` say why. Only ``'infeasible'``,
        ``'not_mss'`` and ``'feedthrough'`` prove that no gain exists.
        ``'infeasible'``: the solver's exact status 'infeasible' for the
        *exact* LMI (structure ``'full'`` with gains on all the controller
        observes; never an ``*_inaccurate`` status; the solver's
        infeasibility certificate, not re-checked, covering the LMI *with*
        its strictness ``margin`` — a level within about the margin of the
        supremum may still have a certificate), a diverging Riccati
        iteration (likewise with its margin), or the gain-independent
        network modes alone having ``ms_radius ≥ 1`` (``≥ r²``; e.g. a loss
        of exactly 1 on an unstable plant; figure
        ``ms_radius_without_control``). ``'sufficient_failed'``: a
        sufficient LMI (structured gains, a hold actuator, the predictor,
        gains common to previous modes) has no solution, which proves
        nothing about other gains; ``'not_found'``: the refinement found no
        certified gain; a crash inside a route is ``'solver_failed'`` with
        the error in ``figures['error']``; ``'solver_failed'``,
        ``'inaccurate'``, ``'not_verified'`` after the retries
        (``RETRIES``), the fallback solver and, for the default call, the
        fallbacks above; ``'time_limit'`` when ``time_limit`` ran out.
        ``'infeasible'`` also when a given ``estimator_gain``'s error loop
        is not mean-square stable (within ``r²``): by separation no ``K``
        helps (:ref:`theory-output-feedback`). Riccati route: ``'infeasible'``
        when some ``R_k`` loses positive definiteness (a proof that the LMI
        with its margin is infeasible), ``'solver_failed'`` when it runs out of
        sweeps or ``P`` grows beyond what double precision can certify
        (inconclusive), ``'not_verified'`` when its gain fails the exact checks
        (no retries).
        Refinement (``method``): ``'infeasible'`` only when states that no
        input reaches evolve on their own with ``ms_radius ≥ 1`` (``≥ r²``;
        figures ``ms_radius_without_control``, ``proof='autonomous
        subsystem'``, e.g. a predictor's estimation error); a refinement
        that certifies nothing raises ``'not_found'`` or ``'time_limit'``,
        never ``'infeasible'``.
    ValueError, ControlDimension, ControlArgument
        The pre-solve checks: ``dim w ≠ dim z``, ``D11 + D11ᵀ ⊁ 2ηI``,
        ``y ≠ x`` (``'static'``, ``'predictor'``), a static gain that can
        never close the loop; for ``'estimator'``: ``(A, B2)`` not
        stabilisable through the actuator schedule or ``(A, C2)`` not
        detectable through the sensor schedule (lifted PBH tests),
        ``estimator_gain`` given to another controller;
        ``solver='riccati'`` for a loop whose structure is not ``'full'``.
    TypeError
        A solver option the chosen solver (or the Riccati iteration) does
        not know.

    Warns
    -----
    NotPassiveWarning
        When ``eta`` is maximised and the best certified level is negative:
        the loop is certified mean-square stable and dissipative with an
        input-feedforward shortage, not passive (``K.result.status`` is
        ``'certified_shortage'``).

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).
    .. [2] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [3] S. Boyd, L. El Ghaoui, E. Feron and V. Balakrishnan, *Linear Matrix
           Inequalities in System and Control Theory*, SIAM, 1994.
    .. [4] S. Bittanti and P. Colaneri, *Periodic Systems: Filtering and
           Control*, Springer, 2009 (periodic Riccati equations and their
           iterations).

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.1)
    >>> K, CL, eta = ncs.passivesyn(P, decay=0.9)
    >>> K.result.certificate.verified, bool(ncs.ms_radius(CL) < 0.81)
    (True, True)

    The same by the Riccati iteration:

    >>> K, CL, eta = ncs.passivesyn(P, decay=0.9, solver='riccati')
    >>> K.result.report.solver, bool(ncs.ms_radius(CL) < 0.81)
    ('RICCATI', True)

    A gain from :func:`control.dlqr` is for ``u = -K x``: negate it.

    >>> import control as ct
    >>> import control_ncs as ncs
    >>> Klqr, _, _ = ct.dlqr([[2.0]], [[1.0]], [[1.0]], [[1.0]])
    >>> CL = ncs.feedback(P, ncs.PeriodicGain(-Klqr))
    >>> bool(ncs.ms_radius(CL) < 1)
    True

    A bursty actuator link (6 % loss in bursts of 1/0.9 steps): gains on the
    previous mode, 4 of them for the modes ``(θ1, θ2)``.

    >>> P3 = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...          nmeas=1, ncon=1, actuator_loss=ncs.gilbert_elliott(fail=0.06,
    ...                                                         recover=0.9))
    >>> K, CL, eta = ncs.passivesyn(P3, decay=0.9)
    >>> K.gains.shape, K.result.gain_kind, bool(ncs.ms_radius(CL) < 0.81)
    ((1, 4, 1, 1), 'mode', True)

    Only ``x[0]`` measured (``C2 = [1 0]``): the estimator-based design.

    >>> P2 = ncs.nss([[1.2, 1.0], [0.0, 0.5]], [[1.0, 0.0], [0.0, 1.0]],
    ...          [[1.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...          nmeas=1, ncon=1, sensor_loss=0.1)
    >>> K, CL, eta = ncs.passivesyn(P2, controller='estimator', decay=0.99)
    >>> K.estimator_gain.shape, K.result.certificate.verified
    ((1, 2, 1), True)
    >>> bool(ncs.ms_radius(ncs.feedback(P2, K)) == ncs.ms_radius(CL))
    True
    """
    if controller == "lti":
        raise ControlArgument(
            "controller: passivesyn designs gains ('static', 'predictor', "
            "'estimator'); an LTI controller ('lti') is given, not designed: "
            "analyse it with feedback(P, K)")
    choice(controller, "controller", controllers())
    choice(actuator, "actuator", actuators())
    choice(method, "method", METHODS)
    if initial_gain is not None:
        initial_gain = real_array(
            initial_gain.gains if isinstance(initial_gain, PeriodicGain)
            else initial_gain, "initial_gain", ndim=3)
    if estimator_gain is not None and (controller != "estimator"
                                       or isinstance(P, JumpPlant)):
        raise ControlArgument(
            "estimator_gain: only controller='estimator' on a "
            "NetworkedStateSpace takes an estimator gain (a JumpPlant "
            "already holds it)")
    # cheap checks first: the estimator design solves an LMI before the
    # plant exists, and its time counts against the budget
    margin = positive_real(margin, "margin")
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    deadline = None if time_limit is None else time.perf_counter() + time_limit
    if isinstance(P, JumpPlant):
        # the gain's labels: the strategy that built the plant, if named
        controller = P.info.get("controller", controller)
        actuator = P.info.get("actuator", actuator)
        plant = JumpPlant(P.A, P.Bu, P.Bw, P.Cz, P.Du, P.Dw, P.E,
                          P.probabilities, P.dt, nominal=P.nominal,
                          transition=P.transition,
                          inputs=P.inputs, outputs=P.outputs,
                          states=P.states, info=dict(
                              P.info, controller=controller,
                              actuator=actuator))
    elif isinstance(P, NetworkedStateSpace):
        if controller == "estimator":
            plant = _estimator_plant(P, actuator, estimator_gain, decay,
                                     solver)
        else:
            try:
                require_state_measured(P, controller)
            except ControlArgument as err:
                raise ControlArgument(
                    f"P: {err}; passivesyn's state-feedback designs need "
                    f"C2 = I") from None
            plant = build(P, controller, actuator)
    else:
        plant = None
    eta, decay, structure0 = _checks(P, eta, decay, controller, actuator,
                                     form, structure, plant, gain)
    riccati = isinstance(solver, str) and solver.upper() == "RICCATI"
    note = ""
    if method == "refine" and plant.transition is not None and gain == "mode":
        raise ControlArgument(
            "method: 'refine' designs gains per phase K_k; on Markov links "
            "ask for them with gain='phase', or use method='lmi' for gains "
            "K_{k,l} that use the previous mode")
    kinds = gain_kinds(plant, gain)
    if riccati and plant.transition is not None and "phase" in kinds:
        # the coupled equations give the optimal K_{k,ℓ}; a gain common to
        # the previous modes is the LMI's (sufficient) condition only
        _riccati_options(solver_options)
        if structure0 != "full":
            raise ValueError(
                f"solver: 'riccati' needs structure 'full'; this loop "
                f"resolves to structure {structure0!r}: use an LMI solver")
        note = ("solver='riccati' designs gains K_{k,l} on Markov links; "
                + ("gain='phase'" if gain == "phase" else
                   "a gain common to previous modes the controller cannot "
                   "tell apart")
                + " was solved by the LMI of theory: Markov losses instead")
        solver_options, solver, riccati = {}, None, False
    if riccati and structure0 != "full":
        raise ValueError(
            f"solver: 'riccati' needs structure 'full' (the gain sees every "
            f"state at every phase); this loop resolves to structure "
            f"{structure0!r} (controller={controller!r}, actuator="
            f"{actuator!r}, sensor schedule or predictor): use an LMI solver")
    if riccati:
        _riccati_options(solver_options)
    else:
        check_options(check_solver(solver), solver_options)
    _open_loop_bound(plant, decay)
    requested = eta
    if eta is not None:
        bound, _ = _feedthrough(plant)
        eta = max(eta, level_floor(bound, plant.A, plant.Bu, plant.Bw,
                                   plant.Cz, plant.Du, plant.Dw))
    if initial_gain is not None and initial_gain.shape != plant.gain_shape():
        raise ControlDimension(
            f"initial_gain: expected gains per phase of shape "
            f"{plant.gain_shape()} (N, m2, nk), got {initial_gain.shape}")
    markov = plant.transition is not None
    # the LMI is exact for an unstructured gain that may use everything the
    # controller observes; elsewhere it is only sufficient, and the default
    # call refines (gains per phase K_k, certified by analysis)
    exact = structure0 == "full" and not (markov and "phase" in kinds)
    refining = method == "refine" or (
        method == "auto" and not exact and structure == "auto"
        and solver is None and not solver_options)
    try:
        if refining:
            # the refinement designs gains per phase K_k; on Markov links
            # the LMI's gains K_{k,ℓ} (gain='mode') compete with it as they
            # are, and a phase gain of the LMI is its first start
            # a given start replaces the sufficient LMI's gain (a sweep has
            # solved that LMI already)
            K, CL, got = _refine_route(plant, eta, decay, deadline, None if
                initial_gain is not None else dict(
                    margin=margin, structure=structure,
                    structure0=structure0, form=form, solver=solver,
                    solver_options=solver_options, riccati=riccati,
                    gain=gain), initial_gain)
        else:
            K, CL, got = _routes(plant, eta, decay, margin, structure,
                                 structure0, form, solver, solver_options,
                                 deadline, riccati, gain)
    except SynthesisError as err:
        if requested == eta or err.reason != INFEASIBLE:
            raise
        # infeasible at the floor proves nothing about the level asked
        raise SynthesisError(
            f"{err} (at the floor eta0 = {eta:.6g}, verify.level_floor; "
            f"nothing is proven for eta = {requested:.6g})", SOLVER_FAILED,
            err.figures) from err
    except (KeyboardInterrupt, SystemExit, MemoryError):
        raise
    except Exception as crash:  # a route's crash is a status, not a trace
        raise SynthesisError(
            f"passivesyn: the {'refinement' if refining else 'LMI'} route "
            f"failed ({type(crash).__name__}: {crash}); nothing is proven",
            SOLVER_FAILED, dict(error=f"{type(crash).__name__}: {crash}",
                                method="refine" if refining else "lmi")
        ) from crash
    if requested != eta:
        # Θ(η) ≼ Θ(η0) for η ≤ η0: the certificate at η0 proves η exactly
        K.result.eta = K.result.eta_solver = got = float(requested)
    hidden = [k for k, kind in enumerate(kinds) if kind == "phase"]
    if gain == "mode" and hidden and K.gains.ndim == 4:
        # gain='mode' kept K_{k,ℓ} where ℓ is observed; say where it is not
        note = "; ".join(filter(None, [note, (
            f"phases {hidden}: a link idle the step before hides part of the "
            "previous mode, so one gain serves every previous mode there "
            "(sufficient, theory: Markov losses)")]))
    if note:
        K.result.note = note
    K.result.exact = bool(exact and K.result.method == "lmi"
                          and K.result.structure == "full")
    if requested is None and got < 0.0:
        # the best certified level is a shortage: true, but not passivity
        warnings.warn(NotPassiveWarning(
            f"passivesyn: the certified level eta = {got:.6g} is negative: "
            f"the loop is mean-square stable and dissipative with an "
            f"input-feedforward shortage, not passive; {_SHORTAGE_HELP}"),
            stacklevel=caller_stacklevel())
    return K, CL, got


def _estimator_plant(P: NetworkedStateSpace, actuator: str, L: Any,
                     decay: Any, solver: Any) -> JumpPlant:
    """The open loop of :ref:`theory-output-feedback` with ``L_k`` given or
    designed, after the pre-solve refusals (unstabilisable or undetectable
    modes, a given ``L`` whose error loop alone is too slow). Over bursty
    links the estimator gain and the error loop are those of the Markov
    sensor chain, and the loop is built on the joint chain of both links."""
    from .estimator import (EstimatorGain, estimation_error_loop,
                            estimator_gain, unobservable_modes)
    r = decay_bound(decay)
    N = P.period
    # dual PBH: what B2 Σ2,k never reaches over a period (lifted pair)
    missed = unobservable_modes(P.A.T, [
        (P.B2 @ P.actuator_schedule.selection(N - 1 - j)).T
        for j in range(N)])
    if missed:
        raise ValueError(
            f"P: (A, B2) is not stabilisable through the actuator schedule: "
            f"the mode(s) with eigenvalue "
            f"{', '.join(f'{m:.4g}' for m in missed)}"
            f"{' of the monodromy A^N' if N > 1 else ''} are never reached "
            f"by a scheduled actuator; no controller stabilises the loop")
    if L is None:
        riccati = isinstance(solver, str) and solver.upper() == "RICCATI"
        L = estimator_gain(P, decay=decay, solver=None if solver is None
                           or riccati else check_solver(solver))
    if isinstance(L, EstimatorGain):
        L = L.gains
    L = real_array(L, "estimator_gain", ndim=(2, 3))
    NL = L.shape[0] if L.ndim == 3 else 1
    plant = build(P, "estimator", actuator, period=math.lcm(N, NL),
                  estimator_gain=L)
    # separation (theory: output feedback): the loop's rate is at least the
    # error loop's, whatever K is: a proof of infeasibility, before any solve
    rate = ms_radius(estimation_error_loop(P, plant.info["estimator_gain"]))
    if not rate < r ** 2:
        raise SynthesisError(
            f"estimator_gain: the estimation-error loop of the given L has "
            f"ms_radius {rate:.6g} >= {r ** 2:.6g}; by separation (theory: output feedback) "
            f"no gain K makes the loop mean-square stable"
            + (f" with decay {r}" if r < 1 else ""),
            INFEASIBLE, dict(error_loop_ms_radius=rate, bound=r ** 2,
                             proof="separation"))
    return plant


#: The synthesis (``passivesyn(method='auto'|'refine')``) tries the
#: sufficient LMI first, as a starting point, up to this many states: above,
#: it took 8.7-14.5 s at 16-18 states, at most 1.1 s up to 10
#: (docs/benchmarks.md, structured refinement).
LMI_START_MAX_STATES = 10


def _refine_route(plant: JumpPlant, eta: float | None, decay: float,
                  deadline: float | None, lmi_start: dict | None,
                  initial: np.ndarray | None = None):
    """The refinement route (checked arguments): proof first, then the
    local search of :mod:`control_ncs.refine`, certified by analysis.

    ``lmi_start`` holds the arguments of :func:`_routes` for the sufficient
    LMI, whose gain (if it certifies one) is the first start; None skips it
    and starts from ``initial`` (gains per phase). A gain the LMI certifies
    at a given ``eta`` is returned as is. Returns ``(K, CL, eta)`` with
    ``K.result.method`` naming what certified it.
    """
    rate, states = autonomous_rate(plant)
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
    if lmi_start is not None and plant.shape["nx"] <= LMI_START_MAX_STATES:
        left = None if deadline is None else deadline - time.perf_counter()
        share = None if left is None else 0.5 * left
        try:
            found = _routes(plant, eta, decay, deadline=None if share is None
                            else time.perf_counter() + share, **lmi_start)
        except SynthesisError:
            found = None
        if found is not None:
            if eta is not None:
                found[0].result.method = "lmi"
                return found
            # gains on the previous mode (Markov links) compete as they
            # are; a gain per phase is the refinement's first start
            given = found[0].gains if found[0].gains.ndim == 3 else None
    if given is None and initial is not None:
        given = initial
    left = None if deadline is None else max(deadline - time.perf_counter(),
                                              1e-3)
    rng = np.random.default_rng(0)
    res = _refine(plant, eta, decay, given, rng,
                  None if left is None else time.perf_counter() + left, 200)
    if found is not None and not (res.verified and
                                  res.eta > found[0].result.eta):
        K = found[0]
        K.result.method, K.result.refinement = "lmi", res
        K.result.start = "lmi"
        return found
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
    if X.ndim == 4:
        # Markov links: storage per phase and previous mode, P_{k,ℓ}
        Y = np.einsum("kuj,kjx,klxy->kluy", res.gains, plant.E, X)
    else:
        Y = np.einsum("kuj,kjx,kxy->kuy", res.gains, plant.E, X)
    s = plant.shape
    report = SolveReport("optimal", "REFINE", 0.0, res.time, res.time,
                         res.iterations, res.eta)
    if found is not None:
        structure = found[0].result.structure
    else:
        structure = "extended" if any(
            plant.known_coordinates(k).size < s["nx"]
            for k in range(plant.period)) else "full"
    K, CL, got = _finish(plant, X, Y, res.gains, plant.close(res.gains),
                         cert, cert.eta, cert.eta, decay, "merged",
                         structure, s["nx"] + s["nw"], report, [report])
    K.result.method = "refine"
    K.result.start = "lmi" if res.start == "given" else res.start
    K.result.refinement = res
    return K, CL, got


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
        # critical loss, tests/test_hardening_synthesis.py).
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
        low = max(low, best[2])
        if high - low <= 1e-4 * max(1.0, abs(low)):
            break
        mid = 0.5 * (low + high)
        finish = level(mid)
        if finish is None:
            high = mid
        else:
            result = finish()
            if result[2] > best[2]:
                best = result
            low = mid
    return best


#: Largest state dimension at which ``_open_loop_bound`` forms the
#: ``n² × n²`` matrices of the gain-independent second-moment operator.
OPEN_LOOP_BOUND_MAX = 24


def _open_loop_bound(plant: JumpPlant, decay: float) -> None:
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
    n = plant.shape["nx"]
    p, N = plant.probabilities, plant.period
    if plant.transition is not None:
        if p.shape[1] * n * n > OPEN_LOOP_BOUND_MAX ** 2:
            return
        rho = _open_loop_rate_markov(plant)
    else:
        if n > OPEN_LOOP_BOUND_MAX:
            return
        M = np.eye(n * n)
        for k in range(N):
            step = np.zeros((n * n, n * n))
            for i in np.flatnonzero(p[k] > 0):
                if not np.any(plant.E[k]) or not np.any(plant.Bu[k, i]):
                    step += p[k, i] * np.kron(plant.A[k, i], plant.A[k, i])
            M = step @ M
        rho = float(np.max(np.abs(np.linalg.eigvals(M)))) ** (1.0 / N)
    bound = min(1.0, decay ** 2)
    # a clear margin over rounding (eigvals is backward stable)
    if rho >= bound * (1 + 1e-9):
        raise SynthesisError(
            f"passivesyn: infeasible: the network modes in which no gain "
            f"acts (every input lost, or nothing known) alone give a "
            f"second-moment rate of {rho:.6g} >= {bound:.6g} per step, and "
            f"every closed loop's rate is at least that: no gain makes the "
            f"loop mean-square stable"
            + (f" with decay {decay}" if decay < 1 else ""),
            INFEASIBLE, dict(ms_radius_without_control=rho, bound=bound,
                               proof="gain-independent modes"))


def _open_loop_rate_markov(plant: JumpPlant) -> float:
    """Per-step rate of the gain-independent part on Markov modes.

    With ``S_{k,ℓ} = E[ξ ξᵀ 1{σ_{k-1} = ℓ}]`` (:ref:`theory-markov`),
    ``S_{k+1,i} = Σ_ℓ T_{k-1}[ℓ, i] Acl S_{k,ℓ} Aclᵀ`` dominates the same
    sum over the modes ``i`` in which ``Acl = A_{k,i}`` whatever the gain
    (also a gain using ``ℓ``); the operator on ``M``-tuples restricted to
    them bounds every closed loop's rate from below. For the scalar
    ``x⁺ = a x + u`` it is ``a² ρ(T_oo)`` (:ref:`theory-markov`).
    """
    n = plant.shape["nx"]
    N, M = plant.probabilities.shape
    T = plant.transitions()
    size = M * n * n
    total = np.eye(size)
    for k in range(N):
        step = np.zeros((M, n * n, M, n * n))
        for i in range(M):
            if np.any(plant.E[k]) and np.any(plant.Bu[k, i]):
                continue
            AA = np.kron(plant.A[k, i], plant.A[k, i])
            for ell in np.flatnonzero(T[k - 1][:, i] > 0):
                step[i, :, ell, :] = T[k - 1][ell, i] * AA
        total = step.reshape(size, size) @ total
    return float(np.max(np.abs(np.linalg.eigvals(total)))) ** (1.0 / N)


def _pair_certificate(P: np.ndarray, CL: JumpStateSpace) -> np.ndarray:
    """``P_{k,ℓ}`` (shape (N, M, n, n)) as the certificate of the closed
    loop of gains ``K_{k,ℓ}`` on (lumped) pair modes (``JumpPlant.close``):
    a previous pair mode whose current plant mode was ``ℓ`` gets
    ``P_{k,ℓ}`` (:ref:`theory-markov`: ``P_{k,(ℓ',ℓ)} = P_{k,ℓ}``)."""
    if CL.modes.is_iid:
        # lumped to i.i.d. modes: a single class of ℓ at every phase
        return P[:, 0]
    cur = np.roll(CL.info["pair_modes"], 1, axis=0)   # [k] = modes at k-1
    return np.array([P[k][cur[k]] for k in range(P.shape[0])])


def _unscale(P: Any, t: np.ndarray) -> Any:
    """``T⁻¹ P T⁻¹`` for each certificate matrix, ``T = diag(t)``."""
    if isinstance(P, list):
        return [np.asarray(Pk) / t[:, None] / t[None, :] for Pk in P]
    return np.asarray(P) / t[:, None] / t[None, :]


def _balancing(plant: JumpPlant) -> np.ndarray | None:
    """Diagonal state scaling ``t`` (powers of two), or None.

    Balances ``Σ |A_ki|`` (plus the input and output matrices' weights on
    each state) like :func:`scipy.linalg.matrix_balance`: a similarity by
    powers of two is exact in floating point and keeps every zero pattern.
    Only for coordinate-selection ``E_k`` (then ``K = K̃ diag(E_k t)⁻¹``).
    """
    if not plant.is_selection():
        return None
    A = np.abs(plant.A).sum(axis=(0, 1))
    b = np.abs(np.concatenate([plant.Bu, plant.Bw], axis=-1)).sum(
        axis=(0, 1)).sum(axis=1)
    c = np.abs(plant.Cz).sum(axis=(0, 1)).sum(axis=0)
    return balancing_scale(A, b, c, BALANCE_FROM)


def _scaled(plant: JumpPlant, t: np.ndarray) -> JumpPlant:
    """The plant in coordinates ``x = T x̃``, ``T = diag(t)``."""
    inv = 1.0 / t
    return JumpPlant(plant.A * inv[:, None] * t[None, :],
                     plant.Bu * inv[:, None], plant.Bw * inv[:, None],
                     plant.Cz * t[None, :], plant.Du, plant.Dw, plant.E,
                     plant.probabilities, plant.dt, nominal=plant.nominal,
                     transition=plant.transition,
                     inputs=plant.inputs, outputs=plant.outputs,
                     states=plant.states, info=plant.info)


def _lmi_route(plant, eta, decay, margin, structure, form, solver, options,
               deadline, supremum=False, gain="mode"):
    """The LMI of ``structure``, through the one driver (``driver.drive``).

    Returns the driver's outcome and a function building the result. The
    LMI is solved in balanced coordinates (``_balancing``); gains and
    certificates are mapped back (``K_k = K̃_k diag(E_k t)⁻¹``,
    ``P_k = T⁻¹ P̃_k T⁻¹``) and verified exactly on the original plant.
    """
    t = _balancing(plant)
    work = plant if t is None else _scaled(plant, t)
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
            P = _pair_certificate(P, CL)    # the pair-mode loop's
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
        gains, X, Y = c["gains"], c["X"], c["Y"]
        if t is not None:
            # back to x = T x̃: K_k = K̃_k diag(E_k t)⁻¹, P_k = T⁻¹ P̃_k T⁻¹,
            # X_k = T X̃_k T, Y_k = Ỹ_k T (all exact: powers of two)
            d = np.einsum("kjx,x->kj", work.E, t)
            d[d == 0] = 1.0
            if gains.ndim == 4:
                d = d[:, None]
            gains = gains / d[..., None, :]
            X = X * t[:, None] * t[None, :]
            Y = Y * t
            cert = replace(cert, P=_unscale(cert.P, t))
        return _finish(plant, X, Y, gains, plant.close(gains), cert,
                       cert.eta, out.eta_solver, decay, form, structure,
                       c["width"], out.report, out.attempts)

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
            f"accepted by solver='riccati' (known: {list(RICCATI_OPTIONS)})")
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
    Pv = _pair_certificate(res.P, CL) if res.gains.ndim == 4 else res.P
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
    return _finish(plant, X, Y, res.gains, CL, cert, cert.eta,
                   res.eta if eta is None else eta, decay, "merged", "full",
                   s["nx"] + s["nw"], report, [report])


def _finish(plant, X, Y, gains, CL, cert, eta_ok, eta_solver, decay, form,
            structure, width, report, attempts):
    info = plant.info
    K = PeriodicGain(gains, info["controller"], info["actuator"],
                     estimator_gain=info.get("estimator_gain"))
    result = SynthesisResult(
        K, float(eta_ok), float(eta_solver), decay, cert,
        X, Y, form, structure, width, report, attempts, plant,
        "mode" if K.mode_dependent else "phase")
    K.result = result
    CL.info["synthesis"] = result
    return K, CL, float(eta_ok)
