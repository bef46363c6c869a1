"""The one coercion of a deterministic LTI operand.

python-control's algebra, ``feedback``, ``interconnect`` and an LTI
controller all take "a deterministic system at the loop's step": a
:class:`control.StateSpace`, a :class:`control.TransferFunction` (converted
with :func:`control.ss`, as python-control does), or a static gain. This
module decides, in one place, what is accepted, what is refused and with
which message:

* a random jump system is not deterministic: its ``StateSpace`` face is
  its mean, and combining two jump systems needs the joint law of their
  modes; a jump system whose live modes coincide and do not change with
  the phase *is* an LTI system (:func:`deterministic_lti`), and so is
  accepted;
* a plain ``StateSpace`` copied from a random jump system's mean face
  (``control.ss(sys)``) has lost the modes (:mod:`control_ncs._face`);
* a :class:`~control_ncs.plant.NetworkedStateSpace` is a plant without its
  network loop;
* a continuous-time system, or one with another sampling period, does not
  run at the loop's step (the modes act per step ``dt``, so a system at the
  lifted step ``N·dt`` is named as the likely mistake).
"""

from __future__ import annotations

import numbers
from typing import Any

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import real_array
from ._face import refuse_mean_copy
from .plant import NetworkedStateSpace

__all__: list[str] = []


def is_jump(sys: Any) -> bool:
    """True for a jump system: a StateSpace that carries a mode law."""
    return isinstance(sys, ct.StateSpace) and hasattr(sys, "modes")


def deterministic_lti(sys: Any) -> ct.StateSpace | None:
    """A jump system as the LTI system it is, or None.

    It is one when, at every phase, its live modes coincide
    (``sys.deterministic()``) and the phases coincide too: then every
    step applies the same known linear map. Returned at the base step
    with the per-step signal names and the system's name.
    """
    mats = sys.deterministic()
    if mats is None or any(not np.array_equal(X, X[:1].repeat(len(X), 0))
                           for X in mats):
        return None
    return ct.StateSpace(*(X[0] for X in mats), sys.dt_step,
                         name=str(sys.name), inputs=list(sys.jump_inputs),
                         outputs=list(sys.jump_outputs),
                         states=list(sys.jump_states))


def lti_operand(other: Any, name: str = "other", *, dt: Any = None,
                period: int = 1, gain: tuple[int, int] | None = None,
                arrays: bool = False) -> Any:
    """``other`` as a deterministic discrete-time LTI operand.

    Parameters
    ----------
    other : StateSpace, TransferFunction, scalar or array
    name : str
        The argument's name in messages.
    dt : True or float, optional
        The loop's step; ``other`` must run at it (``True`` or an equal
        float). None: any discrete step.
    period : int
        The loop's period, for the hint when ``other.dt == period·dt``.
    gain : (rows, cols), optional
        Turn a scalar or array into a static-gain StateSpace of this shape
        (a scalar ``s`` becomes ``s·I``) and check the shape of a system.
    arrays : bool
        Return a scalar or array as a float ndarray, unchanged (python-
        control's algebra broadcasts them itself).

    Returns
    -------
    control.StateSpace or ndarray
    """
    if isinstance(other, NetworkedStateSpace):
        raise ControlArgument(
            f"{name}: a NetworkedStateSpace is a plant without its network "
            f"loop; close it first (control_ncs.feedback)")
    refuse_mean_copy(other, name)
    if is_jump(other):
        lti = deterministic_lti(other)
        if lti is None:
            raise ControlArgument(
                f"{name}: expected a deterministic LTI system, got a random "
                f"{type(other).__name__} (its StateSpace face is its mean, "
                f"not a deterministic system)")
        other = lti
    if isinstance(other, ct.LTI):
        sys = other if isinstance(other, ct.StateSpace) else ct.ss(other)
        _check_step(sys, name, dt, period)
    elif isinstance(other, (numbers.Number, np.ndarray, list, tuple)) \
            and not isinstance(other, (bool, np.bool_, complex,
                                       np.complexfloating)):
        if arrays:
            # numbers stay numbers: python-control broadcasts a scalar
            return (other if isinstance(other, numbers.Number)
                    else real_array(other, name))
        if gain is None:
            raise ControlArgument(f"{name}: expected an LTI system "
                                  f"(StateSpace, TransferFunction), got "
                                  f"{type(other).__name__}")
        K = real_array(other, name, ndim=(0, 2))
        if K.ndim == 0:
            if gain[0] != gain[1]:
                raise ControlDimension(
                    f"{name}: a scalar gain needs as many inputs as outputs, "
                    f"the loop needs {gain[0]} × {gain[1]}")
            K = K * np.eye(gain[0])
        sys = ct.ss(np.zeros((0, 0)), np.zeros((0, K.shape[1])),
                    np.zeros((K.shape[0], 0)), K, None, name="gain")
    else:
        raise ControlArgument(
            f"{name}: expected a deterministic LTI system (StateSpace, "
            f"TransferFunction)" + (", a scalar or an array" if arrays or gain
                                    else "") + f", got {type(other).__name__}")
    if gain is not None and (sys.noutputs, sys.ninputs) != gain:
        raise ControlDimension(
            f"{name}: expected {gain[1]} inputs and {gain[0]} outputs, got "
            f"{sys.ninputs} inputs and {sys.noutputs} outputs")
    return sys


def _check_step(sys: ct.StateSpace, name: str, dt: Any, period: int) -> None:
    """Refuse a continuous-time system, or one at another step than ``dt``."""
    if ct.isctime(sys, strict=True):
        step = "dt" if dt is None or dt is True else repr(dt)
        raise ValueError(f"{name}: continuous-time (dt = 0); the loop is "
                         f"discrete-time (incompatible timebases, in "
                         f"python-control's words): discretize it first, e.g. "
                         f"{name}.sample({step}) or control.sample_system")
    if dt is None or dt is True or sys.dt is True or sys.dt is None:
        return
    if not np.isclose(sys.dt, dt, rtol=1e-12, atol=0):
        hint = (f" (N = {period}: the modes act per step, so it must run at "
                f"the base rate dt, not N·dt)"
                if period > 1 and np.isclose(sys.dt, dt * period) else "")
        raise ValueError(f"{name}: sampling periods differ: the loop steps "
                         f"with dt = {dt}, {name} has dt = {sys.dt} "
                         f"(incompatible timebases){hint}")
