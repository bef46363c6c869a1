"""Interconnections of a jump system with deterministic LTI systems
(:ref:`theory-interconnection`).

:func:`jump_feedback` closes a loop around a
:class:`~control_ncs.jump.JumpStateSpace` with an ordinary discrete-time LTI
system and keeps the result a jump system (for simulation, mean-square
stability, stochastic passivity). :func:`lift_lti` lifts an LTI system over
``N`` steps, so that it can be interconnected with the lifted face of a
periodic jump system.

What python-control's own functions say about a JumpStateSpace
----------------------------------------------------------------
A ``JumpStateSpace`` *is* a :class:`control.StateSpace`, and its matrices
are its exact **mean system** (:ref:`theory-moments`): for deterministic inputs
``w``, ``E z`` obeys them exactly. For a period ``N > 1`` the face is that
periodic mean lifted over one period (sampling time ``N·dt``, inputs
``w[0], …, w[N-1]`` and outputs stacked time-major, named ``'w[0][k]'``).
Every python-control function therefore makes an exact statement, but only
about the mean:

* ``control.step_response`` / ``impulse_response`` / ``forced_response``
  (and ``control.step_info``): ``E z`` for that deterministic input. With
  ``N > 1`` they see the lifted system, where a step of the lifted input
  ``w[j][k]`` is a pulse train at phase ``k``; the per-step step response,
  with its spread, is :func:`control_ncs.simulate.step_response`.
* ``control.bode_plot`` / ``frequency_response``: the steady-state ``E z``
  for sinusoidal deterministic ``w`` (for ``N > 1``, of the lifted system up
  to the Nyquist frequency of ``N·dt``). Nothing about the spread around the
  mean.
* ``control.nyquist_plot``, ``poles``, ``stability_margins``: stability *in
  the mean* of a loop with a deterministic LTI system. Mean-square
  stability (:func:`control_ncs.ms_radius` < 1, :ref:`theory-mss`) is stronger:
  the mean can converge while ``E‖ξ‖²`` diverges, never the other way round.
* ``control.feedback(sys, G)``, ``series``, ``parallel``, ``append``, the
  operators ``sys * G``, ``G * sys``, ``sys + G``, ``sys - G``, ``-sys``
  and indexing ``sys[i, j]`` with a deterministic LTI ``G`` (StateSpace,
  TransferFunction, scalar or array) of the same base step ``dt``: python-
  control dispatches them to the jump system's methods, which return a
  ``JumpStateSpace`` built mode by mode (each mode is python-control's
  operation on that mode; the probabilities are kept). This is exact for
  any ``N`` (``G`` runs at the base rate, indices refer to the per-step
  signals) and equals :func:`jump_feedback`; an algebraic loop through
  ``G``'s feedthrough is closed inside each mode. Two jump systems together
  are refused: their modes are independent only if you say so.
  Where python-control does not dispatch to the jump system -- a
  ``TransferFunction`` on the left (``H * sys``, ``H + sys``),
  ``control.feedback(G, sys)`` and ``control.append(G, sys)`` with ``G``
  first, and ``control.interconnect`` -- it reads the StateSpace face and
  returns an ordinary system of the **mean**. Put the jump system first,
  convert ``H`` with ``control.ss``, or use :func:`interconnect`, which
  mirrors ``control.interconnect`` mode by mode.
* ``control.ispassive(sys)``: passivity of the mean system, i.e. for
  deterministic inputs only. It is **not** stochastic passivity
  (:ref:`theory-passivity`), which covers inputs that depend on the past -- as
  they do in any feedback loop -- and is what control_ncs certifies. Stochastic
  passivity implies that the mean system is passive, not conversely; with
  losses the certified index is lower.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from scipy.linalg import block_diag
import control as ct
from control.exception import ControlArgument

from ._checks import discrete_dt, no_extra_kwargs, real_array
from ._lifting import check_lifted_size, lift, lifted_names
from .jump import JumpStateSpace, as_jump
from ._lti import deterministic_lti, lti_operand

__all__ = ["jump_feedback", "lift_lti", "interconnect"]


def _deterministic(other: Any, rows: int, cols: int) -> ct.StateSpace:
    """``other`` as a StateSpace with ``rows`` outputs and ``cols`` inputs."""
    return lti_operand(other, "other", gain=(rows, cols))


def _common_dt(step: float | bool, dt: Any) -> float | bool:
    if dt is None or dt is True:
        return step
    other = discrete_dt(dt, "other.dt")
    if step is True:
        return other
    if not np.isclose(step, other, rtol=1e-12, atol=0):
        raise ValueError(f"other.dt: sampling periods differ: the jump system "
                         f"steps with dt = {step}, other has dt = {other} "
                         f"(incompatible timebases)")
    return step


def jump_feedback(sys: Any, other: Any = 1, sign: float = -1, *,
                  name: str | None = None, **kwargs: Any) -> JumpStateSpace:
    """Feedback loop of a jump system with a deterministic LTI system.

    Like :func:`control.feedback` (``sys`` in the forward path, ``other`` in
    the feedback path, ``u_sys = w + sign · y_other``, ``u_other = z``), but
    the result stays a jump system: each mode ``i`` of each phase ``k`` of the
    result is :func:`control.feedback` of mode ``(k, i)`` of ``sys`` with
    ``other``, with the same probabilities. ``other`` is time-invariant, so
    any period ``N`` works. The state is ``[ξ; x_other]``. Negative
    feedback by default, as :func:`control.feedback` (see :ref:`guide-sign`).

    ``control.feedback(sys, other, sign)`` returns the same jump system
    (python-control dispatches to :meth:`JumpStateSpace.feedback`). Its
    StateSpace face is the exact mean of the loop (:ref:`theory-moments`). It
    equals the feedback of the means,
    ``control.feedback(sys.mean(), other, sign)`` (for ``N > 1``: with
    ``lift_lti(other, N)``) when ``other`` is strictly proper, or when ``D``
    and one of ``B``, ``C`` of ``sys`` do not depend on the mode (every
    static-gain loop of :func:`control_ncs.feedback`); see the module notes.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
        The forward path; a deterministic system becomes a one-mode jump
        system.
    other : StateSpace, TransferFunction, scalar or 2-D array, optional
        Deterministic discrete-time system with the same ``dt`` (or an
        unspecified one), or a static gain; default 1 (unity feedback).
    sign : float, optional
        Feedback sign (default -1, negative feedback).
    name : str, optional
        Name of the result (default: a generated one).
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Returns
    -------
    JumpStateSpace
        Same inputs and outputs as ``sys``; ``info`` adds a ``'feedback'``
        entry (other's name, matrices and ``dt``, and ``sign``).

    Raises
    ------
    ValueError
        If the loop is not well posed in some mode (``I - sign·D_other·D_i``
        singular), ``other`` is continuous-time, or the sampling periods
        differ.
    ControlArgument
        If ``other`` is a jump or networked system.
    ControlDimension
        If the dimensions do not match.

    Examples
    --------
    A lossy loop in series with an integrator-like filter:

    >>> from control_ncs.connect import jump_feedback
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
    >>> G = ct.ss([[0.5]], [[1.0]], [[0.2]], [[0.0]], True)
    >>> loop = ncs.jump_feedback(sys, G)
    >>> loop.nmodes, loop.nstates
    (2, 2)
    >>> bool(np.allclose(loop.A, ct.feedback(sys.mean(), G).A))
    True
    >>> type(ct.feedback(sys, G)).__name__          # python-control's call
    'JumpStateSpace'
    """
    no_extra_kwargs("jump_feedback", kwargs)
    J = as_jump(sys, "sys")
    M = J.modes
    m, p = M.B.shape[-1], M.C.shape[-2]
    G = _deterministic(other, m, p)
    dt = _common_dt(J.dt_step, G.dt)
    s = float(real_array(sign, "sign", ndim=0))
    A2, B2, C2, D2 = (np.asarray(X, float) for X in (G.A, G.B, G.C, G.D))
    n2 = A2.shape[0]

    # control.StateSpace.feedback, written for every (phase, mode) at once.
    F = np.eye(m) - s * np.einsum("ij,kmjl->kmil", D2, M.D)
    rank = np.linalg.matrix_rank(F)
    bad = np.argwhere(rank != m)
    if bad.size:
        k, i = bad[0]
        raise ValueError(
            f"jump_feedback: the loop is not well posed in mode {i} at phase "
            f"{k}: I - sign·D_other·D_mode is singular, so the algebraic loop "
            f"has no unique solution")
    rhs = np.broadcast_to(np.concatenate([D2, C2], axis=1),
                          F.shape[:2] + (m, p + n2))
    E_D2_C2 = np.linalg.solve(F, rhs)
    E_D2, E_C2 = E_D2_C2[..., :p], E_D2_C2[..., p:]
    T1 = np.eye(p) + s * M.D @ E_D2
    T2 = np.eye(m) + s * E_D2 @ M.D
    A = np.concatenate([
        np.concatenate([M.A + s * M.B @ E_D2 @ M.C, s * M.B @ E_C2], axis=-1),
        np.concatenate([B2 @ T1 @ M.C, A2 + s * B2 @ M.D @ E_C2], axis=-1)],
        axis=-2)
    B = np.concatenate([M.B @ T2, B2 @ M.D @ T2], axis=-2)
    C = np.concatenate([T1 @ M.C, s * M.D @ E_C2], axis=-1)
    D = M.D @ T2

    states = list(J.jump_states) + [f"{G.name}.{x}" for x in G.state_labels]
    info = dict(J.info, feedback=dict(
        other=G.name, sign=s, dt=G.dt, matrices=(A2, B2, C2, D2)))
    law, transition = J.mode_law()   # the chain is kept (theory: Markov losses)
    return JumpStateSpace(A, B, C, D, law, dt, transition=transition,
                          nominal=J.nominal_mode, name=name,
                          inputs=J.jump_inputs, outputs=J.jump_outputs,
                          states=states, info=info)


def lift_lti(sys: Any, period: int, **kwargs: Any) -> ct.StateSpace:
    """A discrete-time LTI system lifted over ``period`` steps.

    The lifted system maps ``[u[jN]; …; u[jN+N-1]]`` to
    ``[y[jN]; …; y[jN+N-1]]`` (time-major, as the face of a
    :class:`~control_ncs.jump.JumpStateSpace` with period ``N``) with
    sampling time ``N·dt``; signals are named ``'u[0][k]'``. Use it to
    interconnect python-control systems with the lifted mean face, e.g.
    ``control.feedback(loop.mean(), lift_lti(G, loop.period))`` (for the
    jump system itself, interconnect ``G`` at the base rate:
    ``control.feedback(loop, G)``).

    Parameters
    ----------
    sys : StateSpace or TransferFunction
        Discrete-time (``dt`` True or > 0).
    period : int
        ``N >= 1``.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Returns
    -------
    control.StateSpace
        The lifted system, named ``'<sys.name>$lifted'``.

    Raises
    ------
    ControlArgument
        If ``sys`` is not a deterministic LTI system.
    ValueError
        If ``sys`` is continuous-time, ``period`` is not an int >= 1, or
        the lifted system would be too large (``MAX_LIFTED_ENTRIES``).

    Examples
    --------
    >>> from control_ncs.connect import lift_lti
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1)
    >>> GL = ncs.lift_lti(G, 2)
    >>> GL.A.tolist(), GL.dt, GL.input_labels
    ([[0.25]], 0.2, ['u[0][0]', 'u[0][1]'])
    """
    no_extra_kwargs("lift_lti", kwargs)
    G = lti_operand(sys, "sys")
    dt = discrete_dt(G.dt, "sys.dt")
    if isinstance(period, (bool, np.bool_)) or not isinstance(
            period, (int, np.integer)) or period < 1:
        raise ValueError(f"period: expected an int >= 1, got {period!r}")
    N = int(period)
    check_lifted_size(G.nstates, G.ninputs, G.noutputs, N, "period")
    mats = lift(*(np.repeat(np.asarray(X, float)[None], N, axis=0)
                  for X in (G.A, G.B, G.C, G.D)))
    return ct.StateSpace(*mats, True if dt is True else dt * N,
                         inputs=lifted_names(G.input_labels, N),
                         outputs=lifted_names(G.output_labels, N),
                         states=list(G.state_labels), name=f"{G.name}$lifted")


def _closed(systems: list[ct.StateSpace], maps: tuple, where: tuple
            ) -> tuple[np.ndarray, ...]:
    """The interconnection of ``systems`` (python-control's maps
    ``u = M y + N r``, ``z = O [y; u]``), algebraic loops included:
    ``y = C x + D u`` gives ``(I - D M) y = C x + D N r``."""
    M, N, O = maps
    A = block_diag(*[np.asarray(S.A, float) for S in systems])
    B = block_diag(*[np.asarray(S.B, float) for S in systems])
    C = block_diag(*[np.asarray(S.C, float) for S in systems])
    D = block_diag(*[np.asarray(S.D, float) for S in systems])
    L = np.eye(D.shape[0]) - D @ M
    if np.linalg.cond(L) > 1e12:
        raise ValueError(f"syslist: the algebraic loop is singular (I - D·M "
                         f"not invertible) at phase {where[0]}, mode "
                         f"{where[1]}: the interconnection is not well "
                         f"posed")
    Yx = np.linalg.solve(L, C)             # y = Yx x + Yr r
    Yr = np.linalg.solve(L, D @ N)
    Ux, Ur = M @ Yx, M @ Yr + N            # u = Ux x + Ur r
    Ox, Or = O[:, :D.shape[0]], O[:, D.shape[0]:]
    return (A + B @ Ux, B @ Ur, Ox @ Yx + Or @ Ux, Ox @ Yr + Or @ Ur)


def interconnect(syslist: Sequence[Any], connections: Any = None,
                 inplist: Any = None, outlist: Any = None,
                 **kwargs: Any) -> JumpStateSpace:
    """Interconnect a jump system with LTI systems, by signal names.

    Mirrors :func:`control.interconnect` (same arguments, same signal-name
    conventions, e.g. ``'CL.z[0]'`` or ``'z[0]'`` with
    ``connections=None``), but keeps the randomness: for every phase ``k``
    and mode ``i``, python-control interconnects mode ``(k, i)`` of the
    jump system (a :class:`control.StateSpace` at the base step with the
    jump system's name and per-step signal names ``jump_inputs``,
    ``jump_outputs``) with the other systems; the result keeps the modes,
    their probabilities and the loss-free mode. This is exact
    (:ref:`theory-interconnection`, :ref:`theory-jump-system`): the other
    systems are deterministic and have no modes, and an algebraic loop is
    closed inside each mode, as in :func:`jump_feedback`.

    ``control.interconnect`` itself accepts a JumpStateSpace too, but sees
    only its StateSpace face: it returns the interconnection of the mean
    system, which is the mean of this function's result when no algebraic
    loop runs through two mode-dependent matrices.

    Parameters
    ----------
    syslist : sequence
        Exactly one random :class:`~control_ncs.jump.JumpStateSpace` and
        any number of deterministic discrete-time
        :class:`control.StateSpace` or :class:`control.TransferFunction`
        systems (or jump systems whose live modes coincide at every phase)
        with the same base step ``dt`` (or an unspecified one),
        time-invariant at that rate for any period ``N``.
    connections, inplist, outlist : optional
        As in :func:`control.interconnect`.
    **kwargs
        ``name`` of the result, and any keyword of
        :func:`control.interconnect` (``inputs``, ``outputs``, ``states``,
        ``check_unused``, ``add_unused``, ...); python-control raises
        ``TypeError`` for an unknown one.

    Returns
    -------
    JumpStateSpace
        Signals as python-control names them for the interconnection;
        ``info`` adds an ``'interconnect'`` entry (the other systems' names).
        A jump system has at least one input and one output: an
        interconnection without external inputs (``inplist=[]``, an
        autonomous loop) gets one input named ``'unused'`` that enters
        nowhere, one without outputs an output ``'unused'`` that is zero.

    Raises
    ------
    ControlArgument
        If ``syslist`` holds no jump system, two of them (their modes are
        independent only if you say so: build one jump system over the joint
        modes with :func:`control_ncs.jss`), a networked plant, or a
        nonlinear system.
    ValueError
        If a system is continuous-time or its sampling period differs.

    Examples
    --------
    A lossy loop whose input is shaped by a first-order disturbance model:

    >>> from control_ncs.connect import interconnect
    >>> CL = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7],
    ...          name="CL", inputs="w", outputs="z")
    >>> W = ct.ss([[0.8]], [[1.0]], [[0.2]], [[0.0]], True, name="W",
    ...           inputs="d", outputs="w")
    >>> sys = ncs.interconnect([W, CL], inplist="d", outlist="z", inputs="d",
    ...                    outputs="z", name="shaped")
    >>> sys.nmodes, sys.nstates, sys.input_labels, sys.output_labels
    (2, 2, ['d'], ['z'])
    """
    J, others = _jump_and_others(syslist)
    name = kwargs.pop("name", None)

    def blocks(k: int, i: int) -> list[ct.StateSpace]:
        mode_sys = J.mode_system(k, i)
        return [mode_sys if s is None else s for s in others]

    maps, first = _signal_maps(blocks(0, 0), connections, inplist, outlist,
                               kwargs)
    done = [[_closed(blocks(k, i), maps, (k, i)) for i in range(J.nmodes)]
            for k in range(J.period)]
    A, B, C, D = (np.array([[m[j] for m in row] for row in done], dtype=float)
                  for j in range(4))
    inputs, outputs = list(first.input_labels), list(first.output_labels)
    if maps[1].shape[1] == 0:     # no external input: one that enters nowhere
        B, D, inputs = _zero_line(B, -1), _zero_line(D, -1), [UNUSED]
    if maps[2].shape[0] == 0:     # no output: one that sees nothing
        C, D, outputs = _zero_line(C, -2), _zero_line(D, -2), [UNUSED]
    dt = J.dt_step if first.dt is True else first.dt
    info = dict(J.info, interconnect=[s.name for s in others if s is not None])
    law, transition = J.mode_law()   # the chain is kept (theory: Markov losses)
    return JumpStateSpace(A, B, C, D, law, dt, transition=transition,
                          nominal=J.nominal_mode, name=name,
                          inputs=inputs, outputs=outputs,
                          states=list(first.state_labels), info=info)


#: The name of the input (output) that an interconnection without external
#: inputs (outputs) gets: a jump system has at least one of each.
UNUSED = "unused"


def _zero_line(X: np.ndarray, axis: int) -> np.ndarray:
    """``X`` with one more column (``axis=-1``) or row (``-2``) of zeros."""
    shape = list(X.shape)
    shape[axis] = 1
    return np.concatenate([X, np.zeros(shape)], axis=axis)


def _jump_and_others(syslist: Any) -> tuple[JumpStateSpace, list]:
    """The one random jump system of ``syslist`` and the others as
    deterministic StateSpaces at its step (None in the jump system's
    place). A deterministic jump system is one of the others."""
    if isinstance(syslist, (ct.InputOutputSystem, str)) or not isinstance(
            syslist, (list, tuple)):
        raise ControlArgument(f"syslist: expected a list of systems, got "
                              f"{type(syslist).__name__}")
    jumps = [s for s in syslist if isinstance(s, JumpStateSpace)]
    if not jumps:
        raise ControlArgument("syslist: no JumpStateSpace; for deterministic "
                              "systems only, use control.interconnect")
    random = [s for s in jumps if deterministic_lti(s) is None]
    if len(random) > 1:
        raise ControlArgument(
            f"syslist: {len(random)} jump systems "
            f"({', '.join(j.name for j in random)}). Their modes are "
            f"independent only if you say so, and the interconnection needs "
            f"the joint law of the mode sequences: build one jump system "
            f"over the joint modes with jss() (products of the "
            f"probabilities if independent)")
    J = (random or jumps)[0]
    others: list[ct.StateSpace | None] = []
    for s in syslist:
        if s is J:
            others.append(None)
            continue
        s = lti_operand(s, f"syslist: {s.name}" if isinstance(
            s, ct.InputOutputSystem) else "syslist", dt=J.dt_step,
            period=J.period)
        others.append(s)
    return J, others


def _signal_maps(systems: list[ct.StateSpace], connections: Any,
                 inplist: Any, outlist: Any, kwargs: dict
                 ) -> tuple[tuple[np.ndarray, ...], Any]:
    """python-control's connection, input and output maps of ``systems``
    (and its interconnection, for the signal names).

    python-control parses the signal names; its own linearisation iterates
    to a fixed point and stops at an algebraic loop, so the maps are taken
    from the systems with ``D = 0`` (each mode is closed exactly by
    :func:`_closed`). It also fails on an interconnection with no external
    input and some output; then the maps are read with one input (any: the
    connection and output maps do not depend on it) and the input map is
    empty.
    """
    static_free = [
        ct.ss(S.A, S.B, S.C, np.zeros_like(S.D), S.dt, name=S.name,
              inputs=list(S.input_labels), outputs=list(S.output_labels),
              states=list(S.state_labels)) for S in systems]
    no_input = (inplist is None and kwargs.get("inputs") is None) or (
        isinstance(inplist, (list, tuple)) and len(inplist) == 0)
    if no_input and not (isinstance(outlist, (list, tuple))
                         and len(outlist) == 0):
        probe = next(f"{S.name}.{S.input_labels[0]}" for S in static_free
                     if S.ninputs)
        first = ct.interconnect(static_free, connections, [probe], outlist,
                                **{k: v for k, v in kwargs.items()
                                   if k != "inputs"})
        input_map = np.zeros((first.input_map.shape[0], 0))
    else:
        first = ct.interconnect(static_free, connections, inplist, outlist,
                                **kwargs)
        input_map = np.asarray(first.input_map, float)
    return (np.asarray(first.connect_map, float), input_map,
            np.asarray(first.output_map, float)), first
