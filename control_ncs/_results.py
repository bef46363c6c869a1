"""One way for every result to state its verdict.

Every result object of the package (a synthesis, a passivity certificate,
its exact check, a refinement, an estimator gain) answers the same three
questions in the same words, as SciPy's ``OptimizeResult`` does:

* ``success`` -- a bool: did the call establish what it was asked to?
* ``status`` -- one word from the registry of
  :mod:`control_ncs.exceptions` (``'certified'``, ``'not_mss'``,
  ``'infeasible'``, ...), the same word an exception would carry;
* ``message`` -- one sentence for humans: the verdict and what it rests on.

``summary()`` (a few lines) and the short ``repr`` are written here once,
from the verdict and each class's own figures (``_details()`` and
``_repr_fields``). ``verdict`` is the older name of ``success``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar


def _short(value: Any) -> str:
    """A value as a repr shows it: floats to 6 significant digits."""
    if isinstance(value, bool) or value is None:
        return repr(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    if isinstance(value, str):
        return repr(value)
    return str(value)


class Result:
    """Base of the package's results: ``success``, ``status``, ``message``.

    A subclass provides ``success``, ``status`` and ``message`` (fields or
    properties), names the fields its ``repr`` shows after the status in
    ``_repr_fields``, and gives the lines of :meth:`summary` after the
    verdict in ``_details()``. Dataclass subclasses are declared with
    ``repr=False``, so that the ``repr`` is this one.
    """

    #: Fields the ``repr`` shows after the status, in this order.
    _repr_fields: ClassVar[tuple[str, ...]] = ()

    @property
    def verdict(self) -> bool:
        """``success``, under its older name."""
        me: Any = self          # subclasses define success, status, message
        return bool(me.success)

    def _details(self) -> list[str]:
        """The lines of :meth:`summary` after the verdict."""
        return []

    def summary(self) -> str:
        """A few lines for humans: the verdict, then the figures.

        Returns
        -------
        str
            ``'<Class>: <status>'``, the message, then the figures.
        """
        me: Any = self
        status, message = me.status, me.message
        lines = [f"{type(self).__name__}: {status}", f"  {message}"]
        lines += [f"  {line}" for line in self._details()]
        return "\n".join(lines)

    def __repr__(self) -> str:
        me: Any = self
        parts = [str(me.status)] + [
            f"{name} = {_short(getattr(self, name))}"
            for name in self._repr_fields]
        return f"<{type(self).__name__}: {', '.join(parts)}>"


class CertifiedResult(Result):
    """A result that exists only with its figure verified: ``success`` is
    True and ``status`` ``'certified'`` (a failure raises instead)."""

    @property
    def success(self) -> bool:
        """True: the result exists only with a verified figure."""
        return True

    @property
    def status(self) -> str:
        """``'certified'``."""
        return "certified"
