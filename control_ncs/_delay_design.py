"""Passive design over delayed links: a local search on exact figures.

The loop over delayed links (:mod:`control_ncs.delays`) has no convex
synthesis program here: its gain acts on the measurement of the current age,
a structure the LMIs of :ref:`theory-synthesis` do not express. This route
searches the gains (one per sensor age for the static gain; the predictor's
gain) locally, as the refinement does where the LMI is only sufficient:

1. **stabilise**: minimise the exact ``log ms_radius`` of the loop until it
   is below ``min(1, r²)`` with room to spare;
2. **improve**: maximise the certified passivity level ``η`` of the loop
   (:func:`control_ncs.passivity_certificate`: an LMI, then the exact check).

Both stages are derivative-free (Nelder–Mead) on figures that are exact for
every gain tried; the result is a local optimum, and its level is the one
the exact check certified for the returned loop, never the search's value.
The start is the design for the same plant without delays (its loss kept),
applied at every age.
"""

from __future__ import annotations

import math
import time
import numpy as np
from scipy.optimize import minimize

from .exceptions import (NOT_FOUND, TIME_LIMIT, CertificationError,
                         SynthesisError)
from .gain import PeriodicGain
from .jump import JumpStateSpace
from .passivity import passivity_certificate
from .plant import NetworkedStateSpace
from .stability import ms_radius
from .strategies import feedback

__all__: list[str] = []

#: Stage 1 stops below this fraction of ``min(1, r²)``.
TARGET_FRACTION = 0.95
#: Objective evaluations per stage.
EVALUATIONS = 200


def undelayed(P: NetworkedStateSpace) -> NetworkedStateSpace:
    """The plant with its delays replaced by their losses (the start's
    plant)."""
    return P.with_network(sensor_delay=None, actuator_delay=None,
                          input_delay=None)


def gain_shape(P: NetworkedStateSpace, controller: str) -> tuple[int, ...]:
    """One gain per sensor age (static) or one predictor gain."""
    n, m2, p2 = P.nstates, P.B2.shape[1], P.C2.shape[0]
    ages = (P.sensor_delay.buffer + 1) if P.sensor_delay is not None else 1
    if controller == "predictor":
        return (1, m2, n)
    return (ages, m2, p2)


def delayed_design(P: NetworkedStateSpace, eta: float | None, decay: float,
                   controller: str, actuator: str, deadline: float | None,
                   start: np.ndarray
                   ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """The two-stage local search (module docstring) from ``start`` (of
    :func:`gain_shape`); returns ``(K, CL, eta_certified)`` with the
    :class:`~control_ncs.PassivityResult` on ``K.result``."""
    shape = gain_shape(P, controller)
    x0 = np.broadcast_to(np.asarray(start, float), shape).reshape(-1).copy()
    target = min(1.0, decay ** 2)

    def loop(x: np.ndarray) -> JumpStateSpace:
        return feedback(P, x.reshape(shape), controller=controller,
                        actuator=actuator)

    def out_of_time() -> bool:
        return deadline is not None and time.perf_counter() > deadline

    def rate(x: np.ndarray) -> float:
        if out_of_time():
            return math.inf
        r = ms_radius(loop(x))
        return math.log(r) if r > 0 else -50.0

    x = x0
    if not rate(x) < math.log(TARGET_FRACTION * target):
        res = minimize(rate, x, method="Nelder-Mead",
                       options=dict(maxfev=EVALUATIONS, xatol=1e-6,
                                    fatol=1e-9))
        x = res.x
    if not ms_radius(loop(x)) < target:
        if out_of_time():
            raise SynthesisError(
                "passivesyn: the time limit ran out before the local search "
                "over the delayed link made the loop mean-square stable",
                TIME_LIMIT, dict(ms_radius=ms_radius(loop(x))))
        raise SynthesisError(
            "passivesyn: the local search over the delayed link found no "
            "gain that makes the loop mean-square stable" +
            (f" with decay {decay}" if decay < 1 else "") +
            " (not a proof that none exists)", NOT_FOUND,
            dict(ms_radius=ms_radius(loop(x))))

    def level(x: np.ndarray) -> float:
        if out_of_time():
            return math.inf
        CL = loop(x)
        if not ms_radius(CL) < target:
            return math.inf
        try:
            result = passivity_certificate(CL, None, decay=decay)
        except CertificationError:        # the solver failed on this gain
            return math.inf
        cert = result.certificate
        return -result.eta if cert is not None and cert.verified \
            else math.inf

    if not out_of_time():
        res = minimize(level, x, method="Nelder-Mead",
                       options=dict(maxfev=EVALUATIONS, xatol=1e-5,
                                    fatol=1e-7))
        if np.isfinite(res.fun) and res.fun <= level(x):
            x = res.x
    CL = loop(x)
    try:
        result = passivity_certificate(CL, None, decay=decay)
    except CertificationError as err:
        raise SynthesisError(
            f"passivesyn: the local search's loop has no certificate: "
            f"{err}", NOT_FOUND, dict(reason=err.reason)) from None
    cert = result.certificate
    if cert is None or not cert.verified:
        raise SynthesisError(
            "passivesyn: the local search's loop has no certificate that "
            "passes the exact check", NOT_FOUND, dict(reason=result.reason))
    if eta is not None and not result.eta >= eta:
        raise SynthesisError(
            f"passivesyn: the local search over the delayed link certified "
            f"eta = {result.eta:.6g} < the requested {eta:.6g} (a local "
            f"optimum, not a proof)", NOT_FOUND, dict(eta=result.eta))
    K = PeriodicGain(x.reshape(shape), controller, actuator)
    K.result = result
    return K, CL, float(result.eta)
