"""The loss probability at which a loop stops meeting a spec
(:ref:`theory-performance`).

For a given gain the spec is mean-square stability, an H2 bound (both
exact), or a certified ℓ2-gain bound or passivity level; without a gain, the
best design's figure at each loss (:func:`control_ncs.h2syn`,
:func:`control_ncs.hinfsyn`, :func:`control_ncs.passivesyn`), or the
critical arrival probability of LQ over the actuator link
(:func:`control_ncs.dlqr`). One bisection serves them all, checked for a
single crossing.
"""

from __future__ import annotations

import inspect
import warnings
from typing import Any, Callable, Mapping

import numpy as np
from control.exception import ControlArgument

from ._checks import choice, finite_real, positive_real
from .exceptions import CertificationError, NotPassiveWarning
from .lq import critical_control_arrival
from .performance import l2_gain, norm
from .synthesis import h2syn, hinfsyn
from .synthesis._options import resolved_options
from .synthesis.norms import DEFAULTS as NORM_OPTIONS
from .synthesis.passive import DEFAULTS as PASSIVE_OPTIONS
from ._map_grid import at_loss
from .delays import BurstyDelay
from .network import GilbertElliott
from .plant import NetworkedStateSpace
from .stability import ms_radius
from .loop import feedback
from .synthesis import passivesyn

__all__ = ["critical_loss"]


def critical_loss(P: Any, K: Any = None, *, link: str = "actuator",
                  tol: float = 1e-6, h2: float | None = None,
                  hinf: float | None = None, eta: float | None = None,
                  options: Mapping[str, Any] | None = None,
                  **kwargs: Any) -> float:
    """The loss probability at which a gain stops stabilising the loop.

    The loop ``feedback(P, K)`` (``u = K y``, :ref:`guide-sign`) with the
    loss of one Bernoulli ``link``
    varied: the loss ``α*`` at which ``ms_radius`` reaches 1, found by
    bisection on ``[0, 1)`` and checked at both ends of the final bracket
    (the loop is mean-square stable at the returned ``α*`` minus ``tol``
    and not at ``α*``). With ``h2=`` the spec is the H2 norm instead: the
    loss at which :func:`norm` of the loop reaches ``h2`` (the loop meets
    the spec below it, and is mean-square stable there). With ``hinf=`` or
    ``eta=`` the spec is a certified one: the ℓ2 gain below ``hinf``
    (:func:`l2_gain`'s certified bound) or the passivity level at least
    ``eta`` (:func:`control_ncs.passivity_certificate`); the returned loss
    is where the certificate stops: the spec is *proven* just below it, and
    not certified at it, which is not a proof that it fails there (the
    bounded real lemma is exact for a fixed loop, so for the ℓ2 gain the
    two differ by the certificate's tolerance, about 1e-4 relative in the
    gain; on the scalar loops of the tests both specs land within 1e-5 of
    their closed forms). For the loss
    beyond which *no* gain stabilises a
    state-feedback loop over its actuator link, see the critical arrival
    probability :func:`control_ncs.dlqr` states; ``K=None`` returns that
    loss (``1 - ν_c``: exact when ``B2`` reaches the whole unstable subspace
    or is one input, else the certified end of a bisection). ``K=None``
    with a spec measures the best design at each loss instead of one gain's
    loop: :func:`control_ncs.h2syn` or
    :func:`control_ncs.hinfsyn` (their exact programs where the gain sees
    the whole state, the global optimum; their local searches otherwise)
    or :func:`control_ncs.passivesyn` for ``eta``, with ``**kwargs`` as
    their ``controller`` and ``actuator`` and ``options`` as their
    ``options``.

    Parameters
    ----------
    P : NetworkedStateSpace
        The plant; its other network settings are kept.
    K : array_like or PeriodicGain, optional
        The gain, as for :func:`control_ncs.feedback`. None: the loss beyond
        which no state feedback over the actuator link stabilises the loop
        (period 1, ``y = x``), or, with a spec, the best design's.
    link : {'actuator', 'sensor'}, optional
        Which link's loss varies.
    tol : float, optional
        Width of the final bracket.
    h2 : float, optional
        A bound on the loop's H2 norm (a spec): return the loss at which
        the norm reaches it.
    hinf : float, optional
        A bound on the loop's ℓ2 gain (H∞ norm), certified at each loss
        tried.
    eta : float, optional
        A passivity level (the output-feedback index ``η`` of
        :ref:`theory-passivity`), certified at each loss tried. At most one
        of ``h2``, ``hinf`` and ``eta``.
    options : dict, optional
        ``K=None`` with a spec: the solver options of each design (as
        :func:`control_ncs.h2syn`, :func:`control_ncs.hinfsyn` or
        :func:`control_ncs.passivesyn` take them, e.g. ``{'time_limit':
        20}``).
    **kwargs
        Passed to :func:`control_ncs.feedback` (``controller``,
        ``actuator``), or with ``K=None`` to the designs (their keywords:
        ``controller``, ``actuator``, ``decay``, ...; solver options given
        here are deprecated, pass them in ``options``).

    Returns
    -------
    float
        ``α*`` in ``(0, 1]``; 1.0 if the loop is mean-square stable (meets
        the spec) for every loss below 1; 0.0 if it is not even without
        loss. Over a bursty (Gilbert–Elliott) link the loss is the link's
        stationary loss at its own mean burst length ``b`` (bursts of that
        length allow losses below ``b/(1 + b)``, the value returned when
        the loop meets the spec at all of them); over a delayed link it is
        a loss composed with the delay law (a packet is lost with
        probability ``α``, else delayed, :ref:`theory-links-compose`).

    Raises
    ------
    ValueError
        If the loop is stable at some loss above one at which it is not
        (``ms_radius`` is not monotone in the loss here: no single critical
        value exists), naming both.

    Examples
    --------
    ``x⁺ = 2x + θu``, ``u = -2x``: ``E x² = 4α x²`` per step, so the gain
    stops stabilising at ``α = 1/4``.

    >>> import control_ncs as ncs
    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1)
    >>> round(ncs.critical_loss(P, [[-2.0]]), 5)
    0.25

    No gain stabilises it beyond the loss ``1/a² = 0.25`` either (the
    deadbeat gain above is the best):

    >>> round(ncs.critical_loss(P), 5)
    0.25

    With ``w`` entering as ``x⁺ = 2x + w + θu`` and ``z = x``, the H2 norm
    is ``1/√(1 - 4α)``: it reaches 2 at ``α = 3/16``.

    >>> round(ncs.critical_loss(P, [[-2.0]], h2=2.0), 5)
    0.1875

    Its ℓ2 gain is certified below 3 up to the loss ``1/6``, where the
    scalar bounded real lemma puts it at 3:

    >>> round(ncs.critical_loss(P, [[-2.0]], hinf=3.0, tol=1e-4), 3)
    0.167

    The best gain at each loss (h2syn, here its exact program: deadbeat)
    keeps the H2 norm below 2 up to the same loss, 3/16:

    >>> round(ncs.critical_loss(P, h2=2.0), 5)
    0.1875
    """
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if options is not None and K is not None:
        raise ControlArgument(
            "options: the solver options of the designs apply with K=None "
            "and a spec (h2, hinf or eta); a given gain is analysed")
    choice(link, "link", ("actuator", "sensor"))
    tol = positive_real(tol, "tol")
    specs = [name for name, value in (("h2", h2), ("hinf", hinf),
                                      ("eta", eta)) if value is not None]
    if len(specs) > 1:
        raise ControlArgument(f"{', '.join(specs)}: give at most one spec "
                              f"of h2, hinf and eta")
    h2 = None if h2 is None else positive_real(h2, "h2")
    hinf = None if hinf is None else positive_real(hinf, "hinf")
    eta = None if eta is None else finite_real(eta, "eta")
    if options is not None and not specs:
        raise ControlArgument(
            "options: the solver options of the designs apply with a spec "
            "(h2, hinf or eta); without one the critical loss is "
            "dlqr's closed form")
    if K is None and not specs:
        if link != "actuator" or P.period != 1 or not np.array_equal(
                P.C2, np.eye(P.nstates)):
            raise ControlArgument(
                "K: the best gain's critical loss is that of state feedback "
                "over the actuator link (link='actuator', period 1, y = x); "
                "give a gain K otherwise")
        A, B2 = np.asarray(P.A, float), np.asarray(P.B2, float)
        nu = critical_control_arrival(A, B2).upper
        return float(1.0 - nu)

    given = getattr(P, f"{link}_link")
    if isinstance(getattr(P, f"{link}_delay"), BurstyDelay):
        raise ControlArgument(
            f"link: the {link} link's losses are in its bursty delay laws "
            f"(one per channel state), not one loss probability; vary those "
            f"laws (a design_map over them), or give the link a random_delay")
    # a bursty link keeps its mean burst length while its loss varies, up
    # to the largest loss bursts of that length allow; a loss on a delayed
    # link composes with its delay law (a packet lost, else delayed)
    burst = given.burst if isinstance(given, GilbertElliott) and \
        not given.is_bernoulli else None
    top = 1.0 - 1e-12 if burst is None else burst / (1.0 + burst) * (
        1.0 - 1e-12)

    if K is None:
        design, keywords, solve = _design(h2, hinf, options, kwargs)

    def stable(alpha: float) -> bool:
        Pa = P.with_network(**{f"{link}_loss": at_loss(given, alpha, burst)})
        if K is None:
            return _best_meets(Pa, h2, hinf, eta, design, keywords, solve)
        CL = feedback(Pa, K, **kwargs)
        if h2 is not None:
            return norm(CL, print_warning=False) < h2
        if not ms_radius(CL) < 1.0:
            return False
        try:
            if hinf is not None:
                return l2_gain(CL).gamma < hinf
            if eta is not None:
                from .passivity import passivity_certificate
                result = passivity_certificate(CL, None)
                return bool(result.certificate is not None
                            and result.certificate.verified
                            and result.eta >= eta)
        except CertificationError:          # nothing certified there
            return False
        return True

    if not stable(0.0):
        return 0.0
    if stable(top):
        return 1.0 if burst is None else float(top)
    lo, hi = 0.0, top
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    # the bisection assumes one crossing; check a coarse grid above it
    for alpha in np.linspace(hi, top, 9)[1:]:
        if stable(float(alpha)):
            what = ("mean-square stable" if not specs else
                    f"within the H2 bound {h2:g}" if h2 is not None else
                    f"certified within the l2 gain {hinf:g}"
                    if hinf is not None else
                    f"certified at the passivity level {eta:g}")
            if K is None:
                raise ValueError(
                    f"P: the best design found is not {what} at loss "
                    f"{hi:.6g} but is again at {alpha:.6g}; no single "
                    f"critical loss exists (local searches, where they run, "
                    f"may also end at different optima)")
            raise ValueError(
                f"K: the loop is not {what} at loss {hi:.6g} but is again "
                f"at {alpha:.6g}; no single critical loss exists")
    return float(hi)


def _design(h2: float | None, hinf: float | None,
            options: Mapping[str, Any] | None, kwargs: dict
            ) -> tuple[Callable, dict, dict]:
    """The design of a spec, its keywords among ``kwargs`` and its
    options; the other keywords are solver options given the old way,
    moved into the options (one DeprecationWarning)."""
    design: Callable = h2syn if h2 is not None else \
        hinfsyn if hinf is not None else passivesyn
    takes = set(inspect.signature(design).parameters) - {
        "P", "eta", "options", "kwargs"}
    keywords = {k: v for k, v in kwargs.items() if k in takes}
    knobs = {k: v for k, v in kwargs.items() if k not in takes}
    defaults = PASSIVE_OPTIONS if design is passivesyn else NORM_OPTIONS
    return design, keywords, resolved_options("critical_loss", options,
                                              knobs, defaults)


def _best_meets(P: NetworkedStateSpace, h2: float | None,
                hinf: float | None, eta: float | None, design: Callable,
                keywords: dict, options: dict) -> bool:
    """Whether the best design of ``P`` meets the spec (certified)."""
    try:
        if h2 is not None:
            return design(P, **keywords, options=options)[2] < h2
        if hinf is not None:
            return design(P, **keywords, options=options)[2] < hinf
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotPassiveWarning)
            return eta is not None and \
                design(P, None, **keywords, options=options)[2] >= eta
    except CertificationError:          # no certified design there
        return False
