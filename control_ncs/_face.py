"""python-control's view of a jump system: its printed forms, copies of
its mean face, and the calls that would read only that face.

A :class:`~control_ncs.jump.JumpStateSpace` *is* a
:class:`control.StateSpace` whose matrices are its exact mean system
(:ref:`theory-moments`). This module decides, in one place, how that
object meets python-control where python-control gives it no method to
override:

* **Printing** follows python-control's protocol: ``repr`` in the
  ``'eval'`` format (loadable, at numpy's print precision as
  python-control's, as long as it fits in a screen) or the
  ``'info'`` format, ``_repr_html_`` and ``str``, each naming the class
  and, for the per-step signals, the mode law.
* **Copies.** python-control's copy constructor (``control.ss(sys)``,
  ``StateSpace(sys)``, ``similarity_transform``, the canonical forms)
  returns a plain ``StateSpace`` of the mean face. It keeps the face's
  state names as they are, so the names of a *random* jump system are
  marked (:class:`MeanFaceState`) and the package's functions refuse a
  copy that carries them (:func:`refuse_mean_copy`): analysing it would
  silently drop the randomness.
* **Reads.** Where python-control would compute a different figure from
  the face without a word -- ``control.norm``, a
  :class:`control.TransferFunction` operator with the jump system on the
  right, ``control.tf(sys)`` -- the read is refused, naming the call to
  use; ``control.step_response`` of a period-``N`` system warns. The
  caller is recognised by its code object (python-control is not
  patched).
"""

from __future__ import annotations

import re
import sys as _sys
import warnings
from types import FrameType
from typing import Any

import control as ct
import control.sysnorm
import control.timeresp
import control.xferfcn
import numpy as np
from control.exception import ControlArgument

__all__: list[str] = []


class MeanFaceState(str):
    """The name of a state of a random jump system's mean face.

    A plain :class:`str` in every respect; python-control copies state
    names by reference, so a plain ``StateSpace`` holding one is a copy of
    a jump system's mean face.
    """

    __slots__ = ()


def face_states(names: list[str], random: bool) -> list[str]:
    """The face's state names, marked when the system is random."""
    return [MeanFaceState(s) for s in names] if random else list(names)


def plain(names: list[str]) -> list[str]:
    """Names as plain strings (for a system that is not a copy)."""
    return [str(s) for s in names]


def is_mean_copy(sys: Any) -> bool:
    """Whether ``sys`` is a plain StateSpace copied from the mean face of a
    random jump system (it carries the face's marked state names)."""
    return (isinstance(sys, ct.StateSpace) and not hasattr(sys, "modes")
            and any(type(s) is MeanFaceState for s in sys.state_index))


def refuse_mean_copy(sys: Any, name: str = "sys") -> None:
    """Raise ``ControlArgument`` if ``sys`` is a copy of a mean face, or a
    system that has no mean face and says which analysis it takes instead
    (a loop over a loss budget: its ``_analysis_refusal(name)``)."""
    refusal = getattr(type(sys), "_analysis_refusal", None)
    if callable(refusal):
        raise ControlArgument(refusal(sys, name))
    if is_mean_copy(sys):
        raise ControlArgument(
            f"{name}: a plain StateSpace copied from the mean face of the "
            f"jump system '{sys.name}' (control.ss(sys), StateSpace(sys), "
            f"similarity_transform or a canonical form): it has lost the "
            f"random modes, and analysing it would answer for the mean "
            f"system only. Pass the jump system itself, or sys.mean() to "
            f"analyse the mean system knowingly")


# -- printing ------------------------------------------------------------------
#: A loadable ``repr`` longer than this falls back to the ``'info'`` form.
EVAL_MAX_LINES, EVAL_MAX_CHARS = 24, 2000

#: python-control's generic signal names, shown as counts in ``repr``.
GENERIC = {"states": "x", "outputs": "y", "inputs": "u"}


def _is_generic_name(name: str) -> bool:
    return re.match(r"^sys\[\d*\]$", name) is not None


def info_repr(J: Any, html: bool = False) -> str:
    """``<JumpStateSpace name: [inputs] -> [outputs], dt=…[, period N][,
    M modes]>`` with the per-step signals (python-control's ``'info'``)."""
    out = (f"<{type(J).__name__} {J.name}: {list(J.jump_inputs)} -> "
           f"{list(J.jump_outputs)}, dt={J.dt_step}")
    if J.period > 1:
        out += f", period {J.period}"
    if J.nmodes > 1:
        law = "i.i.d." if J.modes.is_iid else "Markov"
        out += f", {J.nmodes} {law} modes"
    out += ">"
    if html:       # as python-control escapes its own info line
        out = "".join({"$": r"\$", "<": "&lt;", ">": "&gt;"}.get(c, c)
                      for c in out)
    return out


def _labels_repr(J: Any) -> str:
    """python-control's label part of an ``'eval'`` repr, for the per-step
    signals: the name if not generic, then states, outputs and inputs as
    a count when python-control's generic names, else as a list."""
    out, count = "", 0
    if not _is_generic_name(J.name):
        out = f"name='{J.name}'"
        count = len(out)
    for key, labels in (("states", J.jump_states),
                        ("outputs", J.jump_outputs),
                        ("inputs", J.jump_inputs)):
        generic = all(re.match(r"^" + GENERIC[key] + r"\[\d*\]$", s)
                      for s in labels)
        spec = f"{key}={len(labels)}" if generic else f"{key}={plain(labels)}"
        if count == 0:
            count = len(spec)
        elif count + len(spec) > 72:
            out += ",\n"
            count = len(spec)
        else:
            out += ", "
            count += len(spec) + 2
        out += spec
    return out


def _stack_repr(X: np.ndarray) -> str:
    """``repr`` of a per-phase, per-mode stack in its shortest loadable
    shape: one matrix if all coincide, an ``(M, ., .)`` stack if the
    phases do; blank lines between blocks dropped."""
    if np.all(X == X[:1, :1]):
        X = X[0, 0]
    elif np.all(X == X[:1]):
        X = X[0]
    return _tight(repr(X))


def _tight(text: str) -> str:
    """numpy's ``repr`` without the blank lines between blocks."""
    return re.sub(r"\n\s*\n", "\n", text)


def eval_repr(J: Any) -> str:
    """A loadable ``JumpStateSpace(...)`` (numpy's ``array``), or the
    ``'info'`` form when it would not fit in a screen.

    As python-control's, the matrices are printed at numpy's precision;
    the mode law is printed exactly (numpy's ``'unique'`` float mode), so
    that its rows still sum to one when loaded.
    """
    m = J.modes
    law, transition = J.mode_law()
    one = J.period == 1          # the law keeps the period N otherwise
    parts = [_stack_repr(X) for X in (m.A, m.B, m.C, m.D)]
    with np.printoptions(floatmode="unique"):
        if transition is not None and np.array_equal(law, m.probabilities[0]):
            law_text = "None"       # the stationary law, recomputed exactly
        else:
            law_text = _tight(repr(law[0] if one and law.ndim == 2 else law))
        parts += [law_text, f"dt={J.dt_step}"]
        if transition is not None:
            parts.append("transition=" + _tight(repr(
                transition[0] if one else transition)))
    if J.nominal_mode is not None:
        parts.append(f"nominal={J.nominal_mode.tolist()}")
    out = f"{type(J).__name__}(\n" + ",\n".join(
        parts + [_labels_repr(J)]) + ")"
    if out.count("\n") >= EVAL_MAX_LINES or len(out) > EVAL_MAX_CHARS:
        return info_repr(J)
    return out


def html_repr(J: Any) -> str | None:
    """python-control's LaTeX of the mean face under the jump system's
    ``'info'`` line (None when python-control gives none: too large)."""
    html = ct.StateSpace._repr_html_(J)
    if html is None:
        return None
    head = ct.InputOutputSystem._repr_info_(J, html=True)
    return info_repr(J, html=True) + html[len(head):]


def str_repr(J: Any) -> str:
    """python-control's ``str`` layout: the face's signals, the mode law,
    then the mean matrices ``A``, ``B``, ``C``, ``D``."""
    p = np.array2string(J.modes.probabilities, precision=4)
    law = "i.i.d." if J.modes.is_iid else "Markov"
    lines = [ct.InputOutputSystem.__str__(J),
             f"Periodic jump linear system: period N = {J.period}, "
             f"{J.nmodes} {law} mode{'s' if J.nmodes > 1 else ''} per step, "
             f"dt = {J.dt_step}",
             f"Mode probabilities (rows = phases):\n{p}"]
    if J.modes.transition is not None:
        T = np.array2string(J.modes.transition, precision=4)
        lines.append(f"Transition T[k][i, j] = P(j next | i now):\n{T}")
    kind = J.info.get("controller")
    if kind:
        lines.append(f"Closed loop of a networked plant: controller={kind!r}, "
                     f"actuator={J.info.get('actuator')!r}")
    lines.append("Mean system (exact E z for deterministic w):"
                 if J.period == 1 else
                 "Mean system lifted over one period (dt = N·dt):")
    mats = "\n\n".join(
        "{} = {}".format(X, "\n    ".join(str(M).splitlines()))
        for X, M in zip("ABCD", (J.A, J.B, J.C, J.D)))
    return "\n".join(lines) + "\n\n" + mats


# -- reads of the face that python-control would answer for the mean only ------
_NORM = control.sysnorm.system_norm.__code__
_TO_TF = control.xferfcn._convert_to_transfer_function.__code__
_STEP = control.timeresp.step_response.__code__
_TF = ct.TransferFunction
#: python-control callers of the transfer-function conversion that would
#: silently return a transfer function of the mean (what the user wrote).
_TF_READS = {
    _TF.__mul__.__code__: "G * sys (or series(sys, G))",
    _TF.__rmul__.__code__: "sys * G",
    _TF.__add__.__code__: "G + sys (or G - sys, parallel(G, sys))",
    _TF.__truediv__.__code__: "G / sys",
    _TF.__rtruediv__.__code__: "sys / G",
    control.xferfcn.ss2tf.__code__: "control.tf(sys) or control.ss2tf(sys)",
}


def check_norm_caller(J: Any, frame: FrameType | None) -> None:
    """Refuse when :func:`control.norm` is copying the jump system ``J``:
    it would return the mean system's norm (:ref:`theory-performance`)."""
    for _ in range(3):          # the hook, control.ss(), control.norm
        if frame is None:
            return
        if frame.f_code is _NORM:
            raise ControlArgument(
                "control.norm(sys) would compute the norm of the mean "
                "system, not of this jump system (its modes are random): "
                "use control_ncs.norm(sys, p) for the exact H2 norm or the "
                "certified l2 gain, or control.norm(sys.mean(), p) for the "
                "mean system's")
        frame = frame.f_back


def check_face_read(J: Any, frame: FrameType | None) -> None:
    """Refuse python-control's conversion of a random jump system to a
    transfer function where the user asked for algebra or a copy."""
    if frame is None or frame.f_code is not _TO_TF:
        return
    caller = frame.f_back
    what = _TF_READS.get(caller.f_code) if caller is not None else None
    if what is None:
        return
    if what.startswith("control.tf"):
        advice = ("use control.tf(sys.mean()) for the mean system's "
                  "transfer function, knowingly")
    else:
        advice = ("convert G to state space first (control.ss(G)): "
                  "python-control's algebra of a StateSpace with the jump "
                  "system keeps its modes, mode by mode; or use "
                  "control_ncs.interconnect")
    raise ControlArgument(
        f"{what}: python-control would turn the jump system '{J.name}' into "
        f"the transfer function of its mean system and lose its random "
        f"modes; {advice}")


def warn_step_response(J: Any, frame: FrameType | None) -> None:
    """Warn when :func:`control.step_response` reads a periodic system."""
    if J.period > 1 and frame is not None and frame.f_code is _STEP:
        warnings.warn(
            f"control.step_response of a period-{J.period} jump system "
            f"steps each input of its lifted face separately (a pulse train "
            f"at one phase, sampled once per period, N·dt): it is not the "
            f"step response at the base rate; control_ncs.step_response(sys) "
            f"is (exact E z for any period, with sample paths)",
            UserWarning, stacklevel=4)


def caller(depth: int = 2) -> FrameType | None:
    """The frame ``depth`` levels above the caller of this function."""
    try:
        return _sys._getframe(depth)
    except ValueError:
        return None
