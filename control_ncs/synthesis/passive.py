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

from dataclasses import dataclass, replace
from typing import Any, Mapping

from control.exception import ControlArgument, ControlDimension

from .._checks import (caller_stacklevel, choice, decay_bound, finite_real,
                      positive_real, real_array)
from ..stability import ms_radius
from ..gain import PeriodicGain, actuators, controllers
from ..jump import JumpStateSpace
from ..openloop import JumpPlant
from ..lmi import (DEFAULT_MARGIN, GAINS, check_options, check_solver, gain_kinds)
from ..plant import NetworkedStateSpace
from ..strategies import build, require_state_measured
from ..exceptions import (INFEASIBLE, SOLVER_FAILED, NotPassiveWarning, SynthesisError)
from ..verify import (level_floor)
from .._lifting import unseen_modes
from ._budget import budget_design
from ._options import resolved_options
from ._result import SHORTAGE_HELP, Design, DesignResult
from ._routes import (_feedthrough, _open_loop_bound, _plant_arrays,
                                _refine_route, _riccati_options, _routes)


__all__ = ["passivesyn", "DesignResult"]


#: Default time budget of :func:`passivesyn`, seconds.
TIME_BUDGET = 120.0

#: The keys of ``passivesyn(options=...)`` and their defaults.
DEFAULTS: dict[str, Any] = dict(solver=None, margin=DEFAULT_MARGIN,
                                time_limit=TIME_BUDGET, form="merged",
                                structure="auto", solver_options={})




FORMS = ("merged", "paper")
STRUCTURES = ("auto", "full", "block", "extended")
#: ``passivesyn(method=...)``: 'auto' takes the LMI where it is exact
#: (structure 'full') and the refinement of :mod:`control_ncs.refine` where
#: it is only sufficient (structure left to 'auto' on a structured loop).
METHODS = ("auto", "lmi", "refine")


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
    plant.require_noise_free("passivesyn")
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
               actuator: str = "zero", gain: str = "mode",
               estimator_gain: Any = None, method: str = "auto",
               initial_gain: Any = None,
               options: Mapping[str, Any] | None = None, **kwargs: Any
               ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """Periodic feedback making a networked loop strictly passive.

    The gain is applied as is, ``u = K_k x`` (positive feedback: no minus
    sign, unlike :func:`control.dlqr` / :func:`control.lqr`, whose ``K``
    is for ``u = -K x``; negate such a gain before using it here, see the
    Examples and :ref:`guide-sign`).

    Designs the gain with the synthesis LMI of :ref:`theory-synthesis`
    (exact with full information, sufficient for structured gains, where
    the default call also refines the gain locally), then proves the
    closed loop with exact linear algebra: ``λmax(Θ_k) < 0`` for its
    storage ``P_k`` and ``ms_radius < 1`` (``< r²`` with ``decay=r``). A
    gain that fails the check is never returned; when nothing can be
    certified, :class:`~control_ncs.SynthesisError` says why, and says
    "infeasible" only with a proof. Over bursty (Gilbert–Elliott) links the
    design and the check are those of :ref:`theory-markov`. Over delayed
    links (:ref:`theory-delays`) no convex program applies: one gain per
    sensor age (or the predictor's gain) is searched locally on exact
    figures, from the design without the delays, and the loop found is
    certified by :func:`passivity_certificate` (``K.result``); a local
    optimum, so a level it misses is ``'not_found'``. Give ``decay`` to
    keep the loop away from the edge of stability.

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
    estimator_gain : array_like or EstimatorGain, optional
        ``controller='estimator'`` only: ``L_k`` of shape ``(n, nmeas)`` or
        ``(N_L, n, nmeas)`` (e.g. from :func:`control.dlqe`); default
        :func:`control_ncs.estimator_gain` ``(P, decay=decay)`` with the
        LMI solver ``options['solver']`` if one is named.
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
        where ``options`` name a structure, a solver or solver options;
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
    options : dict, optional
        The solver's knobs, as :func:`scipy.optimize.minimize` takes
        them; every key is optional:

        solver : str or None
            An installed cvxpy solver for the LMI, or ``'riccati'``
            (case-insensitive) for the monotone Riccati iteration of
            :mod:`control_ncs.riccati` (needs ``structure`` to resolve to
            ``'full'``; no cvxpy, memory ``O(N n²)``; ``form`` does not
            apply to it). None (default): the Riccati iteration when the
            structure resolves to ``'full'``, the plant has more than
            ``RICCATI_THRESHOLD`` states and no ``solver_options`` are
            given (if that iteration is inconclusive and the plant has at
            most ``RICCATI_FALLBACK_MAX`` states, Clarabel after it), else
            Clarabel. Over Markov links the iteration solves the coupled
            Riccati equations (gains ``K_{k,ℓ}``); with ``gain='phase'``
            the LMI is solved instead (``K.result.note`` says so).
        margin : float
            Relative strictness margin of the LMIs (for the Riccati
            iteration: the ``εI`` added at each step, relative to the
            data's scale). Default ``lmi.DEFAULT_MARGIN`` (1e-7).
        time_limit : float or None
            Time budget in seconds (default ``TIME_BUDGET`` = 120 s; None:
            no limit). The remaining time is passed to Clarabel
            (``time_limit``); the budget is checked between attempts. A
            Riccati iteration already running is not interrupted.
        form : {'merged', 'paper'}
            ``'merged'`` (default): coinciding network modes merged, LMI
            side ``n + m1 + 2n`` for the static gain; ``'paper'``: one row
            per mode (eq. 15), side ``n + m1 + 4n``. Both give the same
            optimum.
        structure : {'auto', 'full', 'block', 'extended'}
            ``'auto'`` (default): ``'full'`` (exact) when the controller
            knows every coordinate at every phase, else ``'extended'``.
            ``'block'`` and ``'extended'`` are sufficient conditions
            (:ref:`theory-synthesis`).
        solver_options : dict
            Passed to the solver, checked first: an option Clarabel (its
            ``DefaultSettings``), SCS or CVXOPT does not know raises
            ``TypeError``. For ``solver='riccati'``: ``rtol`` (bisection
            tolerance on ``η``, default 1e-4), ``max_sweeps`` (default
            20000), ``probe_sweeps`` (per bisection level, default 3000);
            see :func:`control_ncs.riccati.riccati_synthesis`.

        An unknown key raises ``TypeError``; the values are checked as
        above. ``K.result.options`` holds the options the design used.
    **kwargs
        Deprecated: ``solver``, ``margin``, ``time_limit``, ``form``,
        ``structure`` and solver options given as keywords still work, with
        a ``DeprecationWarning``; pass them in ``options``.

    Returns
    -------
    K : PeriodicGain
        ``K.gains`` has shape ``(N, m2, nk)``, or ``(N, M, m2, nk)`` for
        gains on the previous mode (Markov links, ``gain='mode'``), applied
        as ``u = K_k ŷ`` (no minus sign); ``K.result`` is the
        :class:`DesignResult`.
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
        An unknown key of ``options``, a knob given both in ``options``
        and as a keyword, or a solver option the chosen solver (or the
        Riccati iteration) does not know.

    Warns
    -----
    NotPassiveWarning
        When ``eta`` is maximised and the best certified level is negative:
        the loop is certified mean-square stable and dissipative with an
        input-feedforward shortage, not passive (``K.result.status`` is
        ``'certified_shortage'``).

    Notes
    -----
    The LMI reads ``K_k = Y_k X_k⁻¹`` (or ``Y_k G_k⁻¹`` in the extended
    form) and is checked with ``P_k = X_k⁻¹``; over Markov links it has
    ``X_{k,ℓ}``, ``Y_{k,ℓ}`` per previous mode ``ℓ`` (see ``gain``), and the
    check is ``Θ_{k,ℓ}`` of the closed loop on pair modes with
    ``P_{k,(ℓ',ℓ)} = X_{k,ℓ}⁻¹``. The LMI is solved in balanced coordinates
    (a diagonal similarity by powers of two, exact in floating point), and
    every solve goes through one solve-and-verify loop
    (:func:`control_ncs.driver.drive`: retries ``driver.RETRIES``, then once
    ``lmi.FALLBACK_SOLVER``). With no solver named and ``eta=None``,
    when the maximisation gives no verified gain, fixed levels of ``η`` are
    tried and, for structure ``'full'``, the Riccati iteration; under
    structure ``'auto'`` a loop that resolves to ``'extended'`` is also
    tried with ``'block'``. Progress (each attempt) is logged on the
    ``'control_ncs'`` logger at level INFO
    (``logging.basicConfig(level=logging.INFO)`` shows it).

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

    >>> K, CL, eta = ncs.passivesyn(P, decay=0.9,
    ...                             options={'solver': 'riccati'})
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
    opts = resolved_options("passivesyn", options, kwargs, DEFAULTS)
    solver, form, structure = opts["solver"], opts["form"], opts["structure"]
    solver_options = opts["solver_options"]
    margin, deadline, initial_gain = _validated(
        P, controller, actuator, method, initial_gain, estimator_gain,
        opts["margin"], opts["time_limit"])
    plant = _open_loop(P, controller, actuator, estimator_gain, decay, solver)
    if plant.constraint is not None:
        # a loss budget: certified for every allowed pattern
        design = budget_design(plant, "passivity",
                               eta=finite_real(eta, "eta", allow_none=True),
                               decay=decay_bound(decay), solver=solver,
                               solver_options=dict(solver_options))
        if eta is None:
            _warn_shortage(design.value, "stable under every allowed pattern")
        return design.with_fields(options=opts).finish()
    plan = _plan(P, plant, eta, decay, controller, actuator, form, structure,
                 gain, solver, method, dict(solver_options), initial_gain)
    design = _run(plant, plan, margin, deadline, initial_gain)
    return _stated(design.with_fields(options=opts), plan)


def _validated(P: Any, controller: str, actuator: str, method: str,
               initial_gain: Any, estimator_gain: Any, margin: Any,
               time_limit: Any) -> tuple:
    """The cheap checks, before anything is solved: ``(margin, deadline,
    initial_gain)``."""
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
    # the estimator design solves an LMI before the plant exists: its time
    # counts against the budget
    margin = positive_real(margin, "margin")
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    deadline = None if time_limit is None else time.perf_counter() + time_limit
    return margin, deadline, initial_gain


def _open_loop(P: Any, controller: str, actuator: str, estimator_gain: Any,
               decay: Any, solver: Any) -> JumpPlant:
    """The open loop the design is for, built once (a given JumpPlant is
    taken as it is, labelled with the controller and actuator)."""
    if isinstance(P, JumpPlant):
        # the gain's labels: the strategy that built the plant, if named
        return replace(P, controller=P.controller or controller,
                       actuator=P.actuator or actuator)
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()) "
                              f"or a JumpPlant (see build()), got "
                              f"{type(P).__name__}")
    if controller == "estimator":
        return _estimator_plant(P, actuator, estimator_gain, decay, solver)
    try:
        require_state_measured(P, controller)
    except ControlArgument as err:
        raise ControlArgument(
            f"P: {err}; passivesyn's state-feedback designs need "
            f"C2 = I") from None
    return build(P, controller, actuator)


@dataclass(frozen=True)
class Plan:
    """A passive design, validated against its open loop: the level asked
    and the one solved for, the route and its options."""

    requested: float | None      # the level asked for
    eta: float | None            # the level solved for (floored)
    decay: float
    structure: str               # as asked
    structure0: str              # as resolved
    form: str
    gain: str
    kinds: tuple
    solver: Any
    riccati: bool
    solver_options: dict
    exact: bool
    refining: bool
    note: str


def _plan(P: Any, plant: JumpPlant, eta: Any, decay: Any, controller: str,
          actuator: str, form: str, structure: str, gain: str, solver: Any,
          method: str, solver_options: dict, initial_gain: Any) -> Plan:
    """The route: the checks that need the open loop, then the LMI
    (exact or sufficient), the Riccati iteration or the local search."""
    eta, decay, structure0 = _checks(P, eta, decay, controller, actuator,
                                     form, structure, plant, gain)
    if plant.reads_per_mode:
        method, gain = _per_mode_route(method, structure, form, solver, gain,
                                       solver_options)
    riccati = isinstance(solver, str) and solver.upper() == "RICCATI"
    if method == "refine" and plant.transition is not None and gain == "mode":
        raise ControlArgument(
            "method: 'refine' designs gains per phase K_k; on Markov links "
            "ask for them with gain='phase', or use method='lmi' for gains "
            "K_{k,l} that use the previous mode")
    kinds = gain_kinds(plant, gain)
    note = ""
    if riccati and plant.transition is not None and "phase" in kinds:
        # the coupled equations give the optimal K_{k,ℓ}; a gain common to
        # the previous modes is the LMI's (sufficient) condition only
        _riccati_options(solver_options)
        _riccati_structure(structure0, controller, actuator)
        note = ("solver='riccati' designs gains K_{k,l} on Markov links; "
                + ("gain='phase'" if gain == "phase" else
                   "a gain common to previous modes the controller cannot "
                   "tell apart")
                + " was solved by the LMI of theory: Markov losses instead")
        solver_options, solver, riccati = {}, None, False
    if riccati:
        _riccati_structure(structure0, controller, actuator)
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
    # the LMI is exact for an unstructured gain that may use everything the
    # controller observes; elsewhere it is only sufficient, and the default
    # call refines (gains per phase K_k, certified by analysis)
    exact = structure0 == "full" and not (plant.transition is not None
                                          and "phase" in kinds)
    refining = method == "refine" or (
        method == "auto" and not exact and structure == "auto"
        and solver is None and not solver_options)
    return Plan(requested, eta, decay, structure, structure0, form, gain,
                kinds, solver, riccati, solver_options, exact, refining, note)


def _per_mode_route(method: str, structure: str, form: str, solver: Any,
                    gain: str, solver_options: dict) -> tuple[str, str]:
    """A gain per age of a buffered measurement reads its own block in
    each mode, which no synthesis LMI expresses: the local search, gains
    per phase; the LMIs' options are refused by name."""
    given = [name for name, value, default in (
        ("method", method, "auto"), ("structure", structure, "auto"),
        ("form", form, "merged"), ("solver", solver, None),
        ("gain", gain, "mode")) if value not in (default, "refine")] \
        + sorted(solver_options)
    if given:
        raise ControlArgument(
            f"{given[0]}: this loop's gain reads a measurement of a "
            f"different age in each mode (a delayed sensor link); no "
            f"synthesis LMI expresses that, and the gain is searched "
            f"locally on exact figures (method='refine')")
    return "refine", "phase"


def _riccati_structure(structure0: str, controller: str, actuator: str
                       ) -> None:
    if structure0 != "full":
        raise ValueError(
            f"solver: 'riccati' needs structure 'full' (the gain sees every "
            f"state at every phase); this loop resolves to structure "
            f"{structure0!r} (controller={controller!r}, actuator="
            f"{actuator!r}, sensor schedule or predictor): use an LMI solver")


def _run(plant: JumpPlant, plan: Plan, margin: float,
         deadline: float | None, initial_gain: Any) -> Design:
    """The route the plan chose; a route's crash is a status, not a trace,
    and an infeasible floor proves nothing about the level asked."""
    try:
        if plan.refining:
            # the refinement designs gains per phase K_k; on Markov links the
            # LMI's gains K_{k,ℓ} (gain='mode') compete with it as they are,
            # and a phase gain of the LMI is its first start; a given start
            # replaces the sufficient LMI's gain (a sweep has solved it)
            return _refine_route(plant, plan.eta, plan.decay, deadline, None
                                 if initial_gain is not None else dict(
                margin=margin, structure=plan.structure,
                structure0=plan.structure0, form=plan.form,
                solver=plan.solver, solver_options=plan.solver_options,
                riccati=plan.riccati, gain=plan.gain), initial_gain)
        return _routes(plant, plan.eta, plan.decay, margin, plan.structure,
                       plan.structure0, plan.form, plan.solver,
                       plan.solver_options, deadline, plan.riccati, plan.gain)
    except SynthesisError as err:
        if plan.requested == plan.eta or err.reason != INFEASIBLE:
            raise
        raise SynthesisError(
            f"{err} (at the floor eta0 = {plan.eta:.6g}, verify.level_floor;"
            f" nothing is proven for eta = {plan.requested:.6g})",
            SOLVER_FAILED, err.figures) from err
    except (KeyboardInterrupt, SystemExit, MemoryError):
        raise
    except Exception as crash:
        what = "refinement" if plan.refining else "LMI"
        raise SynthesisError(
            f"passivesyn: the {what} route failed ({type(crash).__name__}: "
            f"{crash}); nothing is proven", SOLVER_FAILED,
            dict(error=f"{type(crash).__name__}: {crash}",
                 method="refine" if plan.refining else "lmi")) from crash


def _stated(design: Design, plan: Plan) -> tuple:
    """What only the dispatcher knows, added to the route's answer: the
    level asked (proven by the floor's certificate), notes, exactness; a
    negative best level is warned about. Returns ``(K, CL, eta)``."""
    if plan.requested is not None and plan.requested != plan.eta:
        # Θ(η) ≼ Θ(η0) for η ≤ η0: the certificate at η0 proves η exactly
        design = design.with_fields(value=float(plan.requested),
                                    solver_value=float(plan.requested))
    note = plan.note
    hidden = [k for k, kind in enumerate(plan.kinds) if kind == "phase"]
    if plan.gain == "mode" and hidden and design.gains.ndim == 4:
        # gain='mode' kept K_{k,ℓ} where ℓ is observed; say where it is not
        note = "; ".join(filter(None, [note, (
            f"phases {hidden}: a link idle the step before hides part of the "
            "previous mode, so one gain serves every previous mode there "
            "(sufficient, theory: Markov losses)")]))
    f = design.fields
    design = design.with_fields(note=note, exact=bool(
        plan.exact and f["method"] in ("lmi", "riccati")
        and f["structure"] == "full"))
    if plan.requested is None:
        _warn_shortage(design.value, "mean-square stable")
    return design.finish()


def _warn_shortage(got: float, stable: str) -> None:
    """A negative best level is a shortage: true, but not passivity."""
    if got < 0.0:
        warnings.warn(NotPassiveWarning(
            f"passivesyn: the certified level eta = {got:.6g} is negative: "
            f"the loop is {stable} and dissipative with an "
            f"input-feedforward shortage, not passive; {SHORTAGE_HELP}"),
            stacklevel=caller_stacklevel())


def _estimator_plant(P: NetworkedStateSpace, actuator: str, L: Any,
                     decay: Any, solver: Any) -> JumpPlant:
    """The open loop of :ref:`theory-output-feedback` with ``L_k`` given or
    designed, after the pre-solve refusals (unstabilisable or undetectable
    modes, a given ``L`` whose error loop alone is too slow). Over bursty
    links the estimator gain and the error loop are those of the Markov
    sensor chain, and the loop is built on the joint chain of both links."""
    from ..estimator import (EstimatorGain, estimation_error_loop,
                            estimator_gain)
    r = decay_bound(decay)
    N = P.period
    # dual PBH: what B2 Σ2,k never reaches over a period (lifted pair)
    missed = unseen_modes(P.A.T, [
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
    rate = ms_radius(estimation_error_loop(P, plant.estimator_gain))
    if not rate < r ** 2:
        raise SynthesisError(
            f"estimator_gain: the estimation-error loop of the given L has "
            f"ms_radius {rate:.6g} >= {r ** 2:.6g}; by separation (theory: output feedback) "
            f"no gain K makes the loop mean-square stable"
            + (f" with decay {r}" if r < 1 else ""),
            INFEASIBLE, dict(error_loop_ms_radius=rate, bound=r ** 2,
                             proof="separation"))
    return plant
