"""python-control's algebra on a jump system, mode by mode
(:ref:`theory-interconnection`, :ref:`theory-jump-system`).

python-control's operators, ``feedback``, ``append`` and indexing dispatch
to a :class:`~control_ncs.jump.JumpStateSpace`'s methods
(``control.series`` and ``control.parallel`` call the operators; Python
calls a subclass's reflected operator first, so ``G * CL`` reaches
``__rmul__``). With a deterministic LTI ``G`` each mode of the result is
python-control's operation on that mode, at the base rate, with the same
probabilities: exact, because ``G`` has no modes and the mode at time
``t`` is the same draw on both sides (an algebraic loop is closed inside
the mode, as in :func:`control_ncs.jump_feedback`). A jump system whose
live modes coincide at every phase is such a ``G``
(:func:`control_ncs._lti.deterministic_lti`); two random ones are refused.
The operators live here, in :class:`ModewiseAlgebra`, the base of
``JumpStateSpace``.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._lti import deterministic_lti, is_jump, lti_operand

__all__: list[str] = []


class ModewiseAlgebra(ct.StateSpace):
    """python-control's operators on a jump system, mode by mode.

    The base of :class:`~control_ncs.jump.JumpStateSpace`, never built on
    its own: it reads the jump system's ``mode_system``, ``mode_law`` and
    signal names, and builds results of the jump system's own class.
    """

    def _operand(self, other: Any, what: str) -> Any:
        """``other`` checked to be deterministic LTI data at the base rate
        (:func:`control_ncs._lti.lti_operand`); NotImplemented for types
        python's operator protocol should try elsewhere."""
        if is_jump(other) and other._random:
            raise ControlArgument(
                f"{what}: both operands are jump systems. Their modes are "
                f"independent only if you say so, and python-control's "
                f"algebra cannot: the interconnection needs the joint law of "
                f"the two mode sequences. Build one jump system over the "
                f"joint modes with jss() (products of the probabilities if "
                f"independent), or use the mean systems .mean() knowingly "
                f"(exact for E z only without an algebraic loop)")
        if not isinstance(other, (ct.InputOutputSystem, numbers.Number,
                                  np.ndarray, list, tuple)):
            return NotImplemented
        try:
            return lti_operand(other, "other", dt=self.dt_step,
                               period=self.period, arrays=True)
        except (ValueError, TypeError) as err:
            raise type(err)(f"{what}: {err}") from None

    def _reflected(self, other: Any) -> ct.StateSpace | None:
        """This system as an LTI operand, if it is deterministic and
        ``other`` is a random jump system: the operation is then built on
        ``other``'s modes (``self`` on the left of each)."""
        if is_jump(other) and other._random:
            return deterministic_lti(self)
        return None

    def _modewise(self, op: Any, what: str, *, name: str | None = None,
                  names: dict | None = None) -> "ModewiseAlgebra":
        """The jump system whose mode (k, i) is ``op`` of mode (k, i)."""
        N, M = self.period, self.nmodes
        try:
            first = op(self.mode_system(0, 0))
        except ValueError as err:
            # python-control's message names neither side's sizes
            raise ControlDimension(
                f"{what}: {err} (the jump system has "
                f"{len(self.jump_inputs)} inputs and "
                f"{len(self.jump_outputs)} outputs per step)") from err
        done = [[first if k == i == 0 else op(self.mode_system(k, i))
                 for i in range(M)] for k in range(N)]
        A, B, C, D = (np.array([[getattr(S, X) for S in row] for row in done],
                               dtype=float) for X in "ABCD")
        labels = dict(inputs=list(first.input_labels),
                      outputs=list(first.output_labels),
                      states=list(first.state_labels))
        labels.update(names or {})
        dt = self.dt_step if first.dt is True else first.dt
        return type(self)(A, B, C, D, self.mode_law()[0], dt,
                          transition=self.modes.transition,
                          nominal=self.nominal_mode, name=name,
                          info=dict(self.info, algebra=what),
                          inputs=labels["inputs"],
                          outputs=labels["outputs"],
                          states=labels["states"])

    def __neg__(self) -> "ModewiseAlgebra":
        return self._modewise(lambda S: -S, "-sys")

    def __add__(self, other: Any) -> Any:
        lti = self._reflected(other)
        if lti is not None:
            return other.__radd__(lti)
        G = self._operand(other, "sys + other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S + G, "sys + other")

    def __radd__(self, other: Any) -> Any:
        G = self._operand(other, "other + sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G + S, "other + sys")

    def __sub__(self, other: Any) -> Any:
        lti = self._reflected(other)
        if lti is not None:
            return other.__rsub__(lti)
        G = self._operand(other, "sys - other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S - G, "sys - other")

    def __rsub__(self, other: Any) -> Any:
        G = self._operand(other, "other - sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G - S, "other - sys")

    def __mul__(self, other: Any) -> Any:
        lti = self._reflected(other)
        if lti is not None:
            return other.__rmul__(lti)
        G = self._operand(other, "sys * other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S * G, "sys * other")

    def __rmul__(self, other: Any) -> Any:
        G = self._operand(other, "other * sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G * S, "other * sys")

    def __truediv__(self, other: Any) -> Any:
        lti = self._reflected(other)
        if lti is not None:
            return other.__rtruediv__(lti)
        G = self._operand(other, "sys / other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S / G, "sys / other")

    def __rtruediv__(self, other: Any) -> Any:
        return self._refuse("other / sys")

    def __pow__(self, other: Any) -> Any:
        if type(other) is int and other == 1:
            return self._modewise(lambda S: S, "sys ** 1")
        if type(other) is int and other == -1:
            # the inverse of the map at each step is the inverse of its mode
            return self._modewise(lambda S: S ** -1, "sys ** -1")
        return self._refuse(f"sys ** {other!r}")

    def _refuse(self, what: str) -> Any:
        from control.exception import ControlArgument
        raise ControlArgument(
            f"{what}: not defined for a jump system: it would put two copies "
            f"of the same random system in series, whose modes are neither "
            f"the same draw nor independent; build the interconnection with "
            f"control_ncs.interconnect or jss()")

    def __getitem__(self, key: Any) -> "ModewiseAlgebra":
        # indices and names refer to the per-step signals z (rows) and w
        # (columns) for any N, not to the lifted face's stacked ones
        sizes = (len(self.jump_outputs), len(self.jump_inputs))
        if isinstance(key, tuple) and len(key) == 2:
            for index, size, what in zip(key, sizes, ("output", "input")):
                if isinstance(index, (int, np.integer)) and not (
                        -size <= index < size):
                    raise ControlDimension(
                        f"sys[{key!r}]: {what} index {index} is out of "
                        f"range for {size} {what}s")
        try:
            first = self.mode_system(0, 0)[key]
        except (IndexError, KeyError, ValueError, TypeError) as err:
            raise ControlDimension(f"sys[{key!r}]: {err}") from None
        if first.noutputs == 0 or first.ninputs == 0:
            raise ControlDimension(
                f"sys[{key!r}]: selects no output or no input of {sizes[0]} "
                f"outputs and {sizes[1]} inputs")
        return self._modewise(lambda S: S[key], f"sys[{key!r}]",
                              name=first.name)
