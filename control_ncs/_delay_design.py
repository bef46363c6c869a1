"""Passive design over delayed links: a local search on exact figures.

The loop over delayed links (:mod:`control_ncs.delays`) has no convex
synthesis program here: its gain acts on the measurement of the current age,
a structure the LMIs of :ref:`theory-synthesis` do not express. This route
searches the gains (one per sensor age for the static gain; the predictor's
gain) locally, as the refinement does where the LMI is only sufficient:

1. **stabilise**: minimise the exact ``log ms_radius`` of the loop until it
   is below ``min(1, r²)`` with room to spare, by the refinement's
   quasi-Newton method on the Perron gradient
   (:mod:`control_ncs.refine`; the loop is affine in the gains, mode by
   mode, :func:`control_ncs.delays.delayed_parts`). Starts, best rate
   first: the design without delays (its loss kept) at every age; for the
   static gain with the state measured, that gain propagated over the age
   (``K A^a``, what the predictor does without the inputs); zero.
2. **improve**: maximise the certified passivity level ``η`` of the loop
   (:func:`control_ncs.passivity_certificate`: an LMI or the coupled
   Riccati iteration, then the exact check) by Nelder–Mead, keeping the best
   certified loop met on the way; it stops at the first loop certified at a
   requested ``eta``, and at the time limit.

Every figure is exact for the gain tried; the result is a local optimum, and
its level is the one the exact check certified for the returned loop, never
the search's value.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.optimize import minimize

from .delays import delayed_parts, gain_shape
from .exceptions import (NOT_FOUND, TIME_LIMIT, CertificationError,
                         SynthesisError)
from .gain import PeriodicGain
from .jump import JumpStateSpace
from .passivity import passivity_certificate
from .plant import NetworkedStateSpace
from .refine import _bfgs, _StackLoop
from .stability import ms_radius
from .strategies import feedback

__all__: list[str] = []

#: Stage 1 stops below this fraction of ``min(1, r²)``.
TARGET_FRACTION = 0.95
#: Nelder–Mead's evaluations of the certified level (stage 2).
EVALUATIONS = 200
#: Quasi-Newton iterations per start (stage 1), as the refinement's.
ITERATIONS = 200


def undelayed(P: NetworkedStateSpace) -> NetworkedStateSpace:
    """The plant with its delays replaced by their losses (the start's
    plant)."""
    return P.with_network(sensor_delay=None, actuator_delay=None,
                          input_delay=None)


def _rate_loop(P: NetworkedStateSpace, controller: str, actuator: str
               ) -> _StackLoop:
    """The loop's exact rate as a function of the gains, with its gradient."""
    parts = delayed_parts(P, controller, actuator)
    N = parts.T.shape[0]

    def phases(X: np.ndarray) -> np.ndarray:
        return np.broadcast_to(X, (N,) + X.shape)

    return _StackLoop(phases(parts.A0), phases(parts.L), phases(parts.S),
                      parts.g, gain_shape(P, controller)[0], parts.T)


def _starts(P: NetworkedStateSpace, controller: str, start: np.ndarray,
            shape: tuple[int, ...]) -> list[tuple[str, np.ndarray]]:
    """Stage 1's starting points (module docstring)."""
    given = np.broadcast_to(np.asarray(start, float), shape)
    starts = [("undelayed", given.reshape(-1).copy())]
    n = P.nstates
    C2 = np.asarray(P.C2, float)
    if controller == "static" and C2.shape == (n, n) and \
            np.array_equal(C2, np.eye(n)) and shape[0] > 1:
        A = np.asarray(P.A, float)
        propagated = np.array([given[0] @ np.linalg.matrix_power(A, a)
                               for a in range(shape[0])])
        starts.append(("propagated", propagated.reshape(-1)))
    starts.append(("zero", np.zeros(int(np.prod(shape)))))
    return starts


class _Reached(Exception):
    """Stage 2 met the requested level: stop the search there."""


def delayed_design(P: NetworkedStateSpace, eta: float | None, decay: float,
                   controller: str, actuator: str, deadline: float | None,
                   start: np.ndarray
                   ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """The two-stage local search (module docstring) from ``start`` (of
    :func:`gain_shape`); returns ``(K, CL, eta_certified)`` with the
    :class:`~control_ncs.PassivityResult` on ``K.result``."""
    shape = gain_shape(P, controller)
    bound = min(1.0, decay ** 2)
    target = math.log(TARGET_FRACTION * bound)

    def loop(x: np.ndarray) -> JumpStateSpace:
        return feedback(P, x.reshape(shape), controller=controller,
                        actuator=actuator)

    def out_of_time() -> bool:
        return deadline is not None and time.perf_counter() > deadline

    rates = _rate_loop(P, controller, actuator)
    scored = sorted(((rates.rate(x)[0], j, x) for j, (_, x) in
                     enumerate(_starts(P, controller, start, shape))),
                    key=lambda s: (s[0], s[1]))
    best = (scored[0][0], scored[0][2])
    for _, _, x0 in scored:
        if best[0] <= target or out_of_time():
            break
        x, f, _, _ = _bfgs(rates.rate, x0, target, deadline, ITERATIONS)
        if f < best[0]:
            best = (f, x)
    x = best[1]
    if not ms_radius(loop(x)) < bound:
        radius = ms_radius(loop(x))
        if out_of_time():
            raise SynthesisError(
                "passivesyn: the time limit ran out before the local search "
                "over the delayed link made the loop mean-square stable",
                TIME_LIMIT, dict(ms_radius=radius))
        raise SynthesisError(
            "passivesyn: the local search over the delayed link found no "
            "gain that makes the loop mean-square stable" +
            (f" with decay {decay}" if decay < 1 else "") +
            f" (ms_radius {radius:.6g} at best; not a proof that none "
            f"exists)", NOT_FOUND, dict(ms_radius=radius))

    found: dict[str, Any] = {}       # the best certified loop met so far

    def certify(x: np.ndarray) -> float:
        """``-η`` certified for the gain ``x`` (``inf`` if none)."""
        if out_of_time():
            return math.inf
        CL = loop(x)
        if not ms_radius(CL) < bound:
            return math.inf
        try:
            result = passivity_certificate(CL, None, decay=decay)
        except CertificationError:        # the solver failed on this gain
            return math.inf
        cert = result.certificate
        if cert is None or not cert.verified:
            return math.inf
        if "result" not in found or result.eta > found["result"].eta:
            found.update(x=x.copy(), CL=CL, result=result)
        if eta is not None and result.eta >= eta:
            raise _Reached
        return -float(result.eta)

    try:
        certify(x)
        if not out_of_time():
            minimize(certify, x, method="Nelder-Mead",
                     options=dict(maxfev=EVALUATIONS, xatol=1e-5,
                                  fatol=1e-7))
    except _Reached:
        pass
    if "result" not in found:
        why = ("the time limit ran out before a certificate" if
               out_of_time() else "no certificate passed the exact check")
        raise SynthesisError(
            f"passivesyn: the local search over the delayed link made the "
            f"loop mean-square stable, but {why}", TIME_LIMIT if
            out_of_time() else NOT_FOUND, dict(ms_radius=ms_radius(loop(x))))
    result = found["result"]
    if eta is not None and not result.eta >= eta:
        raise SynthesisError(
            f"passivesyn: the local search over the delayed link certified "
            f"eta = {result.eta:.6g} < the requested {eta:.6g} (a local "
            f"optimum, not a proof)", NOT_FOUND, dict(eta=result.eta))
    K = PeriodicGain(found["x"].reshape(shape), controller, actuator)
    K.result = result
    return K, found["CL"], float(result.eta)
