"""The route over loss budgets: a gain certified for every allowed pattern
(:ref:`theory-worst-case-dissipativity`, :ref:`theory-budget-links`).

A loop whose link is a loss budget (a :class:`~control_ncs.LossAutomaton`)
has no probabilities to average: the designs certify their figure for
every pattern the budget allows, by the storage LMIs of
:func:`control_ncs.worst_case_route` on the graph of budget states; this
adapter states its answer as the designs' :class:`Design`.
"""

from __future__ import annotations

import math

from ..budgets import worst_case_route
from ..openloop import JumpPlant
from ._result import Design

__all__: list[str] = []


def budget_design(plant: JumpPlant, spec: str, *, eta: float | None = None,
                  decay: float = 1.0, solver: str | None = None,
                  solver_options: dict | None = None) -> Design:
    """The worst-case route's gain and certified figure (``spec``
    ``'passivity'`` or ``'hinf'``) as a :class:`Design`; ``decay`` bounds
    the rate every allowed pattern must beat."""
    res = worst_case_route(plant, "passivity" if spec == "passivity"
                           else "hinf", eta=eta, rate=decay, solver=solver,
                           **(solver_options or {}))
    note = (f"certified for every pattern the loss budget allows: the loop "
            f"decays at rate at most {res.rate:.6g} per step whatever the "
            f"pattern (jsr), and its worst periodic pattern reaches "
            f"{res.bound:.6g}")
    return Design(res.gains, res.loop, dict(
        spec=spec, value=float(res.figure), route="program", method="lmi",
        exact=bool(res.exact), ms_radius=math.nan, decay=float(decay),
        controller=plant.controller or "static",
        actuator=plant.actuator or "zero", period=int(res.gains.shape[0]),
        gain_kind="mode", structure="full", certificate=res,
        lower=float(res.bound) if spec == "hinf" else math.nan,
        note=note, plant=plant), plant.estimator_gain)
