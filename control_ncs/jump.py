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

from typing import Any

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._checks import discrete_dt, no_extra_kwargs, real_array
from ._lifting import check_lifted_size, lift, lifted_names
from . import _face
from ._modewise import ModewiseAlgebra
from .modes import (Modes, apply_groups, chain_law, check_probabilities,
                    markov_mean, merge_groups)
from .plant import NetworkedStateSpace

__all__ = ["JumpStateSpace", "jss"]

#: What cannot change after construction: the face is the exact mean of
#: the modes only while neither changes.
_FROZEN = frozenset({"A", "B", "C", "D", "dt", "modes", "dt_step",
                     "nominal_mode"})


#: The most memory the exact mean of Markov modes may take (its ``A`` is a
#: dense ``(M n) × (M n)`` matrix per phase): beyond it the face is refused
#: before it is allocated.
MAX_MEAN_BYTES = 2 * 2 ** 30


def _check_mean_bytes(N: int, M: int, n: int) -> None:
    size = 8.0 * N * (M * n) ** 2
    if size > MAX_MEAN_BYTES:
        raise ValueError(
            f"transition: the exact mean of {M} Markov modes of {n} states "
            f"(python-control's face of the system, a dense matrix of order "
            f"{M * n} per phase, {N} phase(s)) would take "
            f"{size / 2 ** 30:.3g} GiB, more than MAX_MEAN_BYTES = "
            f"{MAX_MEAN_BYTES / 2 ** 30:.3g} GiB; use fewer modes (shorter "
            f"buffers) or fewer states")


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



class JumpStateSpace(ModewiseAlgebra):
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
    per-step signals for any ``N``. A jump system whose live modes coincide
    and do not change with the phase is such a deterministic ``G`` too; two
    random jump systems together raise ``ControlArgument`` (their modes are
    independent only if you say so). ``control.linearize`` returns the
    system itself. A ``TransferFunction`` operator with this system on
    the right (``H * sys``, ``H + sys``, ``series(sys, H)``) and
    ``control.tf(sys)`` would return the mean's transfer function: they
    raise ``ControlArgument`` (convert ``H`` with ``control.ss``). Calls
    python-control does not dispatch to this object
    (``control.feedback(G, sys)``, ``control.append(G, sys)``,
    ``control.interconnect``) read the face and return an ordinary system
    built from the mean (the exact mean of the interconnection only if no
    algebraic loop multiplies two mode-dependent matrices);
    :func:`control_ncs.interconnect` is the exact interconnection by signal
    names. ``control.ss(sys)`` and python-control's other copies
    (``similarity_transform``, canonical forms) are plain ``StateSpace``
    copies of the mean face, which the package's functions recognise and
    refuse. ``==`` and ``hash`` are by identity, as for python-control's
    systems; :meth:`equals` compares values.

    Build one with :func:`jss` or :func:`control_ncs.feedback`. It is
    immutable: its arrays (the modes and the mean face) are read-only and
    assigning ``A``, ``B``, ``C``, ``D``, ``dt`` or ``modes`` raises
    ``AttributeError``, so the face stays the mean of the modes. It prints
    as python-control's systems do (``repr`` formats ``'eval'`` and
    ``'info'``, ``str``, HTML), with its mode law. A period whose lifted
    face would exceed ``MAX_LIFTED_ENTRIES`` entries is refused.

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
        per-step signals ``w`` and ``z``, not the lifted ones (default
        ``'w[i]'``, ``'z[i]'``, ``'x[i]'``; a count gives python-control's
        generic names ``'u[i]'``, ``'y[i]'``, ``'x[i]'``).
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
        Names of ``w``, ``z`` and ``ξ`` at one step (``nstates`` is the
        face's order: ``M·n`` for Markov modes).
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

        # a random system marks its face's state names: python-control's
        # copies keep them, and the package refuses such a copy (_face)
        self._random = self.deterministic() is None
        if T is None:
            Abar, Bbar, Cbar, Dbar = self.modes.mean()
        else:
            check_lifted_size(M * n, m, q, N, "transition")
            _check_mean_bytes(N, M, n)
            Abar, Bbar, Cbar, Dbar = markov_mean(self.modes)
        if N == 1:
            mats = (Abar[0], Bbar[0], Cbar[0], Dbar[0])
            lifted_dt = self.dt_step
        else:
            mats = lift(Abar, Bbar, Cbar, Dbar)
            lifted_dt = True if self.dt_step is True else self.dt_step * N
        super().__init__(*mats, lifted_dt, name=name,
                         inputs=lifted_names(self.jump_inputs, N),
                         outputs=lifted_names(self.jump_outputs, N),
                         states=self._face_states(self.jump_states))
        # the face is the exact mean of self.modes only while neither changes
        for X in (self.A, self.B, self.C, self.D):
            X.setflags(write=False)
        object.__setattr__(self, "_frozen", True)

    def _face_states(self, names: list[str]) -> list[str]:
        """The face's state names: one per state, or per state and mode
        (``'x[0]#1'``) for Markov modes; marked if the system is random."""
        if not self.modes.is_iid:
            names = [f"{s}#{i}" for i in range(self.nmodes) for s in names]
        return _face.face_states(names, self._random)

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _FROZEN and self.__dict__.get("_frozen", False):
            raise AttributeError(
                f"{name}: a JumpStateSpace cannot be changed: its "
                f"StateSpace matrices are the exact mean of its modes "
                f"(sys.modes), whose arrays are read-only; build a new "
                f"system with control_ncs.jss()")
        super().__setattr__(name, value)

    # python-control reads ``nstates`` first when it converts a system to a
    # transfer function; a random system refuses the conversions that
    # would silently drop its modes (TransferFunction algebra, ct.tf)
    @property
    def nstates(self) -> int:
        """Order of the StateSpace face: ``M·n`` for Markov modes.

        The loop's own state (``n`` entries, the size of an
        ``initial_state``) is named by :attr:`jump_states`.
        """
        if self.__dict__.get("_random"):
            _face.check_face_read(self, _face.caller(2))
        try:
            return self.__dict__["nstates"]
        except KeyError:
            raise AttributeError("nstates") from None

    @nstates.setter
    def nstates(self, value: int) -> None:
        self.__dict__["nstates"] = value

    def issiso(self) -> bool:
        """Whether the face has one input and one output (python-control).

        ``control.step_response`` of a period-``N`` system (``N > 1``)
        warns here: it steps the lifted face, not the base-rate loop.
        """
        _face.warn_step_response(self, _face.caller(2))
        return bool(super().issiso())

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
        is not the jump system's (:ref:`theory-performance`): refused there,
        naming :func:`control_ncs.norm`. Other copies keep the mean face;
        the package's functions refuse them (:mod:`control_ncs._face`).
        """
        if self._random:
            _face.check_norm_caller(self, _face.caller(2))
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
                             states=_face.plain(self.state_labels),
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

    def linearize(self, x0: Any, u0: Any = None, t: float = 0,
                  params: Any = None, eps: float = 1e-6,
                  copy_names: bool = False, **kwargs: Any
                  ) -> "JumpStateSpace":
        """The jump system itself: each mode is already linear.

        :func:`control.linearize` calls this method. The linearization of
        a jump system about any operating point is the system itself, mode
        by mode, with the same mode law (python-control's numerical
        linearization of the face would return its mean only). Named as
        python-control names a linearization.

        Parameters
        ----------
        x0, u0 : array_like or scalar
            Operating point: ``x0`` of the face's ``nstates`` (or the
            loop's own states), ``u0`` of its inputs (or the per-step
            ones); they do not change the result.
        t, params, eps
            Accepted as by python-control; unused (the system is linear
            and time-invariant per phase).
        copy_names : bool, optional
            Keep the signal names and name the result
            ``'<name>$linearized'``; default: python-control's generic
            names.
        **kwargs
            ``name``, ``inputs``, ``outputs``, ``states`` of the result.

        Returns
        -------
        JumpStateSpace

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
        ...               [0.2, 0.8], name="CL")
        >>> lin = ct.linearize(sys, [1.0], [0.0], copy_names=True)
        >>> type(lin).__name__, lin.name, lin.modes.A[0, :, 0, 0].tolist()
        ('JumpStateSpace', 'CL$linearized', [2.0, 0.0])
        """
        no_extra_kwargs("linearize", {k: v for k, v in kwargs.items() if k
                                      not in ("name", "inputs", "outputs",
                                              "states")})
        n = self.modes.A.shape[-1]
        for value, sizes, what in ((x0, (self.nstates, n), "x0"),
                                   (u0, (self.ninputs, len(self.jump_inputs)),
                                    "u0")):
            size = np.size(value) if value is not None else 0
            if value is not None and size != 1 and size not in sizes:
                raise ControlDimension(
                    f"{what}: expected {sizes[0]} entries (or "
                    f"{sizes[1]}, per step), got {size}")
        defaults = ct.config.defaults
        names: dict[str, Any] = dict(
            name=(defaults["iosys.linearized_system_name_prefix"] + self.name
                  + defaults["iosys.linearized_system_name_suffix"]),
            inputs=self.jump_inputs, outputs=self.jump_outputs,
            states=self.jump_states) if copy_names else dict(
            name=None, inputs=len(self.jump_inputs),
            outputs=len(self.jump_outputs), states=n)
        names.update(kwargs)
        m = self.modes
        law, transition = self.mode_law()
        return JumpStateSpace(m.A, m.B, m.C, m.D, law, self.dt_step,
                              transition=transition, nominal=self.nominal_mode,
                              info=dict(self.info), **names)

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
                face[key] = (self._face_states(names) if key == "states"
                             else lifted_names(names, self.period))
        if "name" in kwargs:
            face["name"] = kwargs["name"]
        super().update_names(**face)

    # -- mode by mode (theory: interconnections, jump system) ----------------
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
        lti = self._reflected(other)
        if lti is not None:
            return other._modewise(lambda S: lti.append(S),
                                   "append(other, sys)")
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
        lti = self._reflected(other)
        if lti is not None:
            loop = other._modewise(lambda S: lti.feedback(S, sign),
                                   "feedback(other, sys)")
            if kwargs:
                loop.update_names(**kwargs)
            return loop
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

    # -- printing: python-control's protocol (repr formats, html, str) -----
    def _repr_info_(self, html: bool = False) -> str:
        return _face.info_repr(self, html)

    def _repr_eval_(self) -> str:
        return _face.eval_repr(self)

    def _repr_html_(self) -> str | None:
        return _face.html_repr(self)

    def __str__(self) -> str:
        return _face.str_repr(self)


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
    if isinstance(value, (int, np.integer)) and not isinstance(
            value, (bool, np.bool_)):
        # a count, as python-control takes one: its generic names
        if value != count:
            raise ControlDimension(f"{argname}: expected {count} signals, "
                                   f"got {value}")
        pc = _face.GENERIC[argname]
        return [f"{pc}[{i}]" for i in range(count)]
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
    # a copy of a random jump system's mean face has lost its modes
    _face.refuse_mean_copy(sys, name)
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
