"""The closed-loop jump system: :class:`JumpStateSpace` and :func:`jss`.

A periodic jump linear system ``ξ⁺ = A_ki ξ + B_ki w``,
``z = C_ki ξ + D_ki w`` with phase ``k = t mod N`` and mode ``i`` drawn
i.i.d. or by a Markov chain (:ref:`theory-jump-system`,
:ref:`theory-markov`). It *is* a :class:`control.StateSpace`: its own
``A, B, C, D`` are the exact mean (first-moment) system of
:ref:`theory-moments`, lifted over one period when ``N > 1``, so
python-control's algebra and plots apply to ``E z``; the operations with a
deterministic LTI system are written mode by mode here and keep the
randomness. Analysis and simulation consume it. The law of the modes lives
in :mod:`control_ncs.modes`, the lifting in ``_lifting``, the open loop
that synthesis designs in :mod:`control_ncs.openloop`.
"""

from __future__ import annotations

import inspect
import numbers
from typing import Any

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._checks import discrete_dt, no_extra_kwargs, real_array
from ._lifting import check_lifted_size, lift, lifted_names
from ._lti import lti_operand
from .modes import (Modes, apply_groups, chain_law, check_probabilities,
                    markov_mean, merge_groups)
from .plant import NetworkedStateSpace

__all__ = ["JumpStateSpace", "jss"]

#: python-control's norm, recognised by its code object (not patched).
_SYSTEM_NORM_CODE = ct.system_norm.__code__


def _phase_mode_array(value: Any, name: str, N: int, M: int, shape: tuple
                      ) -> np.ndarray:
    """Broadcast a matrix, a per-mode stack or a per-phase-per-mode stack."""
    arr = real_array(value, name, ndim=(0, 1, 2, 3, 4))
    if arr.ndim < 2:
        arr = arr.reshape(1, 1) if arr.size == 1 else arr
    if arr.ndim < 2:
        raise ControlDimension(f"{name}: expected a matrix of shape {shape}, "
                               f"a stack (M, ...) or (N, M, ...), got {arr.shape}")
    if arr.ndim == 3:
        arr = arr[None]
    try:
        return np.array(np.broadcast_to(arr, (N, M) + shape))
    except ValueError:
        raise ControlDimension(
            f"{name}: expected shape {shape} per mode, for N={N} phases and "
            f"M={M} modes (a matrix, an (M, ...) or an (N, M, ...) stack), "
            f"got {arr.shape}") from None



class JumpStateSpace(ct.StateSpace):
    """Periodic jump linear system; its StateSpace face is its mean.

    ``ξ[t+1] = A[k,i] ξ[t] + B[k,i] w[t]``, ``z[t] = C[k,i] ξ[t] + D[k,i] w[t]``
    with ``k = t mod N`` and mode ``i`` drawn independently at every step
    with probability ``probabilities[k, i]`` (:ref:`theory-jump-system`), or,
    given a ``transition``, a Markov chain
    ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` (:ref:`theory-markov`). For
    Markov modes the StateSpace face is the exact mean system of order ``M·n``
    (state ``E[ξ 1{σ = i}]`` per mode ``i``) under the periodic stationary
    chain; a transition with equal rows is the i.i.d. system.

    The :class:`control.StateSpace` matrices ``self.A, self.B, self.C,
    self.D`` are the *mean system* of :ref:`theory-moments`: ``E ξ`` and
    ``E z`` obey them exactly for deterministic inputs, because the mode at
    time ``t`` is independent of ``ξ[t]``. For ``N = 1`` that system is
    ``(Σ p_i A_i, Σ p_i B_i, Σ p_i C_i, Σ p_i D_i)``; for ``N > 1`` it is that
    periodic system lifted over one period (:func:`lift`), with sampling time
    ``N·dt``, inputs ``w[0], …, w[N-1]`` and outputs ``z[0], …, z[N-1]``
    stacked time-major (all channels of phase 0 first) and named
    ``'<signal>[k]'`` for phase ``k`` (e.g. ``'w[0][1]'``: channel ``w[0]``
    at phase 1). Hence ``control.step_response`` and ``control.bode_plot``
    of this object are exact statements about ``E z``; for ``N > 1`` they
    are statements per period (a step of the lifted input ``w[j][k]`` is a
    pulse train at phase ``k``), and ``control.forced_response`` needs time
    points spaced by ``N·dt``. For ``E z`` and its spread at the base rate,
    for any ``N``, use :func:`control_ncs.forced_response`,
    :func:`control_ncs.step_response` and :func:`control_ncs.moments`; for
    a readable frequency plot of one phase, :meth:`phase`.

    python-control's algebra keeps the randomness: ``control.feedback``,
    ``series``, ``parallel``, ``append``, the operators ``*``, ``+``,
    ``-`` and indexing, with a deterministic LTI system ``G`` (StateSpace,
    TransferFunction, scalar or array, at the base step), return a
    ``JumpStateSpace`` built mode by mode (python-control's operation on
    each mode, probabilities kept): exact, and equal to
    :func:`control_ncs.jump_feedback` for feedback. Indices refer to the
    per-step signals for any ``N``. Two jump systems together raise
    ``ControlArgument`` (their modes are independent only if you say so).
    Calls python-control does not dispatch to this object (a
    ``TransferFunction`` on the left, ``control.feedback(G, sys)``,
    ``control.append(G, sys)``, ``control.interconnect``) read the face and
    return an ordinary system built from the mean (the exact mean of the
    interconnection only if no algebraic loop multiplies two mode-dependent
    matrices); :func:`control_ncs.interconnect` is the exact
    interconnection by signal names. ``==`` and ``hash`` are by identity,
    as for python-control's systems; :meth:`equals` compares values.

    Build one with :func:`jss` or :func:`control_ncs.feedback`. Its arrays
    (the modes and the mean face) are read-only, so the face stays the mean
    of the modes. A period whose lifted face would exceed
    ``MAX_LIFTED_ENTRIES`` entries is refused.

    Parameters
    ----------
    A, B, C, D : array_like
        Per-mode matrices, shape ``(N, M, ., .)``; an ``(M, ., .)`` stack
        means ``N = 1``; a single matrix is shared by all modes.
    probabilities : array_like, shape (M,) or (N, M), optional
        Mode probabilities per phase; each row sums to 1. With a
        ``transition``: the law of the mode at time 0, shape ``(M,)``
        (default: the periodic stationary law).
    dt : True or float > 0
        Sampling period of one step (discrete time only).
    transition : array_like, shape (M, M) or (N, M, M), optional
        Markov modes: ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` at phase
        ``k``; rows non-negative, summing to 1.
    nominal : array_like of int, shape (N,), optional
        Index of the loss-free mode at each phase, for :meth:`nominal`.
    name, inputs, outputs, states : optional
        As in :class:`control.StateSpace`; ``inputs``/``outputs`` name the
        per-step signals ``w`` and ``z``, not the lifted ones.
    info : dict, optional
        What built the system, kept as the ``info`` attribute.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Attributes
    ----------
    modes : Modes
        The per-phase, per-mode matrices and probabilities.
    period : int
        ``N``.
    jump_inputs, jump_outputs, jump_states : list of str
        Names of ``w``, ``z`` and ``ξ`` at one step.
    info : dict
        What built the system (controller kind, actuator strategy, plant,
        gains), for reference; analysis never reads it.

    Examples
    --------
    A scalar loop that loses its control with probability 0.2; the
    StateSpace face is the mean ``0.2 · 2 + 0.8 · 0``:

    >>> sys = ncs.JumpStateSpace([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
    ...                      [0.2, 0.8], nominal=[1])
    >>> sys.period, sys.nmodes, float(sys.A[0, 0])
    (1, 2, 0.4)
    >>> sys.nominal().A.tolist()
    [[0.0]]
    """

    def __init__(self, A: Any, B: Any, C: Any, D: Any,
                 probabilities: Any = None, dt: Any = True, *,
                 transition: Any = None, nominal: Any = None,
                 name: str | None = None, inputs: Any = None,
                 outputs: Any = None, states: Any = None,
                 info: dict | None = None, **kwargs: Any):
        no_extra_kwargs("JumpStateSpace", kwargs)
        a = real_array(A, "A", ndim=(2, 3, 4))
        if transition is None:
            if probabilities is None:
                raise ValueError("probabilities: give the mode probabilities, "
                                 "or a transition matrix (Markov modes)")
            p, T, init = check_probabilities(probabilities), None, None
        else:
            nt = np.ndim(transition)
            N0 = max(a.shape[0] if a.ndim == 4 else 1,
                     np.shape(transition)[0] if nt == 3 else 1)
            p, T, init = chain_law(transition, probabilities, N0,
                                a.shape[-3] if a.ndim >= 3 else None)
        N, M = p.shape
        n = a.shape[-1]
        if a.shape[-2] != n:
            raise ControlDimension(f"A: each mode matrix must be square, got "
                                   f"shape {a.shape}")
        A_ = _phase_mode_array(a, "A", N, M, (n, n))
        b = real_array(B, "B", ndim=(2, 3, 4))
        m = b.shape[-1]
        B_ = _phase_mode_array(b, "B", N, M, (n, m))
        c = real_array(C, "C", ndim=(2, 3, 4))
        q = c.shape[-2]
        for arg, count, what in (("B", m, "input w (a column of B)"),
                                 ("C", q, "output z (a row of C)")):
            if count == 0:
                raise ControlDimension(
                    f"{arg}: a jump system needs at least one {what}; for "
                    f"a system without one, pass a zero column or row")
        check_lifted_size(n, m, q, N, "probabilities")
        C_ = _phase_mode_array(c, "C", N, M, (q, n))
        D_ = _phase_mode_array(D, "D", N, M, (q, m))
        for X in (A_, B_, C_, D_, p, T, init):
            if X is not None:
                X.setflags(write=False)
        self.modes = Modes(A_, B_, C_, D_, p, T, init)
        self.dt_step = discrete_dt(dt)
        self.nominal_mode = None if nominal is None else self._check_nominal(
            nominal, N, M)
        self.info = dict(info or {})
        self.jump_inputs = _names(inputs, m, "w", "inputs")
        self.jump_outputs = _names(outputs, q, "z", "outputs")
        self.jump_states = _names(states, n, "x", "states")

        if T is None:
            Abar, Bbar, Cbar, Dbar = self.modes.mean()
            face_states = self.jump_states
        else:
            check_lifted_size(M * n, m, q, N, "transition")
            Abar, Bbar, Cbar, Dbar = markov_mean(self.modes)
            face_states = [f"{s}#{i}" for i in range(M)
                           for s in self.jump_states]
        if N == 1:
            mats = (Abar[0], Bbar[0], Cbar[0], Dbar[0])
            lifted_dt = self.dt_step
        else:
            mats = lift(Abar, Bbar, Cbar, Dbar)
            lifted_dt = True if self.dt_step is True else self.dt_step * N
        super().__init__(*mats, lifted_dt, name=name,
                         inputs=lifted_names(self.jump_inputs, N),
                         outputs=lifted_names(self.jump_outputs, N),
                         states=face_states)
        # the face is the exact mean of self.modes only while neither changes
        for X in (self.A, self.B, self.C, self.D):
            X.setflags(write=False)

    @staticmethod
    def _check_nominal(nominal: Any, N: int, M: int) -> np.ndarray:
        idx = np.atleast_1d(np.asarray(nominal))
        if idx.shape != (N,) or not np.issubdtype(idx.dtype, np.integer) \
                or idx.min() < 0 or idx.max() >= M:
            raise ValueError(f"nominal: expected {N} mode indices in 0..{M - 1}, "
                             f"got {nominal!r}")
        return idx.astype(int)

    # -- accessors -----------------------------------------------------------
    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.modes.period

    @property
    def nmodes(self) -> int:
        """Number of modes ``M`` per phase."""
        return self.modes.count

    def mode(self, k: int, i: int) -> tuple[np.ndarray, ...]:
        """Matrices ``(A, B, C, D)`` of mode ``i`` at phase ``k mod N``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.
        i : int
            Mode index, ``0 <= i < nmodes``.

        Returns
        -------
        A, B, C, D : ndarray
            Read-only views of the mode's matrices.

        Examples
        --------
        >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mode(0, 1)[0].tolist()
        [[0.9]]
        """
        k %= self.period
        return tuple(M[k, i] for M in (self.modes.A, self.modes.B,
                                       self.modes.C, self.modes.D))

    def mean_phase(self, k: int) -> tuple[np.ndarray, ...]:
        """Mean matrices ``(Σ p A, …, Σ p D)`` at phase ``k mod N``.

        For Markov modes ``p`` are the stationary marginals: the average
        matrices of the phase, not the mean dynamics (the face is).

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        A, B, C, D : ndarray
            The probability-weighted means over the modes of that phase.

        Examples
        --------
        >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mean_phase(0)[0].tolist()
        [[0.78]]
        """
        return tuple(M[k % self.period] for M in self.modes.mean())

    def deterministic(self) -> tuple[np.ndarray, ...] | None:
        """Per-phase ``(A, B, C, D)`` of a deterministic system, or None.

        The system is deterministic when, at every phase, all modes of
        positive probability have identical matrices (whether or not they
        were merged); then each step applies one known linear map and the
        mean system is the system itself.

        Returns
        -------
        tuple of ndarray or None
            ``(A, B, C, D)`` of shapes ``(N, n, n)``, ``(N, n, m)``,
            ``(N, p, n)``, ``(N, p, m)`` (copies), or None if some phase
            has two live modes that differ.

        Examples
        --------
        Two identical modes make a deterministic system; two different ones
        do not:

        >>> ncs.jss([[[0.5]], [[0.5]]], [[1.0]], [[1.0]], [[0.0]],
        ...     [0.3, 0.7]).deterministic()[0].tolist()
        [[[0.5]]]
        >>> ncs.jss([[[0.5]], [[0.4]]], [[1.0]], [[1.0]], [[0.0]],
        ...     [0.3, 0.7]).deterministic() is None
        True
        """
        m = self.modes
        live = m.probabilities > 0
        first = np.argmax(live, axis=1)  # a live mode of each phase
        k = np.arange(self.period)
        mats = tuple(X[k, first] for X in (m.A, m.B, m.C, m.D))
        for X, ref in zip((m.A, m.B, m.C, m.D), mats):
            same = np.all(X == ref[:, None], axis=(2, 3))
            if not np.all(same | ~live):
                return None
        return mats

    def _generic_name_check(self) -> bool:
        """python-control's name check, which its ``ss(sys)`` copy calls
        first; refuses when :func:`control.norm` is the caller.

        ``ct.norm`` copies its argument into a plain ``StateSpace`` (this
        system's mean face) and would return the *mean* system's norm, which
        is not the jump system's (:ref:`theory-performance`): the one place
        where python-control would compute a silently different figure. The
        copy is refused there, naming :func:`control_ncs.norm`; every other
        ``ss(sys)`` copy keeps the mean face, as documented.
        """
        frame = inspect.currentframe()
        for _ in range(3):                  # this method, ss(), its caller
            frame = frame.f_back if frame is not None else None
            if frame is not None and frame.f_code is _SYSTEM_NORM_CODE \
                    and self.deterministic() is None:
                raise ControlArgument(
                    "control.norm(sys) would compute the norm of the mean "
                    "system, not of this jump system (its modes are "
                    "random): use control_ncs.norm(sys, p) for the exact H2 "
                    "norm or the certified l2 gain, or control.norm("
                    "sys.mean(), p) for the mean system's")
        return bool(super()._generic_name_check())

    def mean(self) -> ct.StateSpace:
        """The mean system as a plain :class:`control.StateSpace` (a copy).

        Returns
        -------
        control.StateSpace
            The face ``(self.A, self.B, self.C, self.D)`` with its signal
            names, lifted if ``N > 1``.
        """
        return ct.StateSpace(self.A, self.B, self.C, self.D, self.dt,
                             inputs=self.input_labels, outputs=self.output_labels,
                             states=self.state_labels,
                             name=f"{self.name}$mean")

    def nominal(self) -> ct.StateSpace:
        """The loss-free system (every message arrives), lifted.

        Returns
        -------
        control.StateSpace
            The loss-free mode of every phase, as a deterministic system.

        Raises
        ------
        ValueError
            If the system was built without knowing its loss-free mode.
        """
        if self.nominal_mode is None:
            raise ValueError("nominal: this jump system does not know which "
                             "mode is loss-free; pass nominal= to jss()")
        k = np.arange(self.period)
        A, B, C, D = (M[k, self.nominal_mode] for M in (
            self.modes.A, self.modes.B, self.modes.C, self.modes.D))
        mats = (lift(A, B, C, D) if self.period > 1
                else (A[0], B[0], C[0], D[0]))
        return ct.StateSpace(*mats, self.dt, inputs=self.input_labels,
                             outputs=self.output_labels,
                             name=f"{self.name}$nominal")

    def merged(self) -> "JumpStateSpace":
        """The system with coinciding modes merged (probabilities added).

        Returns
        -------
        JumpStateSpace
            Equal in distribution to ``self``, with fewer modes where modes
            coincide; zero-probability modes are dropped (except the
            loss-free one).
        """
        if not self.modes.is_iid:
            # modes may share a row only if their futures coincide too (theory:
            # Markov losses); merging is not attempted for Markov modes
            return self
        keys = (self.modes.A, self.modes.B, self.modes.C, self.modes.D)
        groups, nominal = merge_groups(keys, self.modes.probabilities,
                                        self.nominal_mode)
        return self._rebuild(groups, nominal)

    def _rebuild(self, groups: list, nominal: np.ndarray | None
                 ) -> "JumpStateSpace":
        (A, B, C, D), p = apply_groups(
            (self.modes.A, self.modes.B, self.modes.C, self.modes.D),
            self.modes.probabilities, groups)
        return JumpStateSpace(A, B, C, D, p, self.dt_step, nominal=nominal,
                              name=self.name, inputs=self.jump_inputs,
                              outputs=self.jump_outputs, states=self.jump_states,
                              info=self.info)

    def phase(self, k: int) -> ct.StateSpace:
        """The mean system of phase ``k`` at the base rate (a StateSpace).

        For frequency plots of one phase when ``N > 1``: the lifted face
        (``N·dt``, stacked signals) is exact but its Bode plot has
        ``N·p × N·m`` panels. This is the phase-``k`` mean
        ``(Σ p A, Σ p B, Σ p C, Σ p D)`` frozen in time, with step ``dt``
        and the per-step signal names: the loop as it would be if every
        step were phase ``k``. For ``N = 1`` it is :meth:`mean` itself; for
        ``N > 1`` it is a view of one phase, not a statement about ``E z``
        of the periodic loop (the face and the package's base-rate
        responses, :func:`control_ncs.step_response` and
        :func:`control_ncs.forced_response`, are).

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        control.StateSpace
            Named ``'<name>$phase<k>'``.

        Examples
        --------
        >>> sys = ncs.jss([[[[0.5]]], [[[0.9]]]], [[1.0]], [[1.0]], [[0.0]],
        ...           [[1.0], [1.0]], dt=0.1)
        >>> sys.dt, sys.ninputs                   # the lifted face
        (0.2, 2)
        >>> one = sys.phase(1)
        >>> one.A.tolist(), one.dt, one.input_labels
        ([[0.9]], 0.1, ['w[0]'])
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ControlArgument(f"k: expected an int phase, got {k!r}")
        k = int(k) % self.period
        return ct.StateSpace(*self.mean_phase(k), self.dt_step,
                             inputs=self.jump_inputs, outputs=self.jump_outputs,
                             states=self.jump_states,
                             name=f"{self.name}$phase{k}")

    def update_names(self, **kwargs: Any) -> None:
        """Rename the system or its per-step signals (as python-control).

        Parameters
        ----------
        **kwargs
            ``name``, and ``inputs``, ``outputs``, ``states`` naming the
            per-step signals ``w``, ``z``, ``ξ`` (the lifted face's names
            follow); anything else raises ``TypeError``.
        """
        allowed = {"name", "inputs", "outputs", "states"}
        extra = set(kwargs) - allowed
        if extra:
            raise TypeError(f"update_names: unknown keyword(s) "
                            f"{sorted(extra)}; expected {sorted(allowed)}")
        n = self.modes.A.shape[-1]
        counts = dict(inputs=len(self.jump_inputs),
                      outputs=len(self.jump_outputs), states=n)
        prefix = dict(inputs="w", outputs="z", states="x")
        face: dict = {}
        for key in ("inputs", "outputs", "states"):
            if key in kwargs:
                names = _names(kwargs[key], counts[key], prefix[key], key)
                setattr(self, f"jump_{key}", names)
                face[key] = (names if key == "states"
                             else lifted_names(names, self.period))
        if "name" in kwargs:
            face["name"] = kwargs["name"]
        super().update_names(**face)

    # -- python-control algebra, mode by mode (theory: interconnections, jump system) ---
    # python-control's operators, feedback, append and indexing dispatch to
    # these methods (ct.series and ct.parallel call the operators; Python
    # calls a subclass's reflected operator first, so ``G * CL`` reaches
    # __rmul__). With a deterministic LTI ``G`` each mode of the result is
    # python-control's operation on that mode, at the base rate, with the
    # same probabilities: exact, because ``G`` has no modes and the mode at
    # time t is the same draw on both sides (an algebraic loop is closed
    # inside the mode, as in control_ncs.jump_feedback).
    def mode_system(self, k: int, i: int) -> ct.StateSpace:
        """Mode ``i`` of phase ``k`` as a StateSpace at the base rate.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.
        i : int
            Mode index, ``0 <= i < nmodes``.

        Returns
        -------
        control.StateSpace
            With the jump system's signal names and its base sampling time.

        Examples
        --------
        >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mode_system(0, 1).A.tolist()
        [[0.9]]
        """
        return ct.StateSpace(*self.mode(k, i), self.dt_step,
                             inputs=self.jump_inputs,
                             outputs=self.jump_outputs,
                             states=self.jump_states, name=self.name)

    def _operand(self, other: Any, what: str) -> Any:
        """``other`` checked to be deterministic LTI data at the base rate
        (:func:`control_ncs._lti.lti_operand`); NotImplemented for types
        python's operator protocol should try elsewhere."""
        from control.exception import ControlArgument
        if isinstance(other, JumpStateSpace):
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

    def mode_law(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The ``(probabilities, transition)`` that rebuild this mode law.

        A system built from new per-mode matrices with the same mode law
        (an interconnection, python-control's algebra) passes both to
        :class:`JumpStateSpace`; ``probabilities`` is the initial law for
        Markov modes (:ref:`theory-markov`) and ``transition`` is None for
        i.i.d. ones.

        Returns
        -------
        probabilities : ndarray, shape (N, M) or (M,)
        transition : ndarray, shape (N, M, M), or None

        Examples
        --------
        >>> S = ncs.jss([[[0.5]], [[1.2]]], [[1.0]], [[1.0]], [[0.0]],
        ...         transition=[[0.5, 0.5], [0.125, 0.875]])
        >>> p, T = S.mode_law()
        >>> T.shape
        (1, 2, 2)
        """
        m = self.modes
        law = m.probabilities if m.initial is None else m.initial
        return law, m.transition


    def _modewise(self, op: Any, what: str, *, name: str | None = None,
                  names: dict | None = None) -> "JumpStateSpace":
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
        return JumpStateSpace(A, B, C, D, self.mode_law()[0], dt,
                              transition=self.modes.transition,
                              nominal=self.nominal_mode, name=name,
                              info=dict(self.info, algebra=what),
                              inputs=labels["inputs"],
                              outputs=labels["outputs"],
                              states=labels["states"])

    def __neg__(self) -> "JumpStateSpace":
        return self._modewise(lambda S: -S, "-sys")

    def __add__(self, other: Any) -> Any:
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

    def __getitem__(self, key: Any) -> "JumpStateSpace":
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

    def append(self, other: Any) -> "JumpStateSpace":
        """Append a deterministic LTI system, mode by mode.

        Parameters
        ----------
        other : StateSpace, TransferFunction, scalar or array
            Deterministic, with the same base step ``dt``.

        Returns
        -------
        JumpStateSpace
            Inputs and outputs of ``self`` then of ``other``; same modes.
        """
        G = self._operand(other, "append(sys, other)")
        if G is NotImplemented:
            return self._refuse("append(sys, other)")
        return self._modewise(lambda S: S.append(G), "append(sys, other)")

    def feedback(self, other: Any = 1, sign: float = -1, **kwargs: Any
                 ) -> "JumpStateSpace":
        """Feedback with a deterministic LTI system, mode by mode.

        :func:`control.feedback` calls this method. Each mode of the result
        is python-control's feedback of that mode with ``other`` (an
        algebraic loop through ``other``'s feedthrough is closed inside the
        mode, exactly); the result equals
        :func:`control_ncs.jump_feedback`.

        Parameters
        ----------
        other : StateSpace, TransferFunction, scalar or array, optional
            Deterministic feedback path with the same base step ``dt``.
        sign : float, optional
            Feedback sign (default -1).
        **kwargs
            ``name``, ``inputs``, ``outputs``, ``states`` for the result.

        Returns
        -------
        JumpStateSpace
            Same inputs and outputs as ``self``; the state is
            ``[ξ; x_other]``.
        """
        G = self._operand(other, "feedback(sys, other)")
        if G is NotImplemented:
            return self._refuse("feedback(sys, other)")
        m, p = len(self.jump_inputs), len(self.jump_outputs)
        if np.ndim(G) == 0 and not isinstance(G, ct.StateSpace) and m == p:
            G = G * np.eye(m)  # a scalar gain on every channel, as jump_feedback
        if isinstance(G, ct.StateSpace):
            gstates = [f"{G.name}.{x}" for x in G.state_labels]
        else:
            gstates = []
        loop = self._modewise(
            lambda S: S.feedback(G, sign), "feedback(sys, other)",
            names=dict(inputs=self.jump_inputs, outputs=self.jump_outputs,
                       states=self.jump_states + gstates))
        if kwargs:
            loop.update_names(**kwargs)
        return loop

    # -- python protocol -----------------------------------------------------
    def __reduce__(self) -> tuple:
        # control.StateSpace holds lambdas and cannot be pickled; rebuild
        # from the defining data instead (this also serves copy/deepcopy).
        m = self.modes
        return (_restore_jss, (m.A, m.B, m.C, m.D, self.mode_law()[0], self.dt_step,
                               self.nominal_mode, self.name, self.jump_inputs,
                               self.jump_outputs, self.jump_states, self.info,
                               m.transition))

    def equals(self, other: object) -> bool:
        """Whether ``other`` is the same jump system, value by value.

        Same modes and probabilities, step, signal names and loss-free mode
        (the name and ``info`` are not compared).

        Parameters
        ----------
        other : object
            Anything; only a :class:`JumpStateSpace` can be equal.

        Returns
        -------
        bool

        Examples
        --------
        >>> import copy
        >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> twin = copy.deepcopy(sys)
        >>> sys.equals(twin), sys == twin
        (True, False)
        """
        return (type(other) is type(self) and self.modes == other.modes
                and self.dt_step == other.dt_step
                and self.jump_inputs == other.jump_inputs
                and self.jump_outputs == other.jump_outputs
                and _same_nominal(self.nominal_mode, other.nominal_mode))

    # ``==`` and ``hash`` are by identity, as for every python-control
    # system: ct.interconnect and dicts key systems by object, and a value
    # ``==`` with an identity hash would break dict semantics (equal objects
    # must hash equal). Compare values with :meth:`equals`.
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    def __repr__(self) -> str:
        n = self.modes.A.shape[-1]
        return (f"<JumpStateSpace {self.name}: {n} states, "
                f"{len(self.jump_inputs)} inputs, {len(self.jump_outputs)} outputs, "
                f"period {self.period}, {self.nmodes} modes, dt={self.dt_step}>")

    def __str__(self) -> str:
        p = np.array2string(self.modes.probabilities, precision=4)
        law = "i.i.d." if self.modes.is_iid else "Markov"
        head = (f"JumpStateSpace: {self.name}\n"
                f"Periodic jump linear system, period N = {self.period}, "
                f"{self.nmodes} {law} modes per step, dt = {self.dt_step}\n"
                f"Mode probabilities (rows = phases):\n{p}\n")
        if self.modes.transition is not None:
            T = np.array2string(self.modes.transition, precision=4)
            head += f"Transition T[k][i, j] = P(j next | i now):\n{T}\n"
        kind = self.info.get("controller")
        if kind:
            head += (f"Closed loop of a networked plant: controller={kind!r}, "
                     f"actuator={self.info.get('actuator')!r}\n")
        what = ("Mean system (exact E z for deterministic w)" if self.period == 1
                else "Mean system lifted over one period (dt = N·dt)")
        return head + what + ":\n" + ct.StateSpace.__str__(self.mean())




def _restore_jss(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                 p: np.ndarray, dt: float | bool, nominal: np.ndarray | None,
                 name: str, inputs: list[str], outputs: list[str],
                 states: list[str], info: dict,
                 transition: np.ndarray | None = None) -> JumpStateSpace:
    return JumpStateSpace(A, B, C, D, p, dt, transition=transition,
                          nominal=nominal, name=name,
                          inputs=inputs, outputs=outputs, states=states,
                          info=info)


def _same_nominal(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two loss-free mode sequences (or their absence) agree."""
    if a is None or b is None:
        return a is b
    return bool(np.array_equal(a, b))


def _names(value: Any, count: int, prefix: str, argname: str) -> list[str]:
    if value is None:
        return [f"{prefix}[{i}]" for i in range(count)]
    if isinstance(value, str):
        value = [value] if count == 1 else [f"{value}[{i}]" for i in range(count)]
    names = [str(v) for v in value]
    if len(names) != count:
        raise ControlDimension(f"{argname}: expected {count} signal names, "
                               f"got {len(names)}")
    return names




def jss(A: Any, B: Any, C: Any, D: Any, probabilities: Any = None,
        dt: Any = True, *, transition: Any = None, **kwargs: Any
        ) -> JumpStateSpace:
    """Create a periodic jump linear system from per-mode matrices.

    Parameters
    ----------
    A, B, C, D : array_like
        Per-mode matrices: a stack of shape ``(M, ., .)`` for ``N = 1``,
        ``(N, M, ., .)`` for period ``N``; a single matrix is shared by all
        modes.
    probabilities : array_like, shape (M,) or (N, M), optional
        Probability of each mode at each phase (i.i.d. in time). With a
        ``transition``: the law of the mode at time 0, shape ``(M,)``
        (default: the periodic stationary law).
    dt : True or float > 0, optional
        Sampling period (discrete time only; default True = unspecified).
    transition : array_like, shape (M, M) or (N, M, M), optional
        Markov modes (:ref:`theory-markov`):
        ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` at phase ``k``. Equal rows
        are exactly the i.i.d. system.
    **kwargs
        ``nominal`` (loss-free mode index per phase), ``name``, ``inputs``,
        ``outputs``, ``states`` (as for :class:`control.StateSpace`), and
        ``info`` (a dict kept on the result for reference, never read by
        analysis); anything else raises ``TypeError``.

    Returns
    -------
    JumpStateSpace

    Raises
    ------
    ValueError
        Complex, string, non-finite or overflowing (``> 1e150``) entries,
        probabilities outside ``[0, 1]`` or not summing to 1, a
        continuous-time ``dt``, or a period whose lifted face exceeds
        ``MAX_LIFTED_ENTRIES``.
    ControlDimension
        Inconsistent shapes, or no input or output.
    TypeError
        Unknown keyword.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    A scalar loop ``x⁺ = 2x + u`` with ``u = -2x`` applied with probability
    0.8 (else ``u = 0``) has mean ``x⁺ = 0.4 x``:

    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> float(sys.A[0, 0])
    0.4

    The same modes driven by a Markov chain (bursts of mode 0): the mean
    face has one state per mode.

    >>> bursty = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
    ...              transition=[[0.5, 0.5], [0.125, 0.875]])
    >>> bursty.modes.is_iid, bursty.nstates, bursty.modes.probabilities.round(12).tolist()
    (False, 2, [[0.2, 0.8]])
    """
    return JumpStateSpace(A, B, C, D, probabilities, dt, transition=transition,
                          **kwargs)




def as_jump(sys: Any, name: str = "sys") -> JumpStateSpace:
    """``sys`` as a :class:`JumpStateSpace`; a deterministic discrete-time
    :class:`control.StateSpace` (or :class:`control.TransferFunction`,
    converted with :func:`control.ss`, as python-control does) becomes a
    one-mode jump system."""
    if isinstance(sys, JumpStateSpace):
        return sys
    from control.exception import ControlArgument
    if isinstance(sys, NetworkedStateSpace):
        # its StateSpace face is the plant without its network: analysing it
        # as a deterministic system would silently drop every loss
        raise ControlArgument(
            f"{name}: got a NetworkedStateSpace, a plant with its network but "
            f"no loop; close it first with control_ncs.feedback(P, K), or "
            f"pass ct.ss(P) to analyse the plant without its network")
    if isinstance(sys, ct.TransferFunction):
        sys = ct.ss(sys)
    if isinstance(sys, ct.StateSpace):
        dt = discrete_dt(sys.dt, f"{name}.dt")
        return JumpStateSpace(sys.A[None], sys.B[None], sys.C[None],
                              sys.D[None], [1.0], dt, nominal=[0],
                              inputs=list(sys.input_labels),
                              outputs=list(sys.output_labels),
                              states=list(sys.state_labels), name=sys.name)
    raise ControlArgument(f"{name}: expected a JumpStateSpace (see jss() or "
                          f"control_ncs.feedback()) or a discrete-time "
                          f"control.StateSpace or TransferFunction, got "
                          f"{type(sys).__name__}")
