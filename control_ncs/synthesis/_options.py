"""The solver options of the designs, grouped in one mapping.

:func:`~control_ncs.passivesyn`, :func:`~control_ncs.h2syn` and
:func:`~control_ncs.hinfsyn` take the problem (the plant, the level, the
controller kind) as arguments and the solver's knobs in ``options=``, the
way :func:`scipy.optimize.minimize` does. :func:`resolved_options` merges
that mapping with its defaults, and with the knobs a caller still passes as
keywords (deprecated: one :class:`DeprecationWarning` per call, pointing at
the caller's line).
"""

from __future__ import annotations

import warnings
from typing import Any, Mapping

from .._checks import caller_stacklevel
from ..lmi import DEFAULT_MARGIN, check_options, check_solver, installed_solvers

__all__: list[str] = []

#: The knobs every design takes in ``options=``, with their defaults
#: (``solver_options``: passed to the cvxpy solver, or the Riccati
#: iteration's settings with ``solver='riccati'``).
COMMON_DEFAULTS: dict[str, Any] = dict(solver=None, margin=DEFAULT_MARGIN,
                                       time_limit=60.0, solver_options={})

#: Longest representation of a value in the deprecation message.
SHOWN_CHARS = 60


def resolved_options(who: str, options: Mapping[str, Any] | None,
                     keywords: Mapping[str, Any],
                     defaults: Mapping[str, Any]) -> dict[str, Any]:
    """The options of one call of ``who``: ``defaults`` updated by
    ``options`` and by the deprecated ``keywords``.

    ``defaults`` names the accepted keys. ``keywords`` are the call's extra
    keywords: a knob by its name (``margin=1e-6``) or, any other name, a
    solver option (once ``**solver_options``). Raises TypeError for an
    unknown key, a knob given both ways, or ``options`` that is not a
    mapping with string keys; warns once (DeprecationWarning) when
    ``keywords`` is not empty. The values are checked where they are used,
    as they were as keywords.
    """
    given = _checked_mapping(who, options)
    accepted = tuple(defaults)
    unknown = [key for key in given if key not in defaults]
    if unknown:
        raise TypeError(
            f"{who}() got unknown option(s) {unknown} in options; accepted "
            f"keys: {', '.join(accepted)}")
    if "solver_options" in given:
        given["solver_options"] = dict(_checked_mapping(
            who, given["solver_options"], "options['solver_options']"))
    moved = _moved_keywords(who, keywords, defaults, given)
    if "solver_options" in moved:
        # a keyword that is no option of the solver is an unknown keyword:
        # TypeError at once, without a deprecation warning before it
        solver = moved.get("solver", given.get("solver", defaults.get(
            "solver")))
        if solver is None or str(solver).upper() in installed_solvers():
            try:
                check_options(check_solver(solver), moved["solver_options"])
            except TypeError as err:
                raise TypeError(
                    f"{who}() got unexpected keyword argument(s) "
                    f"{sorted(moved['solver_options'])}: neither a keyword "
                    f"of {who} nor, deprecated, a solver option ({err})"
                    ) from None
    if moved:
        _warn_deprecated(who, keywords, moved)
    resolved = dict(defaults, **given, **moved)
    resolved["solver_options"] = dict(resolved["solver_options"])
    return resolved


def _checked_mapping(who: str, value: Any, name: str = "options"
                     ) -> dict[str, Any]:
    """A copy of a mapping with string keys (None: empty), else TypeError."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError(f"{who}(): {name} must be a mapping (a dict) of "
                        f"option names to values, got "
                        f"{type(value).__name__}")
    bad = [key for key in value if not isinstance(key, str)]
    if bad:
        raise TypeError(f"{who}(): {name} keys must be strings, got {bad}")
    return dict(value)


def _moved_keywords(who: str, keywords: Mapping[str, Any],
                    defaults: Mapping[str, Any], given: Mapping[str, Any]
                    ) -> dict[str, Any]:
    """The deprecated keywords as options: knobs by name, the rest
    gathered into ``solver_options``; TypeError where a knob is given both
    ways."""
    if "solver_options" in keywords:
        raise TypeError(
            f"{who}() got the keyword solver_options; solver options go in "
            f"options={{'solver_options': {{...}}}}")
    knobs = {k: v for k, v in keywords.items() if k in defaults}
    extra = {k: v for k, v in keywords.items() if k not in defaults}
    both = [k for k in knobs if k in given]
    if extra and "solver_options" in given:
        both.append("solver_options")
    if both:
        raise TypeError(
            f"{who}() got {', '.join(both)} both as keyword(s) and in "
            f"options; give each only in options")
    if extra:
        knobs["solver_options"] = extra
    return knobs


def _warn_deprecated(who: str, keywords: Mapping[str, Any],
                     moved: Mapping[str, Any]) -> None:
    """One DeprecationWarning naming the keywords and what to write."""
    names = ", ".join(f"{k}=" for k in keywords)
    spelled = ", ".join(f"{k!r}: {_shown(v)}" for k, v in moved.items())
    warnings.warn(
        f"{who}(): passing the solver options {names} as keywords is "
        f"deprecated; pass them in options: options={{{spelled}}}",
        DeprecationWarning, stacklevel=caller_stacklevel())


def _shown(value: Any) -> str:
    """A value's repr, shortened for a message."""
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else text[:SHOWN_CHARS - 3] + \
        "..."
