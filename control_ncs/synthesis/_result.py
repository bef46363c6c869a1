"""One frozen result for every design (:func:`passivesyn`, :func:`h2syn`,
:func:`hinfsyn`): the certified figure, how the gain was found, and what
proves it.

A route answers with a :class:`Design` (the gains, their closed loop and
the result's fields); the dispatcher adds what only it knows (a note, the
exactness of the route it chose) and states it once with
:meth:`Design.finish`: the frozen :class:`DesignResult` on the gain and on
the loop. Nothing changes a result afterwards (SciPy's ``OptimizeResult``,
built once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any, ClassVar, Mapping

import numpy as np

from .._results import Result
from ..exceptions import CERTIFIED, CERTIFIED_SHORTAGE, MESSAGES
from ..gain import PeriodicGain

__all__ = ["DesignResult"]

#: What helps a negative certified level (printed with it).
SHORTAGE_HELP = ("a larger feedthrough D11 from w to z, a weaker decay "
                 "requirement or less loss on the links would raise eta")

#: The figure each specification certifies, and its name.
FIGURES = {"passivity": "eta", "h2": "h2", "hinf": "gamma"}


@dataclass(frozen=True, repr=False)
class DesignResult(Result):
    """What a design function returned and what proves it.

    Every design of the package (:func:`control_ncs.passivesyn`,
    :func:`control_ncs.h2syn`, :func:`control_ncs.hinfsyn`) returns its
    gain with one of these on ``K.result``. The figure (``eta``, ``h2`` or
    ``gamma``) is always measured on the returned loop by an analysis of
    its own (the exact H2 norm, the verified certificate of the passivity
    or bounded real lemma), never taken from a solver.

    Attributes
    ----------
    spec : {'passivity', 'h2', 'hinf'}
        What was designed for.
    value : float
        The certified figure: ``η`` (passivity, the larger the better),
        ``‖G‖₂`` (h2, exact) or the certified ℓ2-gain bound ``γ`` (hinf).
    route : {'program', 'riccati', 'local'}
        How the gain was found: a convex program (an LMI or SDP), a Riccati
        iteration, or a local search on exact figures (a local optimum).
    method : {'lmi', 'riccati', 'refine'}
        The same, in passivesyn's words: ``'refine'`` is the local search.
    exact : bool
        True when the route is exact for the gain class: no gain of this
        class does better than ``value`` (up to the program's margin).
    ms_radius : float
        The returned loop's exact mean-square rate.
    decay : float
        The decay bound ``r`` asked for (1: none); ``ms_radius < r²``.
    controller, actuator : str
        The controller and actuator kinds of the gain.
    period : int
        The gain's period ``N``.
    gain_kind : {'phase', 'mode'}
        ``K_k`` per phase, or ``K_{k,ℓ}`` per phase and previous mode.
    structure : str
        Passivity: which condition certified the gain (``'full'`` exact,
        ``'block'``/``'extended'`` sufficient LMIs, ``'per_mode'`` a gain
        reading a different block in each mode); h2 and hinf: ``'full'``
        for the exact program, else ``'structured'``.
    certificate : object or None
        What proves the figure: the verified
        :class:`~control_ncs.verify.Certificate` (passivity), the
        :class:`~control_ncs.GainResult` of the designed loop (hinf), None
        for h2 (the exact norm needs no certificate).
    lower : float
        A lower bound on what the loop achieves, where one is known
        (hinf: the largest gain of the mean system), else nan.
    solver_value : float
        The program's own objective (passivity: its η; h2: ``√`` of its
        bound; hinf: its γ), never the returned figure; nan for a local
        search.
    report : SolveReport or None
        The successful solve's status and times.
    attempts : tuple of SolveReport
        Every solve made.
    note : str
        Why the call took another route than asked or than usual.
    start : str or None
        Local search: the starting point that led to the gain.
    refinement : object or None
        Local passivity search: its :class:`~control_ncs.RefineResult`.
    X, Y : ndarray or None
        The program's variables (passivity).
    form : str
        The LMI's form (passivity), ''.
    width : int
        The side of each LMI block (passivity), 0.
    estimator_gain : ndarray or None
        The estimator's ``L_k`` the gain belongs to (``controller=
        'estimator'``).
    options : dict
        The solver options the design ran with (the ``options=`` of the
        call filled in with their defaults; ``{}`` where none applied).
    plant : JumpPlant or None
        The open loop that was designed for.

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=0.1)
    >>> K, CL, eta = ncs.passivesyn(P, eta=0.0, decay=0.9)
    >>> res = K.result
    >>> res.spec, res.route, res.exact, res.structure
    ('passivity', 'program', True, 'full')
    >>> res.certificate.verified, bool(res.ms_radius < 0.81), res.eta == eta
    (True, True, True)
    """

    spec: str
    value: float
    route: str
    method: str
    exact: bool
    ms_radius: float
    decay: float = 1.0
    controller: str = "static"
    actuator: str = "zero"
    period: int = 1
    gain_kind: str = "phase"
    structure: str = "full"
    certificate: Any = None
    lower: float = math.nan
    solver_value: float = math.nan
    report: Any = None
    attempts: list = field(default_factory=list)
    note: str = ""
    start: str | None = None
    refinement: Any = None
    X: Any = None
    Y: Any = None
    form: str = ""
    width: int = 0
    estimator_gain: Any = None
    options: dict = field(default_factory=dict)
    plant: Any = field(default=None, compare=False)

    _repr_fields: ClassVar[tuple[str, ...]] = ("value", "ms_radius", "period",
                                               "route", "structure",
                                               "gain_kind")

    # -- the figure under its name ---------------------------------------
    @property
    def eta(self) -> float:
        """The certified dissipation ``η`` (passivity designs)."""
        return self._figure("passivity")

    @property
    def h2(self) -> float:
        """The exact H2 norm (h2 designs)."""
        return self._figure("h2")

    @property
    def gamma(self) -> float:
        """The certified ℓ2-gain bound (hinf designs)."""
        return self._figure("hinf")

    def _figure(self, spec: str) -> float:
        if self.spec != spec:
            raise AttributeError(f"{FIGURES[spec]}: this result is of a "
                                 f"{self.spec} design; its figure is "
                                 f"{FIGURES[self.spec]} (result.value)")
        return self.value

    @property
    def eta_solver(self) -> float:
        """Passivity: the program's η (:attr:`solver_value`)."""
        self._figure("passivity")
        return self.solver_value

    @property
    def tight(self) -> bool:
        """Whether the figure is what the loop achieves, not only a bound.

        h2: always (the norm is exact). hinf: the certificate's bracket
        ``[lower, γ]`` is within 1 % (:attr:`GainResult.tight
        <control_ncs.GainResult.tight>`). Passivity: the level is a
        certified bound with no attained counterpart; asking raises
        AttributeError.
        """
        if self.spec == "passivity":
            raise AttributeError("tight: a passivity design certifies a "
                                 "level eta, not a bracket (result.eta)")
        if self.spec == "h2":
            return True
        return bool(getattr(self.certificate, "tight", False))

    # -- the verdict ---------------------------------------------------------
    @property
    def passive(self) -> bool:
        """Passivity: whether the certified level is passive (``η ≥ 0``)."""
        return self.spec == "passivity" and self.value >= 0.0

    @property
    def success(self) -> bool:
        """True: a design returns only certified loops (else it raises)."""
        return True

    @property
    def status(self) -> str:
        """``'certified'``, or ``'certified_shortage'`` (η < 0).

        A negative certified passivity level: the loop is dissipative,
        not passive."""
        if self.spec == "passivity" and not self.passive:
            return CERTIFIED_SHORTAGE
        return CERTIFIED

    @property
    def message(self) -> str:
        """One sentence: what is proven and how the gain was found."""
        how = {"program": "an exact convex program" if self.exact else
               "a sufficient convex program",
               "riccati": "a Riccati iteration",
               "local": "a local search (a local optimum)"}[self.route]
        name = FIGURES[self.spec]
        radius = (f", ms_radius = {self.ms_radius:.6g}"
                  if math.isfinite(self.ms_radius) else "")
        said = MESSAGES[self.status]
        if not math.isfinite(self.ms_radius):
            # a loss budget: no probabilities, the verdict is for every
            # allowed pattern
            said = said.replace("mean-square stable",
                                "stable under every allowed loss pattern")
        text = (f"{said} ({name} = {self.value:.6g}{radius}); found by "
                f"{how}")
        if self.spec == "passivity" and not self.passive:
            text += f"; the loop is not passive ({SHORTAGE_HELP})"
        return text

    def _details(self) -> list[str]:
        lines = [f"controller={self.controller!r}, actuator={self.actuator!r}"
                 f", N={self.period}, structure={self.structure}, "
                 f"gain={self.gain_kind}, route={self.route}"]
        program = (f" (program {self.solver_value:.8g})"
                   if math.isfinite(self.solver_value) else "")
        lines.append(f"certified {FIGURES[self.spec]} = {self.value:.8g}"
                     f"{program}")
        if math.isfinite(self.lower):
            lines.append(f"lower bound {self.lower:.8g}")
        r = self.report
        if r is not None:
            lines.append(f"solver {r.solver}: {r.status}, compile "
                         f"{r.compile_time:.3f} s, solve {r.solve_time:.3f} "
                         f"s, {len(self.attempts)} attempt(s)")
        if self.options:
            lines.append("options " + ", ".join(
                f"{k}={v!r}" for k, v in self.options.items()
                if k != "solver_options" or v))
        if self.estimator_gain is not None:
            lines.append(f"estimator gain L_k of shape "
                         f"{np.shape(self.estimator_gain)} (N_L, n, nmeas)")
        if self.note:
            lines.append(f"note: {self.note}")
        cert = self.certificate
        if cert is not None and hasattr(cert, "summary"):
            lines += cert.summary().splitlines()
        return lines

    def __reduce__(self) -> tuple:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return (_restore, (values,))


def _restore(fields: dict) -> DesignResult:
    return DesignResult(**fields)


@dataclass(frozen=True)
class Design:
    """A route's answer before the dispatcher states it.

    Attributes
    ----------
    gains : ndarray
        ``K_k`` (or ``K_{k,ℓ}``), as the loop applies them.
    loop : JumpStateSpace
        Their closed loop.
    fields : mapping
        The :class:`DesignResult` fields measured so far.
    estimator_gain : ndarray or None
        The estimator's ``L_k`` the gains belong to.
    """

    gains: np.ndarray
    loop: Any
    fields: Mapping
    estimator_gain: Any = None

    @property
    def value(self) -> float:
        """The certified figure."""
        return float(self.fields["value"])

    def with_fields(self, **changes: Any) -> "Design":
        """The same design with some result fields set."""
        return replace(self, fields={**self.fields, **changes})

    def finish(self) -> tuple[PeriodicGain, Any, float]:
        """``(K, CL, value)``: the frozen result on the gain and the loop."""
        L = self.estimator_gain
        if L is not None:
            L = np.asarray(getattr(L, "gains", L), float)
            L = L[None] if L.ndim == 2 else L
        result = DesignResult(**self.fields, estimator_gain=L)
        K = PeriodicGain(self.gains, result.controller, result.actuator,
                         result=result, estimator_gain=L)
        self.loop.info["synthesis"] = result
        return K, self.loop, result.value


def passive_design(plant: Any, X: Any, Y: Any, gains: np.ndarray, CL: Any,
                   cert: Any, eta_ok: float, eta_solver: float, decay: float,
                   form: str, structure: str, width: int, report: Any,
                   attempts: Any, *, route: str, method: str) -> Design:
    """A passivity route's answer: the certified gain, its certificate
    and the solver's reports."""
    return Design(gains, CL, dict(
        spec="passivity", value=float(eta_ok), route=route, method=method,
        exact=False, ms_radius=float(cert.ms_radius), decay=float(decay),
        controller=plant.controller or "static",
        actuator=plant.actuator or "zero", period=int(gains.shape[0]),
        gain_kind="mode" if gains.ndim == 4 else "phase",
        structure=structure, certificate=cert,
        solver_value=float(eta_solver), report=report,
        attempts=list(attempts), X=X, Y=Y, form=form, width=int(width),
        plant=plant), plant.estimator_gain)
