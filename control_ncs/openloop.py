"""The open loop that synthesis consumes: :class:`JumpPlant`.

A network strategy (:mod:`control_ncs.strategies`) turns a plant, its
network and a controller kind into a periodic jump system whose gain is
still free (:ref:`theory-jump-system`); synthesis designs the gain and
:meth:`JumpPlant.close` applies it, giving a
:class:`~control_ncs.jump.JumpStateSpace`.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field, replace
from typing import Any, Mapping

import numpy as np
from control.exception import ControlArgument

from .constrained import ConstrainedLoop, Constraint
from .jump import JumpStateSpace
from .modes import apply_groups, merge_groups

__all__ = ["JumpPlant"]

#: The per-mode entries of a sampling record (tau and s as (N, M, 1, 1)
#: while modes are merged).
_MODE_RECORD = ("x", "u", "u_w", "u_prev", "omega", "tau", "s", "u_n",
                "n_noise")
_SCALARS = ("tau", "s")


@dataclass(frozen=True, eq=False)
class JumpPlant:
    """A periodic jump system before its gain is chosen.

    (:ref:`theory-jump-system`.)

    ``ξ⁺ = (A + Bu K_k E_k) ξ + Bw w``, ``z = (Cz + Du K_k E_k) ξ + Dw w``, all
    matrices per phase ``k`` and mode ``i``. ``E_k`` says what the controller
    knows of ``ξ``: for synthesis it must be a coordinate selection (each row
    a unit vector or zero). Network strategies build this object
    (``strategies.py``); :func:`control_ncs.passivesyn` designs ``K``;
    :meth:`close` applies it.

    The object is immutable: a transformation (merged modes, new
    coordinates) is a new plant, made with :func:`dataclasses.replace`.
    Everything synthesis reads is a named field; ``description`` is for
    people only.

    Parameters
    ----------
    A, Bu, Bw, Cz, Du, Dw : array_like, shape (N, M, ., .)
        Per-phase, per-mode matrices of the loop before the gain: shapes
        ``(nx, nx)``, ``(nx, nu)``, ``(nx, nw)``, ``(nz, nx)``, ``(nz, nu)``,
        ``(nz, nw)``. Taken as they are (no broadcasting, no validation):
        builders such as :func:`control_ncs.build` check their inputs.
    E : array_like, shape (N, nk, nx) or (N, M, nk, nx)
        What the controller sees of ``ξ`` at each phase, or in each mode
        of each phase (a gain per age of a buffered measurement: each mode
        reads the block of its age).
    probabilities : array_like, shape (N, M)
        Mode probabilities per phase; each row sums to 1.
    dt : True or float > 0, optional
        Sampling period of one step (default True, unspecified).
    transition : array_like, shape (N, M, M), optional
        Markov modes (:ref:`theory-markov`):
        ``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``; ``probabilities`` are then
        the stationary marginals. None: i.i.d.
    nominal : array_like of int, shape (N,), optional
        The loss-free mode of each phase.
    inputs, outputs, states : list of str, optional
        Names of ``w``, ``z`` and ``ξ``, handed to the closed loop.
    name : str, optional
        The plant's name; the closed loop is ``'<name> (closed loop)'``.
    controller, actuator : str, optional
        The controller and actuator kinds that built the plant (the labels
        of the designed gain; see :data:`control_ncs.gain.CONTROLLERS`).
    observed : array_like of int, shape (N, M), optional
        Markov links: the observation class of each previous mode at each
        phase; equal labels for modes the controller cannot tell apart (a
        link reveals its state only when it was scheduled). Mode-dependent
        gains ``K_{k,ℓ}`` are equal within a class.
    estimator_gain : array_like, shape (N_L, n, nmeas), optional
        The estimator's ``L_k`` of a ``controller='estimator'`` plant.
    Ew : array_like, shape (N, nk, nw) or (N, M, nk, nw), optional
        Noise in what the controller sees (a measurement ``y = C2 x +
        D21 w`` read at once): it sees ``E_k ξ + Ew_k w``.
    Gw : array_like, shape (N, M, nx, nw), optional
        Noise that reached the state with the last message (a measurement
        stored when it arrived): step ``k`` acts on ``ξ + Gw[k, ℓ] w``,
        ``ℓ`` the previous mode. The loop is then closed on pair modes
        ``(ℓ, i)``, as for gains per previous mode. ``Ew`` and ``Gw``
        (:ref:`theory-measurement-noise`) are for analysis: synthesis
        refuses plants that have them.
    description : mapping, optional
        The network's description (losses, links), copied into the closed
        loop's ``info``.
    sampling : mapping, optional
        For a plant sampled from a continuous-time one: the open loop's
        record of where the plant state and its input sit, per phase and
        mode (``x``, ``u``, ``u_w``, ``u_v`` the rows of ``u_k`` on the
        command, ``u_prev``, ``omega``, ``tau``, with ``h``, ``plant``,
        ``nmeas``, ``ncon``); :meth:`close` gives the closed loop's
        ``info['sampling']``, which :func:`control_ncs.cost` reads
        (:mod:`control_ncs.intersample` defines the entries).
    constraint : Constraint, optional
        A network with a loss budget (:ref:`theory-worst-case`): the
        budget state and stochastic state of each mode, the moves the
        budgets allow per phase and the law of the rest. ``probabilities``
        are then those of each mode's stochastic state given its budget
        state (rows sum to 1 over the modes of one budget state, not over
        the phase: the budgets have no probabilities), ``transition`` is
        None, and :meth:`close` gives a
        :class:`~control_ncs.ConstrainedLoop`.

    Attributes
    ----------
    A, Bu, Bw, Cz, Du, Dw, E, probabilities, transition, nominal : ndarray
        The parameters above as read-only float (``nominal``: int) arrays.
    dt, inputs, outputs, states, name, controller, actuator
        As given.
    observed, estimator_gain, Ew, Gw : ndarray or None
        As given, read-only.
    description : dict
        A copy, for people: synthesis never reads it.

    Examples
    --------
    The scalar plant ``x⁺ = 2x + u`` whose actuator message is lost with
    probability 0.2, closed with ``u = -2x``:

    >>> import numpy as np
    >>> import control_ncs as ncs
    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=0.2)
    >>> plant = ncs.build(P)
    >>> plant.gain_shape(), plant.probabilities.tolist()
    ((1, 1, 1), [[0.0, 0.2, 0.0, 0.8]])
    >>> plant.controller, plant.actuator
    ('static', 'zero')
    >>> CL = plant.close(np.full((1, 1, 1), -2.0))
    >>> CL.modes.A[0, :, 0, 0].tolist(), CL.modes.probabilities.tolist()
    ([2.0, 0.0], [[0.2, 0.8]])
    """

    A: np.ndarray
    Bu: np.ndarray
    Bw: np.ndarray
    Cz: np.ndarray
    Du: np.ndarray
    Dw: np.ndarray
    E: np.ndarray
    probabilities: np.ndarray
    dt: Any = True
    _: KW_ONLY
    transition: np.ndarray | None = None
    nominal: np.ndarray | None = None
    inputs: list | None = None
    outputs: list | None = None
    states: list | None = None
    name: str | None = None
    controller: str | None = None
    actuator: str | None = None
    observed: np.ndarray | None = None
    estimator_gain: np.ndarray | None = None
    Ew: np.ndarray | None = None
    Gw: np.ndarray | None = None
    description: Mapping = field(default_factory=dict)
    sampling: Mapping | None = None
    constraint: Constraint | None = None

    _FIELDS = ("A", "Bu", "Bw", "Cz", "Du", "Dw")

    def __post_init__(self) -> None:
        def frozen(value: Any, dtype: Any) -> np.ndarray | None:
            if value is None:
                return None
            out = np.array(value, dtype)
            out.flags.writeable = False
            return out

        for f in self._FIELDS + ("E", "probabilities", "transition"):
            object.__setattr__(self, f, frozen(getattr(self, f), float))
        object.__setattr__(self, "nominal", frozen(self.nominal, int))
        object.__setattr__(self, "observed", frozen(self.observed, int))
        for f in ("estimator_gain", "Ew", "Gw"):
            object.__setattr__(self, f, frozen(getattr(self, f), float))
        object.__setattr__(self, "description", dict(self.description))

    @property
    def info(self) -> dict:
        """What the closed loop records in its ``info``.

        The description, the plant's name, the controller and actuator
        kinds, and the estimator gain and what is observed, when set.
        """
        out = dict(self.description, controller=self.controller,
                   actuator=self.actuator, plant=self.name)
        for key in ("observed", "estimator_gain"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out

    def require_noise_free(self, who: str) -> None:
        """Refuse a plant whose controller hears noise (``Ew``, ``Gw``).

        Synthesis treats what the controller sees as part of the state
        (``K E ξ``); a gain acting on measurement noise as well is a
        different problem, not written yet.

        Parameters
        ----------
        who : str
            The function that refuses, for the message.

        Raises
        ------
        ControlArgument
            If the plant has ``Ew`` or ``Gw``.
        """
        if self.Ew is not None or self.Gw is not None:
            raise ControlArgument(
                f"P: {who} designs for measurements without noise "
                f"(D21 = 0); with D21 ≠ 0 the gain also acts on w, which "
                f"its programs do not cover yet. Design for D21 = 0 and "
                f"analyse the loop with the noise: feedback(P, K)")

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.probabilities.shape[0]

    @property
    def is_iid(self) -> bool:
        """True for i.i.d. modes.

        Synthesis from ``probabilities`` alone (:ref:`theory-synthesis`) is
        valid only then (never over a loss budget)."""
        return self.transition is None and self.constraint is None

    def _refuse_budget(self, what: str) -> None:
        if self.constraint is not None:
            raise ControlArgument(
                f"P: {what} needs the probabilities of every mode, but the "
                f"network has a loss budget (modes allowed by an automaton, "
                f"without probabilities); design for every allowed pattern "
                f"with control_ncs.worst_case_route, analyse the loop with "
                f"control_ncs.jsr")

    @property
    def shape(self) -> dict:
        """Sizes: ``nx`` (state), ``nw``, ``nz``, ``nu`` (control), ``nk``."""
        return dict(nx=self.A.shape[-1], nw=self.Bw.shape[-1],
                    nz=self.Cz.shape[-2], nu=self.Bu.shape[-1],
                    nk=self.E.shape[-2])

    @property
    def reads_per_mode(self) -> bool:
        """True when the gain reads something else in each mode.

        ``E`` of shape (N, M, nk, nx): a gain per age of a buffered
        measurement. The convex programs need one reading per phase."""
        return self.E.ndim == 4

    def readings(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``E`` and ``Ew`` per phase and mode, (N, M, nk, ·).

        Returns
        -------
        E, Ew : ndarray
            Broadcast over the modes when they are per phase; ``Ew`` None
            without measurement noise read at once.
        """
        M = self.probabilities.shape[1]

        def per_mode(X):
            if X is None or X.ndim == 4:
                return X
            return np.broadcast_to(X[:, None], (X.shape[0], M) + X.shape[1:])
        return per_mode(self.E), per_mode(self.Ew)

    def gain_shape(self) -> tuple[int, int, int]:
        """Shape ``(N, nu, nk)`` of a gain sequence for :meth:`close`.

        Returns
        -------
        tuple of int
            ``(period, nu, nk)``.
        """
        s = self.shape
        return (self.period, s["nu"], s["nk"])

    # the loop is a JumpStateSpace, or a ConstrainedLoop over a loss budget
    # (the designs close only plants without one, as JumpStateSpace)
    def close(self, gains: np.ndarray, **info: Any) -> Any:
        """The closed loop with ``v = K_k E_k ξ`` (a JumpStateSpace).

        The gain acts in positive feedback, as it is (``u = K x`` for
        ``E = I``); negate a gain designed for ``u = -K x``, such as
        :func:`control.dlqr`'s.

        Parameters
        ----------
        gains : array_like, shape (N, nu, nk) or (N, M, nu, nk)
            ``K_k`` per phase (:meth:`gain_shape`), or ``K_{k,ℓ}`` per phase
            and previous mode ``ℓ`` (:ref:`theory-markov`).
        **info
            Added to the result's ``info``.

        Returns
        -------
        JumpStateSpace or ConstrainedLoop
            Coinciding modes merged; named ``'<name> (closed loop)'`` after
            the plant's ``name``, when the builder recorded it (as
            :func:`control_ncs.build` does). Over a loss budget
            (:attr:`constraint`): a :class:`~control_ncs.ConstrainedLoop`,
            its modes unmerged (gains per previous mode: per pair).
        """
        K = np.asarray(gains, float)
        name = None if self.name is None else f"{self.name} (closed loop)"
        if self.constraint is not None:
            return self._close_budget(K, name, info)
        if K.ndim == 4 or self.Gw is not None:
            if K.ndim == 3:     # one gain for every previous mode
                K = np.repeat(K[:, None], self.probabilities.shape[1], 1)
            return self._close_pairs(K, name, info)
        E, Ew = self.readings()
        F = np.einsum("kuj,kmjx->kmux", K, E)     # K_k E_ki per mode
        A = self.A + self.Bu @ F
        C = self.Cz + self.Du @ F
        B, D = self.Bw, self.Dw
        if Ew is not None:
            Fw = np.einsum("kuj,kmjw->kmuw", K, Ew)
            B = B + self.Bu @ Fw
            D = D + self.Du @ Fw
        loop = (A, B, C, D)
        record = self._record(F, None if Ew is None else Fw, K=K)
        if self.transition is not None:
            # Markov modes are not merged (their futures differ, theory: Markov
            # losses)
            return JumpStateSpace(*loop, None, self.dt,
                                  transition=self.transition,
                                  nominal=self.nominal,
                                  inputs=self.inputs, outputs=self.outputs,
                                  states=self.states, name=name,
                                  info=self._info(K, info, record))
        # merge before building: the lifted face is then built once; modes
        # whose sampling rows differ move the continuous plant differently
        extra = [] if record is None else [
            record[f] if f not in _SCALARS else record[f][..., None, None]
            for f in _MODE_RECORD]
        groups, nominal = merge_groups(list(loop) + extra,
                                       self.probabilities, self.nominal)
        merged, p = apply_groups(list(loop) + extra, self.probabilities,
                                 groups)
        if record is not None:
            record = dict(record, **dict(zip(_MODE_RECORD, merged[4:])))
            for f in _SCALARS:
                record[f] = record[f][:, :, 0, 0]
        A, B, C, D = merged[:4]
        return JumpStateSpace(A, B, C, D, p, self.dt, nominal=nominal,
                              inputs=self.inputs, outputs=self.outputs,
                              states=self.states, name=name,
                              info=self._info(K, info, record))

    def _close_budget(self, K: np.ndarray, name: Any, info: dict
                      ) -> ConstrainedLoop:
        """The loop over a loss budget (:ref:`theory-worst-case`): the
        closed-loop matrices per phase and mode with the plant's
        constraint; gains per previous mode (or noise that reached the state
        with the last message) make them depend on pairs ``(ℓ, i)``, whose
        constraint is :meth:`Constraint.pairs`."""
        assert self.constraint is not None
        out = dict(self.info, gains=K, **info)
        if K.ndim == 4 or self.Gw is not None:
            if K.ndim == 3:
                K = np.repeat(K[:, None], self.probabilities.shape[1], 1)
            A, B, C, D = self._lumped_pairs(K)[:4]
            N, M = self.probabilities.shape
            loop = [X.reshape((N, M * M) + X.shape[3:]) for X in (A, B, C, D)]
            constraint = self.constraint.pairs()
            out["pair_modes"] = True
        else:
            E, Ew = self.readings()
            F = np.einsum("kuj,kmjx->kmux", K, E)
            B, D = self.Bw, self.Dw
            if Ew is not None:
                Fw = np.einsum("kuj,kmjw->kmuw", K, Ew)
                B = B + self.Bu @ Fw
                D = D + self.Du @ Fw
            loop = [self.A + self.Bu @ F, B, self.Cz + self.Du @ F, D]
            constraint = self.constraint
        return ConstrainedLoop(loop[0], loop[1], loop[2], loop[3],
                               constraint, self.dt,
                               inputs=self.inputs, outputs=self.outputs,
                               states=self.states, name=name, info=out)

    def _info(self, K: np.ndarray, info: dict, record: dict | None) -> dict:
        out = dict(self.info, gains=K, **info)
        if record is not None:
            # the plant state sits in the same place in every mode: its rows
            # once, or a slice where they are a block of the identity
            rows = record["x"].reshape((-1,) + record["x"].shape[-2:])
            if not np.all(rows == rows[0]):
                raise ValueError("the plant state moves within the loop "
                                 "state from mode to mode: the sampling "
                                 "record cannot describe this loop")
            x = rows[0]
            n = x.shape[0]
            start = int(np.argmax(x[0])) if x.size else 0
            block = np.zeros_like(x)
            block[:, start:start + n] = np.eye(n)
            out["sampling"] = dict(record, x=slice(start, start + n)
                                   if np.array_equal(x, block) else x)
        return out

    def _record(self, F: np.ndarray, Fw: np.ndarray | None,
                Gw: np.ndarray | None = None, K: np.ndarray | None = None
                ) -> dict | None:
        """The closed loop's sampling record (:mod:`control_ncs.intersample`)
        with the feedback rows ``F = K E`` (and ``Fw = K Ew``; ``Gw`` the
        noise the state carries from the last message), per phase and mode
        (or previous and current mode, when ``F`` has that axis); with
        sampling jitter, the rows of ``u_k`` on the late sample's noise
        ``n_s`` and where it enters the next state (the gain ``K`` reads
        it)."""
        s = self.sampling
        if s is None:
            return None
        pairs = F.ndim == 5
        lift = (lambda X: X[:, None]) if pairs else (lambda X: X)
        u = lift(s["u"]) + lift(s["u_v"]) @ F
        u_w = lift(s["u_w"]) + (0.0 if Fw is None else lift(s["u_v"]) @ Fw)
        if Gw is not None:
            # step k acts on ξ + Gw[k, ℓ] w: the input too; the plant state
            # and the held input never carry that noise (checked)
            if np.any(s["x"][:, None] @ Gw[:, :, None]) or \
                    np.any(s["u_prev"][:, None] @ Gw[:, :, None]):
                raise ValueError("the noise a message carried reaches the "
                                 "plant state: the sampling record cannot "
                                 "describe this loop")
            u_w = u_w + u @ Gw[:, :, None]
        shape = u.shape[:-2]
        out = dict(s, u=u, u_w=u_w)
        for f in ("u_v", "e_n", "n_in", "sample_next"):
            out.pop(f, None)
        for f in ("x", "u_prev", "omega"):
            out[f] = np.broadcast_to(lift(s[f]), shape + s[f].shape[-2:])
        out["tau"] = np.broadcast_to(lift(s["tau"]), shape)
        out["s"] = np.broadcast_to(lift(s.get("s", np.zeros_like(
            s["tau"], float))), shape)
        out["u_n"], out["n_noise"] = self._late_sample(F, u, K, lift, shape)
        return out

    def _late_sample(self, F: np.ndarray, u: np.ndarray, K: Any,
                     lift: Any, shape: tuple) -> tuple:
        """``(u_n, n_noise)`` of the closed record: the rows of ``u_k`` on
        a late sample's noise ``n_s`` and where ``n_s`` enters ``ξ_{k+1}``
        (:ref:`theory-sampling-jitter`). The static gain reads it in the
        same step (``K e_n``); a controller with memory read it at the end
        of the previous step, into the state this step acts on (like the
        next measurement's noise, ``Gw``): its rows there move with the
        closed loop's ``A`` and reach ``u_k``."""
        s = self.sampling
        assert s is not None
        nX = self.A.shape[-1]
        n = s["omega"].shape[-1]
        m2 = s["u"].shape[-2]
        if "e_n" not in s or K is None:
            return (np.zeros(shape + (m2, n)), np.zeros(shape + (nX, n)))
        pairs = F.ndim == 5
        Fn = np.einsum("kluj,kmjx->klmux" if pairs else "kuj,kmjx->kmux",
                       K, s["e_n"])
        u_n = lift(s["u_v"]) @ Fn
        n_noise = lift(self.Bu) @ Fn
        if not s["sample_next"]:
            return (np.broadcast_to(u_n, shape + (m2, n)),
                    np.broadcast_to(n_noise + lift(s["n_in"]),
                                    shape + (nX, n)))
        g = np.roll(s["n_in"], 1, axis=0)
        if not pairs:
            if np.any(g):
                raise ValueError("a late sample's noise reaches the state "
                                 "through the previous mode: the loop "
                                 "needs modes on pairs")
            return (np.broadcast_to(u_n, shape + (m2, n)),
                    np.broadcast_to(n_noise, shape + (nX, n)))
        g = g[:, :, None]                        # [k, ℓ]: written at k - 1
        if np.any(s["x"][:, None] @ g) or np.any(s["u_prev"][:, None] @ g):
            raise ValueError("a late sample's noise reaches the plant state "
                             "or the held input: the sampling record cannot "
                             "describe this loop")
        A = lift(self.A) + lift(self.Bu) @ F
        return u_n + u @ g, n_noise + A @ g

    def transitions(self) -> np.ndarray:
        """``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``, shape (N, M, M).

        For i.i.d. modes every row of ``T[k]`` is ``probabilities[k + 1]``.

        Returns
        -------
        ndarray

        Raises
        ------
        ControlArgument
            Over a loss budget (no probabilities).
        """
        self._refuse_budget("transitions()")
        if self.transition is not None:
            return self.transition
        M = self.probabilities.shape[1]
        nxt = np.roll(self.probabilities, -1, axis=0)
        return np.repeat(nxt[:, None, :], M, axis=1)

    def _close_pairs(self, K: np.ndarray, name: Any, info: dict
                     ) -> JumpStateSpace:
        """The closed loop with gains ``K_{k,ℓ}`` (shape (N, M, nu, nk)) on
        the previous mode ``ℓ = σ_{k-1}`` (:ref:`theory-markov`).

        A Markov jump system on pair modes ``(ℓ, i)``, ``(ℓ, i) → (i, j)``
        with probability ``T_k[i, j]``, mode matrices
        ``A_{k,i} + Bu_{k,i} K_{k,ℓ} E_k``. Pairs with the same ``i`` and
        the same matrices (e.g. every ``ℓ`` when the input is lost in
        ``i``) have the same future and are lumped into one mode; phases
        with fewer lumped modes repeat their last one, unreachable. The
        current plant mode ``i`` of each lumped mode is
        :meth:`pair_modes` (also recorded as ``info['pair_modes']``). The
        initial law is the stationary one.
        """
        A, B, C, D, where, padded, record = self._lumped_pairs(K)
        N, M = self.probabilities.shape
        T = self.transitions()
        G = len(padded[0])
        cur = np.array([[i for i, _ in g] for g in padded])

        def pick(X: np.ndarray) -> np.ndarray:
            return np.array([[X[k, ell, i] for i, ell in g]
                             for k, g in enumerate(padded)])
        Ap, Bp, Cp, Dp = (pick(X) for X in (A, B, C, D))
        if record is not None:
            record = dict(record, **{f: pick(record[f])
                                     for f in _MODE_RECORD})
        Tp = np.zeros((N, G, G))
        for k in range(N):
            for s, (i, _) in enumerate(padded[k]):
                for j in range(M):
                    Tp[k, s, where[(k + 1) % N][(i, j)]] += T[k, i, j]
        nominal = None
        if self.nominal is not None:
            # the loss-free mode reached from the loss-free mode
            nominal = [where[k][(self.nominal[k - 1], self.nominal[k])]
                       for k in range(N)]
        return JumpStateSpace(Ap, Bp, Cp, Dp, None, self.dt, transition=Tp,
                              nominal=nominal, inputs=self.inputs,
                              outputs=self.outputs, states=self.states,
                              name=name,
                              info=self._info(K, dict(info, pair_modes=cur),
                                              record))

    def pair_modes(self, gains: np.ndarray) -> np.ndarray:
        """The current plant mode of each lumped pair mode.

        With gains ``K_{k,ℓ}`` per previous mode, :meth:`close` builds a
        Markov jump system on pair modes ``(ℓ, i)``, lumping pairs with the
        same future; this is the plant mode ``i`` of each of them.

        Parameters
        ----------
        gains : array_like, shape (N, M, nu, nk)

        Returns
        -------
        ndarray of int, shape (N, G)
            Row ``k``: the plant mode of each closed-loop mode at phase
            ``k`` (the loop's modes in the order :meth:`close` gives them).
        """
        padded = self._lumped_pairs(np.asarray(gains, float))[5]
        return np.array([[i for i, _ in g] for g in padded])

    def _lumped_pairs(self, K: np.ndarray) -> tuple:
        """Mode matrices of the pairs ``(ℓ, i)`` and their lumping:
        ``A, B, C, D[k, ℓ, i]``, ``where[k][(ℓ, i)]`` (the lumped mode) and
        the padded groups ``[(i, ℓ), …]`` per phase. With noise the
        controller hears (``Ew``, ``Gw``) the input matrices are
        ``Bw + Bu K Ew + (A + Bu K E) Gw`` and likewise for ``D``."""
        N, M = self.probabilities.shape
        E, Ew = self.readings()
        F = np.einsum("kluj,kmjx->klmux", K, E)  # K_{k,ℓ} E_{k,i}
        A = self.A[:, None] + self.Bu[:, None] @ F
        C = self.Cz[:, None] + self.Du[:, None] @ F
        B = np.repeat(self.Bw[:, None], M, 1)
        D = np.repeat(self.Dw[:, None], M, 1)
        if Ew is not None:
            Fw = np.einsum("kluj,kmjw->klmuw", K, Ew)
            B = B + self.Bu[:, None] @ Fw
            D = D + self.Du[:, None] @ Fw
        if self.Gw is not None:
            B = B + np.einsum("klmxy,klyw->klmxw", A, self.Gw)
            D = D + np.einsum("klmzy,klyw->klmzw", C, self.Gw)
        record = self._record(F, None if Ew is None else Fw, self.Gw, K)
        extra = () if record is None else tuple(
            record[f] for f in _MODE_RECORD)
        # lumped mode of the pair (ℓ, i) at each phase; first member kept
        where: list = []
        groups: list = []
        for k in range(N):
            index: dict = {}
            where.append({})
            groups.append([])
            for i in range(M):
                for ell in range(M):
                    key = (i,) + tuple(X[k, ell, i].tobytes()
                                       for X in (A, B, C, D) + extra)
                    if key not in index:
                        index[key] = len(groups[k])
                        groups[k].append((i, ell))
                    where[k][(ell, i)] = index[key]
        G = max(map(len, groups))
        # unreachable copies keep the shape (N, G): no flow enters them
        padded = [g + [g[-1]] * (G - len(g)) for g in groups]
        return A, B, C, D, where, padded, record

    def merged(self) -> "JumpPlant":
        """The same plant with coinciding modes merged.

        (:ref:`theory-synthesis`, merged form.)

        Returns
        -------
        JumpPlant
            Same ``E``, fewer modes where modes coincide.
        """
        if self.transition is not None or self.Gw is not None or \
                self.constraint is not None:
            # Markov modes are not merged (theory: Markov losses), nor modes
            # that Gw tells apart as previous modes, nor a budget's
            return self
        mats = [getattr(self, f) for f in self._FIELDS]
        per_mode = [X for X in (self.E, self.Ew) if X is not None
                    and X.ndim == 4]
        groups, nominal = merge_groups(mats + per_mode, self.probabilities,
                                       self.nominal)
        merged, p = apply_groups(mats + per_mode, self.probabilities, groups)
        changes: dict[str, Any] = dict(zip(self._FIELDS, merged))
        if self.E.ndim == 4:
            changes["E"] = merged[6]
            if self.Ew is not None and self.Ew.ndim == 4:
                changes["Ew"] = merged[7]
        return replace(self, probabilities=p, nominal=nominal, **changes)

    def mean(self) -> tuple[np.ndarray, ...]:
        """Per-phase mean matrices ``Σ_i p_ki X_ki`` of every field.

        Returns
        -------
        A, Bu, Bw, Cz, Du, Dw : ndarray, each shape (N, ., .)
            In the order of the attributes, as :meth:`Modes.mean`.

        Raises
        ------
        ControlArgument
            Over a loss budget (no probabilities, no mean).
        """
        self._refuse_budget("mean()")
        p = self.probabilities
        return tuple(np.einsum("km,kmij->kij", p, getattr(self, f))
                     for f in self._FIELDS)

    def known_coordinates(self, k: int) -> np.ndarray:
        """Coordinates of ``ξ`` the controller sees at phase ``k``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray of int
            Indices of the columns of ``E_k`` that are not zero (in some
            mode, when the reading is per mode).
        """
        Ek = self.E[k % self.period]
        return np.flatnonzero(np.any(Ek != 0, axis=tuple(range(Ek.ndim - 1))))

    def active_inputs(self, k: int) -> np.ndarray:
        """Control inputs that can act at phase ``k``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray of int
            Indices of the columns of ``Bu`` or ``Du`` nonzero in some mode.
        """
        k %= self.period
        used = np.any(self.Bu[k] != 0, axis=(0, 1)) | np.any(self.Du[k] != 0,
                                                             axis=(0, 1))
        return np.flatnonzero(used)

    def is_selection(self) -> bool:
        """True when every ``E_k`` is a 0/1 coordinate selection.

        Returns
        -------
        bool
            Whether each row and each column of every ``E_k`` holds at most
            one 1 and otherwise zeros (required by synthesis).
        """
        E = self.E
        if E.ndim == 4:         # one reading per mode: not a phase selection
            return False
        binary = np.all((E == 0) | (E == 1))
        return bool(binary and np.all(E.sum(axis=2) <= 1)
                    and np.all(E.sum(axis=1) <= 1))

    def __repr__(self) -> str:
        s = self.shape
        return (f"<JumpPlant: {s['nx']} states, {s['nw']} w, {s['nz']} z, "
                f"{s['nu']} u, period {self.period}, "
                f"{self.probabilities.shape[1]} modes"
                f"{'' if self.constraint is None else ' over a loss budget'}, "
                f"controller={self.controller!r}, actuator={self.actuator!r}>")
