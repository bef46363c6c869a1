"""H2- and H∞-optimal state feedback over the network
(:ref:`theory-performance`).

Convex programs design periodic gains ``K_k`` (over bursty links ``K_{k,ℓ}``,
also on the previous link state) when the controller sees the whole loop
state: Costa, do Val and Geromel's for the H2 norm
(``lmi.h2_model``), the bounded real lemma in ``X = P⁻¹, Y = K X`` for the
ℓ2 gain (``lmi.hinf_model``). The number returned is always an analysis of
the closed loop — its exact H2 norm (:func:`control_ncs.norm`), or its
certified ℓ2-gain bound (:func:`control_ncs.l2_gain`) — never the solver's
objective. Over a lossy actuator link with the state measured the H2 problem
is TCP-like LQ, whose optimum is the modified Riccati equation's
(:func:`control_ncs.dlqr`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from control.exception import ControlArgument

from ._checks import choice, positive_real
from ._results import CertifiedResult
from .exceptions import NOT_MSS, SOLVER_FAILED, SynthesisError
from .gain import PeriodicGain, actuators
from .jump import JumpStateSpace
from .lmi import (DEFAULT_MARGIN, check_options, check_solver, gain_kinds,
                  h2_model, hinf_model, solve)
from .performance import GainResult, l2_gain, norm
from .plant import NetworkedStateSpace
from .stability import ms_radius
from .strategies import build
from ._synthesis_routes import _open_loop_bound

__all__ = ["h2syn", "H2Result", "hinfsyn"]


@dataclass(repr=False)
class H2Result(CertifiedResult):
    """What :func:`h2syn` designed and measured.

    Attributes
    ----------
    h2 : float
        The exact H2 norm of the closed loop (the certified figure).
    h2_solver : float
        ``√`` of the solver's objective (an upper bound it claims; never the
        returned number).
    ms_radius : float
        The loop's exact mean-square rate.
    report : SolveReport
        The solver's status and timings.

    Examples
    --------
    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, h2 = ncs.h2syn(P)
    >>> K.result.status
    'certified'
    """

    h2: float
    h2_solver: float
    ms_radius: float
    report: Any

    _repr_fields: ClassVar[tuple[str, ...]] = ("h2", "ms_radius")

    @property
    def message(self) -> str:
        """One sentence."""
        return (f"the loop is mean-square stable with H2 norm "
                f"{self.h2:.6g} (exact)")

    def _details(self) -> list[str]:
        return [f"H2 norm {self.h2:.8g} exact (solver's bound "
                f"{self.h2_solver:.8g}), ms_radius {self.ms_radius:.6g}"]


def _full_information(P: Any, actuator: str, solver: str | None,
                      margin: Any, solver_options: dict, who: str
                      ) -> tuple[Any, str, float]:
    """The checks of the exact full-information programs; the open loop."""
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    choice(actuator, "actuator", actuators())
    if actuator != "zero":
        raise ControlArgument(
            f"actuator: {who} designs with actuator='zero' (a held command "
            f"is extra state the static gain does not see), got {actuator!r}")
    name = check_solver(solver)
    check_options(name, solver_options)
    margin = positive_real(margin, "margin")
    n = P.nstates
    if P.C2.shape != (n, n) or not np.array_equal(P.C2, np.eye(n)):
        raise ControlArgument(
            f"P: {who} needs the state measured, y = x (C2 = I, {n}x{n}), "
            f"got C2 of shape {P.C2.shape}")
    plant = build(P, "static", actuator)
    plant.require_noise_free(who)
    if not plant.is_iid and "phase" in gain_kinds(plant, "mode"):
        raise ControlArgument(
            f"P: {who}'s exact program over a bursty link uses gains on the "
            f"previous link state, known from acknowledgements; under this "
            f"schedule a link idle the step before hides its state, and the "
            f"program with one gain for the hidden states is not written")
    if not all(np.array_equal(Ek, np.eye(n)) for Ek in plant.E):
        raise ControlArgument(
            f"P: the static gain does not see the whole state at every phase "
            f"(a sensor schedule); {who}'s exact program needs y = x at "
            f"every step")
    return plant, name, margin


def _designed_loop(plant: Any, model: Any, name: str, solver_options: dict,
                   who: str) -> tuple[np.ndarray, JumpStateSpace, float, Any]:
    """Solve ``model``, read its gains, close the loop and require it
    mean-square stable: ``(gains, CL, ms_radius, report)``. Before the
    solve, the one proof that needs no solver: the modes no gain acts in
    (a lost command) alone make every loop mean-square unstable."""
    _open_loop_bound(plant, 1.0, who)
    report = solve(model.problem, name, **solver_options)
    if report.status not in ("optimal", "optimal_inaccurate") or \
            model.problem.value is None:
        raise SynthesisError(f"{who}: the solver gave no gain (status "
                             f"{report.status!r})", SOLVER_FAILED,
                             dict(status=report.status))
    gains = model.gains()
    CL = plant.close(gains)
    rate = ms_radius(CL)
    if not rate < 1.0:
        raise SynthesisError(
            f"{who}: the solver's gain does not make the loop mean-square "
            f"stable (ms_radius {rate:.6g})", NOT_MSS, dict(ms_radius=rate))
    return gains, CL, rate, report


def h2syn(P: NetworkedStateSpace, *, actuator: str = "zero",
          solver: str | None = None, margin: float = DEFAULT_MARGIN,
          **solver_options: Any) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """H2-optimal periodic state feedback over the lossy network.

    Like :func:`control.h2syn` with python-control's generalized-plant
    layout (inputs ``[w; u]``, outputs ``[z; y]``), for the periodic jump
    loop of the plant and its network: the periodic static gains
    ``u = K_k x`` minimising ``‖G‖₂`` (unit white ``w``; see
    :func:`control_ncs.norm`), by the convex program of Costa, do Val and
    Geromel. Exact (the global optimum over periodic static gains) when the
    controller sees the whole state, ``y = x`` at every phase; over a
    bursty (Gilbert–Elliott) link the gains also use the link's previous
    state, known from acknowledgements, ``K_{k,ℓ}`` (:ref:`theory-markov`),
    and the program, written per class of previous states, is exact again
    (it solves the coupled Riccati equations of LQ over the link). ``z``
    counts the applied control (``D12`` acts on what arrives).

    Parameters
    ----------
    P : NetworkedStateSpace
        With ``y = x`` (``C2 = I``); Bernoulli or bursty links (a bursty
        link's state must be revealed at every step: a schedule that
        leaves it idle is refused).
    actuator : {'zero'}, optional
        What the actuator applies when a command is lost (the exact program
        needs the loop state to be the plant state).
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative lower bound on the covariance ``Q_k``.
    **solver_options
        Passed to the solver.

    Returns
    -------
    K : PeriodicGain
        ``K.result`` is an :class:`H2Result`; shape ``(N, m2, n)``, or
        ``(N, M, m2, n)`` (gains on the previous mode) over bursty links.
    CL : JumpStateSpace
        The closed loop ``w → z``.
    h2 : float
        The exact H2 norm of ``CL`` (not the solver's objective).

    Raises
    ------
    ControlArgument
        ``P`` is not a NetworkedStateSpace, the state is not measured,
        a schedule hides a bursty link's state, or ``actuator`` is not
        ``'zero'``.
    SynthesisError
        ``'infeasible'`` (a proof: the modes in which every command is lost
        alone make every loop mean-square unstable, e.g. bursts too long
        for the plant), the solver gave no gain (``'solver_failed'``), or
        the gain does not make the loop mean-square stable
        (``'not_mss'``).

    References
    ----------
    .. [1] O. L. V. Costa, J. B. R. do Val and J. C. Geromel, "A convex
           programming approach to H2 control of discrete-time Markovian
           jump linear systems", *Int. J. Control* 66(4), 1997.

    Examples
    --------
    ``x⁺ = 1.2 x + θ u + w``, ``z = [x; θu]``, half the commands lost: the
    optimal cost is the modified Riccati solution ``S = 5.7626``
    (:func:`control_ncs.dlqr`).

    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, h2 = ncs.h2syn(P)
    >>> round(h2 ** 2, 5)
    5.76262
    """
    plant, name, margin = _full_information(P, actuator, solver, margin,
                                            solver_options, "h2syn")
    model = h2_model(plant, margin)
    gains, CL, rate, report = _designed_loop(plant, model, name,
                                             solver_options, "h2syn")
    h2 = norm(CL, 2)
    K = PeriodicGain(gains, "static", actuator)
    K.result = H2Result(h2, float(np.sqrt(max(model.problem.value, 0.0))),
                        rate, report)
    return K, CL, h2


def hinfsyn(P: NetworkedStateSpace, *, actuator: str = "zero",
            solver: str | None = None, margin: float = DEFAULT_MARGIN,
            **solver_options: Any) -> tuple[PeriodicGain, JumpStateSpace,
                                            float]:
    """ℓ2-gain (H∞) optimal periodic state feedback over the network.

    Like :func:`control.hinfsyn` (python-control's generalized-plant
    layout), for the periodic jump loop of the plant and its network: the
    periodic static gains ``u = K_k x`` minimising the loop's ℓ2 gain from
    ``w`` to ``z`` for inputs adapted to the past, by the bounded real
    lemma in ``X_k = P_k⁻¹``, ``Y_k = K_k X_k`` (convex, and exact for
    ``y = x`` at every phase; over bursty links with gains ``K_{k,ℓ}`` on
    the previous link state and storages per previous state, exact again).
    The returned ``gamma`` is
    the certified upper bound of :func:`control_ncs.l2_gain` on the
    designed loop — its own LMI and exact check — never this program's
    objective; ``K.result`` is that :class:`GainResult` (with the lower end
    of the bracket).

    Parameters
    ----------
    P : NetworkedStateSpace
        With ``y = x`` (``C2 = I``); Bernoulli or bursty links, as for
        :func:`h2syn`.
    actuator : {'zero'}, optional
        What the actuator applies when a command is lost.
    solver : str, optional
        Any installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMI.
    **solver_options
        Passed to the solver.

    Returns
    -------
    K : PeriodicGain
    CL : JumpStateSpace
    gamma : float
        The certified ℓ2-gain bound of ``CL``.

    Raises
    ------
    ControlArgument
        As :func:`h2syn`.
    SynthesisError
        ``'infeasible'`` (a proof, as for :func:`h2syn`), no gain from the
        solver (``'solver_failed'``), or the gain leaves the loop not
        mean-square stable (``'not_mss'``).
    CertificationError
        The designed loop's gain could not be certified (see
        :func:`control_ncs.l2_gain`).

    Examples
    --------
    ``x⁺ = 1.2 x + w + θ u``, ``z = [x; θu]``, half the commands lost:

    >>> import control_ncs as ncs
    >>> P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
    ...             ncon=1, actuator_loss=0.5)
    >>> K, CL, gamma = ncs.hinfsyn(P)
    >>> bool(K.result.lower <= gamma), K.result.status
    (True, 'certified')
    """
    plant, name, margin = _full_information(P, actuator, solver, margin,
                                            solver_options, "hinfsyn")
    model = hinf_model(plant, margin)
    gains, CL, rate, report = _designed_loop(plant, model, name,
                                             solver_options, "hinfsyn")
    result: GainResult = l2_gain(CL, solver=solver)
    K = PeriodicGain(gains, "static", actuator)
    K.result = result
    return K, CL, result.gamma
