"""Argument checks done once, at the public boundary (STYLE: scipy)."""

from __future__ import annotations

from typing import Any, Iterable, Literal, overload

import numpy as np
from control.exception import ControlArgument, ControlDimension

__all__: list[str] = []


def caller_stacklevel() -> int:
    """``stacklevel`` for :func:`warnings.warn` that names the user's line.

    Counts the frames of this package above the function that warns, so
    that the warning points at the first caller outside ``control_ncs``
    however deep inside the package it was raised.
    """
    import os
    import sys
    package = os.path.dirname(os.path.abspath(__file__)) + os.sep
    frame: Any = sys._getframe(1)  # the function that calls warnings.warn
    level = 1
    while frame is not None and os.path.abspath(
            frame.f_code.co_filename).startswith(package):
        frame = frame.f_back
        level += 1
    return level


#: Largest magnitude accepted for an entry of a matrix: squares of larger
#: numbers overflow float64 (about 1.3e154), which would surface later as an
#: OverflowError or LinAlgError deep inside a Kronecker product or a solver.
MAX_ENTRY = 1e150


def real_array(value: Any, name: str, ndim: int | Iterable[int] | None = None
               ) -> np.ndarray:
    """``value`` as a finite float array, with a message naming ``name``.

    Complex data and strings are refused (numpy would drop an imaginary
    part with only a warning, and parse ``'1.5'`` as a number); so are
    entries larger than :data:`MAX_ENTRY` in magnitude.
    """
    raw = value if isinstance(value, np.ndarray) else None
    if raw is None:
        try:
            raw = np.asarray(value)
        except ValueError:  # ragged nesting
            raw = None
    kind = None if raw is None else raw.dtype.kind
    if kind == "c" or isinstance(value, complex):
        raise ValueError(f"{name}: expected a real numeric array, got complex "
                         f"data (take .real explicitly if that is meant)")
    if kind in ("U", "S"):
        raise ValueError(f"{name}: expected a real numeric array, got str "
                         f"data {value!r}")
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a real numeric array, "
                         f"got {type(value).__name__}") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            raise ControlDimension(f"{name}: expected an array with "
                                   f"{' or '.join(map(str, allowed))} dimensions, "
                                   f"got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: entries must be finite (no nan or inf)")
    if arr.size and np.max(np.abs(arr)) > MAX_ENTRY:
        raise ValueError(f"{name}: entries must not exceed {MAX_ENTRY:g} in "
                         f"magnitude (their squares would overflow), got "
                         f"{np.max(np.abs(arr)):g}")
    return arr


def matrix(value: Any, name: str, shape: tuple[int | None, int | None]
           ) -> np.ndarray:
    """A 2-D finite matrix whose shape matches ``shape`` (None = any)."""
    arr = real_array(value, name)
    if arr.ndim == 0 and shape == (1, 1):
        arr = arr.reshape(1, 1)
    if arr.ndim != 2:
        raise ControlDimension(f"{name}: expected a matrix, got shape {arr.shape}")
    for got, want, what in zip(arr.shape, shape, ("rows", "columns")):
        if want is not None and got != want:
            raise ControlDimension(f"{name}: expected {want} {what}, got shape "
                                   f"{arr.shape}")
    return arr


def discrete_dt(dt: Any, name: str = "dt") -> float | bool:
    """A discrete-time sampling period: True (unspecified) or a number > 0."""
    if dt is True:
        return True
    if np.ndim(dt) != 0 or isinstance(dt, (str, bytes)):
        raise ValueError(f"{name}: expected True or a sampling period > 0, "
                         f"got {dt!r}")
    if dt is None or dt is False or dt == 0:
        raise ValueError(
            f"{name}: control_ncs works in discrete time; got a continuous-time "
            f"system (dt={dt!r}). Discretize first, e.g. "
            f"control.sample_system(sys, Ts)")
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected True or a sampling period > 0, "
                         f"got {dt!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: expected True or a sampling period > 0, "
                         f"got {dt!r}")
    return value


def no_extra_kwargs(func: str, kwargs: dict) -> None:
    """python-control's convention: unknown keywords raise TypeError."""
    if kwargs:
        raise TypeError(f"{func}() got unexpected keyword argument(s): "
                        f"{', '.join(sorted(kwargs))}")


def choice(value: Any, name: str, allowed: Iterable[str]) -> str:
    """One of a few named options, else ControlArgument naming them."""
    allowed = tuple(allowed)
    if value not in allowed:
        raise ControlArgument(f"{name}: expected one of {allowed}, got {value!r}")
    return value


def flag(value: Any, name: str) -> bool:
    """True or False (a bool or numpy bool), else ControlArgument."""
    if not isinstance(value, (bool, np.bool_)):
        raise ControlArgument(f"{name}: expected True or False, got {value!r}")
    return bool(value)


# overloads: without allow_none the result is never None, so callers need
# no cast
@overload
def positive_int(value: Any, name: str, allow_none: Literal[False] = ...
                 ) -> int: ...


@overload
def positive_int(value: Any, name: str, allow_none: bool) -> int | None: ...


def positive_int(value: Any, name: str, allow_none: bool = False
                 ) -> int | None:
    """An int ``>= 1`` (not a bool), or None when allowed."""
    if value is None and allow_none:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name}: expected an int >= 1"
                         f"{' or None' if allow_none else ''}, got {value!r}")
    return int(value)


def positive_real(value: Any, name: str) -> float:
    """A finite real number ``> 0``."""
    out = real_or_nan(value)
    if not out > 0:
        raise ValueError(f"{name}: expected a positive finite number, got "
                         f"{value!r}")
    return out


def real_or_nan(value: Any) -> float:
    """``value`` as a finite float, or nan (bools are not numbers here)."""
    # bools, strings and complex numbers convert to float silently (or with
    # only a warning); none of them is meant as a real number
    if isinstance(value, (bool, np.bool_, str, bytes)) or np.iscomplexobj(
            value) or np.ndim(value) != 0:
        return np.nan
    try:
        out = float(value)
    except (TypeError, ValueError):
        return np.nan
    return out if np.isfinite(out) else np.nan


def decay_bound(value: Any, name: str = "decay") -> float:
    """A decay bound ``r`` in ``(0, 1]``; None means 1 (no bound)."""
    if value is None:
        return 1.0
    r = positive_real(value, name)
    if r > 1.0:
        raise ValueError(f"{name}: expected r in (0, 1], got {value!r}")
    return r


@overload
def finite_real(value: Any, name: str, allow_none: Literal[False] = ...
                ) -> float: ...


@overload
def finite_real(value: Any, name: str, allow_none: bool) -> float | None: ...


def finite_real(value: Any, name: str, allow_none: bool = False
                ) -> float | None:
    """A finite real number (or None when allowed)."""
    if value is None and allow_none:
        return None
    out = real_or_nan(value)
    if np.isnan(out):
        raise ValueError(f"{name}: expected a finite number"
                         f"{' or None' if allow_none else ''}, got {value!r}")
    return out
