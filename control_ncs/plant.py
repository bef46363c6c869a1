"""The generalized plant with its network (:ref:`theory-plant`,
:ref:`theory-network`; paper eq. 1-2)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import scipy.linalg
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._checks import discrete_dt, flag, matrix, no_extra_kwargs
from .exceptions import ScheduleWarning
from .automata import LossAutomaton
from .delays import BurstyDelay, delay_model
from .network import (GilbertElliott, budget_loss, common_period, link_model,
                      mode_probabilities, mode_transition, schedule,
                      warn_silent_nodes)
# the sampled delayed hold is importable from the plant module too
from ._timing import InputDelay, parse_timing
from ._timing import input_delay_sampling as input_delay_sampling

__all__ = ["NetworkedStateSpace", "nss", "InputDelay"]


class NetworkedStateSpace(ct.StateSpace):
    """A generalized plant whose signals travel over a network.

    The StateSpace matrices are the plant of paper eq. 1 in the layout of
    :func:`control.hinfsyn`::

        x⁺ = A x + B1 w + B2 u        inputs  [w; u],  u = last ncon
        z  = C1 x + D11 w + D12 u     outputs [z; y],  y = last nmeas
        y  = C2 x + D21 w             (D22 = 0)

    The network (:ref:`theory-network`): at time ``t`` only the sensors in
    ``sensor_schedule`` phase ``t mod N`` send, in one packet lost with
    probability ``sensor_loss``; the controller's packet reaches the
    actuators of ``actuator_schedule`` unless lost (``actuator_loss``).
    Each link loses packets i.i.d. (Bernoulli, a float) or in bursts (a
    Gilbert–Elliott chain, :ref:`theory-markov`); the two links are
    independent. The matrices are read-only: the network was validated against
    them.

    Use :func:`nss` to create one.

    Parameters
    ----------
    A, B, C, D : array_like
        Plant matrices with inputs ``[w; u]`` and outputs ``[z; y]``.
    dt : True or float > 0
        Sampling period; continuous-time plants are rejected (discretize
        with :func:`control.sample_system` first).
    nmeas, ncon : int
        Number of measured outputs ``y`` (last outputs) and control inputs
        ``u`` (last inputs), as in :func:`control.hinfsyn`. Required
        (keyword-only; a missing one raises ``ControlArgument``).
    sensor_schedule, actuator_schedule : None, index vector or 0/1 matrix
        See :func:`control_ncs.network.schedule`. ``None``: everyone sends at
        every step.
    sensor_loss, actuator_loss : float in [0, 1], GilbertElliott, 2x2 array or LossAutomaton
        ``α1 = P(θ1 = 0)`` and ``α2 = P(θ2 = 0)`` (paper notation), or a
        bursty link: :func:`control_ncs.gilbert_elliott` or its transition
        matrix (rows: from lost, from delivered). Or a loss budget without
        probabilities (:ref:`theory-worst-case`): a
        :class:`~control_ncs.LossAutomaton` such as
        :func:`control_ncs.weakly_hard` or
        :func:`control_ncs.max_consecutive_losses`, whose allowed patterns
        count the link's transmissions (a phase that sends nothing takes
        no step of the budget). The loop over a budget is a
        :class:`~control_ncs.ConstrainedLoop`, analysed for every allowed
        pattern by :func:`control_ncs.jsr`. A budget beside a delay on the
        same link is refused (a budget counts lost transmissions; a delay
        law delivers them late, by chance).
    shared_channel : bool
        If True, at most one message crosses the network per step: no phase
        may schedule a sensor and an actuator together (paper §2).
    sensor_delay, actuator_delay : RandomDelay, BurstyDelay or array_like, optional
        Random integer delays on the link, the freshest packet winning
        (:func:`control_ncs.random_delay`, or its pmf
        ``[P(δ = 0), P(δ = 1), …]``, or :func:`control_ncs.bursty_delay`;
        :ref:`theory-delays`). A loss on the same link composes with the
        delay (:ref:`theory-links-compose`): a packet is lost with
        probability ``sensor_loss``, else delayed by the pmf, whose own
        ``1 - Σ pmf`` is lost too; the link's total loss is
        ``1 - (1 - α)(1 - (1 - Σ pmf))``. A Gilbert–Elliott loss on a
        delayed link, or a loss beside a bursty delay, is refused (write
        the laws per channel state with ``bursty_delay``). One packet
        carries every node's value, so a schedule may only let all nodes
        of the link send together or none (the age chain is then
        periodic). Every combination with the other link, the schedules
        and the controllers composes into one loop
        (:func:`control_ncs.feedback`).
    input_delay : InputDelay, optional
        Sub-sample delays of the control input (and of the sample); give
        ``input_delay=(taus, probabilities)`` or ``timing=(pairs,
        probabilities)`` to :func:`nss` with a continuous-time plant,
        which computes this object.
    continuous : control.StateSpace or (A, B, C, D), optional
        The continuous-time generalized plant these matrices sample with a
        zero-order hold at ``dt`` (:func:`nss` sets it), for the cost
        between the samples (:func:`control_ncs.cost`). Checked against
        ``A, B, C, D``: give ``continuous=None`` with new matrices.
    name, inputs, outputs, states : optional
        As for :class:`control.StateSpace`.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Attributes
    ----------
    nmeas, ncon : int
        Numbers of measured outputs and control inputs.
    sensor_schedule, actuator_schedule : Schedule
        Both written over the common ``period``.
    sensor_loss, actuator_loss : float
        Loss probabilities ``α1`` and ``α2`` of each link (stationary ones
        for a bursty link; a delay law's own loss included). For a loss
        budget: not a probability, the largest long-run fraction of the
        link's transmissions the budget allows to be lost (the maximum
        cycle mean of its losses, ``misses / window`` for
        ``weakly_hard(misses, window)``).
    sensor_link, actuator_link : float, GilbertElliott or LossAutomaton
        The loss models as given (a matrix becomes a GilbertElliott).
    shared_channel : bool
        Whether at most one message crosses the network per step.
    sensor_delay, actuator_delay : RandomDelay, BurstyDelay or None
        The delay models as given (None: no delay).
    input_delay : InputDelay or None
        Sub-sample delays of the control input and of the sample (made by
        :func:`nss`).
    continuous : control.StateSpace or None
        The continuous-time plant that was sampled (None: a discrete plant).
    period : int
        Least common multiple of the two schedules' periods.

    Examples
    --------
    A scalar plant ``x⁺ = 2x + w + u`` with ``z = x``, measured ``y = x``;
    the actuator may act at even steps only:

    >>> P = ncs.NetworkedStateSpace([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...                         [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...                         actuator_schedule=[1, 0], sensor_loss=0.1)
    >>> P.period, P.B2.tolist(), P.disturbance_labels
    (2, [[1.0]], ['w[0]'])
    >>> P.actuator_schedule.senders(1).tolist()
    []
    """

    def __init__(self, A: Any, B: Any, C: Any, D: Any, dt: Any = True, *,
                 nmeas: int | None = None, ncon: int | None = None,
                 sensor_schedule: Any = None,
                 actuator_schedule: Any = None, sensor_loss: float = 0.0,
                 actuator_loss: float = 0.0, shared_channel: bool = False,
                 sensor_delay: Any = None, actuator_delay: Any = None,
                 input_delay: InputDelay | None = None,
                 continuous: Any = None,
                 name: str | None = None, inputs: Any = None,
                 outputs: Any = None, states: Any = None, **kwargs: Any):
        no_extra_kwargs("NetworkedStateSpace", kwargs)
        dt = discrete_dt(dt)
        A = matrix(A, "A", (None, None))
        n = A.shape[0]
        if A.shape != (n, n):
            raise ControlDimension(f"A: expected a square matrix, got {A.shape}")
        B = matrix(B, "B", (n, None))
        C = matrix(C, "C", (None, n))
        D = matrix(D, "D", (C.shape[0], B.shape[1]))
        ninputs, noutputs = B.shape[1], C.shape[0]
        self.ncon = _count(ncon, "ncon", ninputs, "inputs")
        self.nmeas = _count(nmeas, "nmeas", noutputs, "outputs")
        p1 = noutputs - self.nmeas
        m1 = ninputs - self.ncon
        split = (f"with {ninputs} inputs [w; u] and {noutputs} outputs "
                 f"[z; y], ncon = {self.ncon} and nmeas = {self.nmeas} give "
                 f"dim w = {m1} and dim z = {p1} (u and y are the last "
                 f"ncon inputs and nmeas outputs)")
        for arg, dim, what in (("ncon", m1, "disturbance input w"),
                               ("nmeas", p1, "performance output z")):
            if dim == 0:
                raise ControlDimension(
                    f"{arg}: {split}; the closed loop needs at least one "
                    f"{what} (add a zero column or row if there is none)")
        if np.any(D[p1:, m1:] != 0):
            raise ValueError(f"D: the measured outputs y must not depend on "
                             f"the control inputs (D22 = 0 is required, "
                             f"theory: plant); {split}: check nmeas and ncon")
        self.sensor_schedule = schedule(sensor_schedule, self.nmeas,
                                        "sensor_schedule")
        self.actuator_schedule = schedule(actuator_schedule, self.ncon,
                                          "actuator_schedule")
        labels = (list(outputs)[p1:] if outputs is not None
                  and not isinstance(outputs, str)
                  and len(list(outputs)) == noutputs
                  else [f"y[{i}]" for i in range(self.nmeas)])
        warn_silent_nodes(self.sensor_schedule, "sensor", labels)
        labels = (list(inputs)[m1:] if inputs is not None
                  and not isinstance(inputs, str)
                  and len(list(inputs)) == ninputs
                  else [f"u[{i}]" for i in range(self.ncon)])
        warn_silent_nodes(self.actuator_schedule, "actuator", labels)
        period = common_period(self.sensor_schedule, self.actuator_schedule)
        self.sensor_schedule = self.sensor_schedule.repeat(period)
        self.actuator_schedule = self.actuator_schedule.repeat(period)
        self.sensor_link = link_model(sensor_loss, "sensor_loss")
        self.actuator_link = link_model(actuator_loss, "actuator_loss")
        self.sensor_loss, self.actuator_loss = (
            x.loss if isinstance(x, GilbertElliott) else
            budget_loss(x) if isinstance(x, LossAutomaton) else x
            for x in (self.sensor_link, self.actuator_link))
        self.shared_channel = flag(shared_channel, "shared_channel")
        if input_delay is not None and not isinstance(input_delay,
                                                      InputDelay):
            raise ControlArgument(
                "input_delay: give (taus, probabilities) to nss() with a "
                "continuous-time plant and dt=h; it computes the sampled "
                "model")
        if input_delay is not None and (
                input_delay.gamma0.shape[1:] != (n, self.ncon)):
            raise ControlDimension(
                f"input_delay: its matrices are for {input_delay.gamma0.shape[1]} "
                f"states and {input_delay.gamma0.shape[2]} controls, the plant "
                f"has {n} and {self.ncon}")
        self.input_delay = input_delay
        self.sensor_delay = delay_model(sensor_delay, "sensor_delay")
        self.actuator_delay = delay_model(actuator_delay, "actuator_delay")
        self._compose_links()
        if self.shared_channel:
            both = (self.sensor_schedule.pattern.any(axis=1)
                    & self.actuator_schedule.pattern.any(axis=1))
            if both.any():
                k = np.flatnonzero(both).tolist()
                raise ValueError(
                    "shared_channel: only one message may cross the network per "
                    f"step, but phases {k} schedule a sensor and an actuator "
                    "together (sensor_schedule[k] != 0 requires "
                    "actuator_schedule[k] == 0)")
        self._m1, self._p1 = m1, p1
        if inputs is None:
            inputs = [f"w[{i}]" for i in range(m1)] + \
                [f"u[{i}]" for i in range(self.ncon)]
        if outputs is None:
            outputs = [f"z[{i}]" for i in range(p1)] + \
                [f"y[{i}]" for i in range(self.nmeas)]
        super().__init__(A, B, C, D, dt, name=name, inputs=inputs,
                         outputs=outputs, states=states)
        # the network settings were validated against these matrices: they
        # may not change afterwards (a NaN written into D would surface deep
        # inside an analysis)
        for X in (self.A, self.B, self.C, self.D):
            X.setflags(write=False)
        self.continuous = _continuous(continuous, self)

    def _compose_links(self) -> None:
        """Refuse a link combination no chain models; a loss and a delay on
        one link compose (theory: links compose): the link's loss is the
        total one."""
        for side, delay in (("sensor", self.sensor_delay),
                            ("actuator", self.actuator_delay)):
            if delay is None:
                continue
            link = getattr(self, f"{side}_link")
            if isinstance(link, LossAutomaton):
                raise ControlArgument(
                    f"{side}_loss: a loss budget beside a delay on the same "
                    f"link has no model here: the budget counts lost "
                    f"transmissions, the delay law delivers packets late by "
                    f"chance (is a late packet lost for the budget?); give "
                    f"the {side} link either the budget or the delay")
            if isinstance(link, GilbertElliott):
                raise ControlArgument(
                    f"{side}_loss: a bursty (Gilbert–Elliott) loss on a "
                    f"delayed link has no finite chain (a packet lost while "
                    f"the channel is bad, delayed otherwise, needs the "
                    f"channel's past); give the delay law of each channel "
                    f"state instead: {side}_delay=ncs.bursty_delay(link, "
                    f"pmf_bad, pmf_good)")
            if isinstance(delay, BurstyDelay) and link:
                raise ControlArgument(
                    f"{side}_loss: a loss beside a bursty delay is not a "
                    f"thinning of one law (the channel state sets the "
                    f"arrivals); put the losses in bursty_delay's laws "
                    f"(pmf_bad, pmf_good summing to less than 1) and give "
                    f"{side}_loss=0")
            pattern = getattr(self, f"{side}_schedule").pattern
            if not np.all(pattern.all(axis=1) | ~pattern.any(axis=1)):
                raise ValueError(
                    f"{side}_delay: a delayed link carries one packet with "
                    f"every {side}'s value; its schedule must let all "
                    f"{side}s send together or none at each phase")
            # a loss and a delay on one link compose: a packet is lost with
            # probability α, else delayed by the pmf (theory: links compose)
            total = 1.0 - (1.0 - float(link)) * (1.0 - delay.loss)
            if side == "sensor":
                self.sensor_loss = total
            else:
                self.actuator_loss = total

    # -- partition (theory: plant) --------------------------------------------
    @property
    def period(self) -> int:
        """Common period ``N`` of the schedules."""
        return self.sensor_schedule.period

    @property
    def B1(self) -> np.ndarray:
        """Disturbance input matrix (columns of ``B`` for ``w``)."""
        return self.B[:, :self._m1]

    @property
    def B2(self) -> np.ndarray:
        """Control input matrix (columns of ``B`` for ``u``)."""
        return self.B[:, self._m1:]

    @property
    def C1(self) -> np.ndarray:
        """Performance output matrix (rows of ``C`` for ``z``)."""
        return self.C[:self._p1]

    @property
    def C2(self) -> np.ndarray:
        """Measurement matrix (rows of ``C`` for ``y``)."""
        return self.C[self._p1:]

    @property
    def D21(self) -> np.ndarray:
        """Feedthrough from ``w`` to ``y``: measurement noise, references."""
        return self.D[self._p1:, :self._m1]

    @property
    def D11(self) -> np.ndarray:
        """Feedthrough from ``w`` to ``z``."""
        return self.D[:self._p1, :self._m1]

    @property
    def D12(self) -> np.ndarray:
        """Feedthrough from ``u`` to ``z``."""
        return self.D[:self._p1, self._m1:]

    @property
    def disturbance_labels(self) -> list[str]:
        """Names of the exogenous inputs ``w``."""
        return list(self.input_labels[:self._m1])

    @property
    def performance_labels(self) -> list[str]:
        """Names of the performance outputs ``z``."""
        return list(self.output_labels[:self._p1])

    def mode_probabilities(self) -> dict:
        """``{(θ1, θ2): probability}`` of the four network modes (eq. 14).

        Returns
        -------
        dict
            Keys ``(θ1, θ2)`` with ``θ = 1`` for a message that arrives.

        Examples
        --------
        >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
        ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, sensor_loss=0.5)
        >>> P.mode_probabilities()[(1, 1)]
        0.5
        """
        self._refuse_budget("mode_probabilities()")
        return mode_probabilities(self.sensor_loss, self.actuator_loss)

    @property
    def is_iid(self) -> bool:
        """True when both links lose packets i.i.d. (Bernoulli).

        False over a loss budget: its patterns have no probabilities."""
        return all(not isinstance(x, (GilbertElliott, LossAutomaton))
                   or (isinstance(x, GilbertElliott) and x.is_bernoulli)
                   for x in (self.sensor_link, self.actuator_link))

    def _refuse_budget(self, what: str) -> None:
        """Raise ``ControlArgument`` for a probability asked of a budget."""
        for side in ("sensor", "actuator"):
            link = getattr(self, f"{side}_link")
            if isinstance(link, LossAutomaton):
                raise ControlArgument(
                    f"P: {what} needs probabilities, but the {side} link is a "
                    f"loss budget ({link.name}) without any; close the loop "
                    f"(feedback) and analyse it for every allowed pattern "
                    f"with ncs.jsr")

    def mode_transition(self) -> np.ndarray | None:
        """Transition matrix of the four network modes, or None.

        Modes in eq. 14 order; None when both links are i.i.d.
        (:ref:`theory-markov`).

        Returns
        -------
        ndarray of shape (4, 4) or None
            ``T[i, j] = P(mode j next | mode i now)``; the links are
            independent chains (Kronecker product).

        Examples
        --------
        >>> from control_ncs import gilbert_elliott
        >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
        ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
        ...         actuator_loss=ncs.gilbert_elliott(fail=0.1, recover=0.5))
        >>> P.mode_transition()[3].round(3).tolist()
        [0.0, 0.1, 0.0, 0.9]
        """
        self._refuse_budget("mode_transition()")
        if self.is_iid:
            return None
        return mode_transition(self.sensor_link, self.actuator_link)

    def with_network(self, **changes: Any) -> "NetworkedStateSpace":
        """A copy with some network settings changed.

        Parameters
        ----------
        **changes
            Any keyword of :class:`NetworkedStateSpace` (network settings,
            matrices, names); others raise ``TypeError``.

        Returns
        -------
        NetworkedStateSpace
            Validated afresh; ``self`` is unchanged.

        Examples
        --------
        >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
        ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
        >>> P.with_network(actuator_loss=0.3).actuator_loss, P.actuator_loss
        (0.3, 0.0)
        """
        args = self._init_args()
        unknown = set(changes) - set(args)
        if unknown:
            raise TypeError(f"with_network() got unexpected keyword argument(s): "
                            f"{', '.join(sorted(unknown))}")
        args.update(changes)
        return NetworkedStateSpace(**args)

    def _init_args(self) -> dict:
        return dict(A=self.A, B=self.B, C=self.C, D=self.D, dt=self.dt,
                    nmeas=self.nmeas, ncon=self.ncon,
                    sensor_schedule=self.sensor_schedule.pattern.astype(int),
                    actuator_schedule=self.actuator_schedule.pattern.astype(int),
                    sensor_loss=self.sensor_link,
                    actuator_loss=self.actuator_link,
                    shared_channel=self.shared_channel,
                    sensor_delay=self.sensor_delay,
                    actuator_delay=self.actuator_delay,
                    input_delay=self.input_delay,
                    continuous=self.continuous, name=self.name,
                    inputs=list(self.input_labels),
                    outputs=list(self.output_labels),
                    states=list(self.state_labels))

    # -- python protocol -----------------------------------------------------
    def __reduce__(self) -> tuple:
        # control.StateSpace holds lambdas and cannot be pickled: the
        # continuous plant travels as its matrices
        args = self._init_args()
        if self.continuous is not None:
            args["continuous"] = _matrices(self.continuous)
        return (_restore_nss, (args,))

    def equals(self, other: object) -> bool:
        """Whether ``other`` is the same networked plant, value by value.

        Parameters
        ----------
        other : object
            Anything; only a :class:`NetworkedStateSpace` can be equal.

        Returns
        -------
        bool
            Same matrices, partition, network and signal names.
        """
        if type(other) is not type(self):
            return False
        a, b = self._init_args(), other._init_args()
        ca, cb = a.pop("continuous"), b.pop("continuous")
        if (ca is None) != (cb is None) or (ca is not None and not all(
                np.array_equal(x, y)
                for x, y in zip(_matrices(ca), _matrices(cb)))):
            return False
        return all(np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray)
                   else a[k] == b[k] for k in a)

    # ``==`` and ``hash`` by identity, as every python-control system (see
    # JumpStateSpace): ct.interconnect and dicts key systems by object.
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    def __repr__(self) -> str:
        return (f"<NetworkedStateSpace {self.name}: {self.nstates} states, "
                f"w:{self._m1} u:{self.ncon} z:{self._p1} y:{self.nmeas}, "
                f"period {self.period}, α1={self.sensor_loss:g}, "
                f"α2={self.actuator_loss:g}{self._bursts()}"
                f"{self._delays()}, dt={self.dt}>")

    def _delays(self) -> str:
        """The delays in a few words: each link's largest delay (and its
        buffer when longer), and the sub-sample input delays."""
        out = ""
        for side in ("sensor", "actuator"):
            delay = getattr(self, f"{side}_delay")
            if delay is None:
                continue
            laws = delay.pmfs if isinstance(delay, BurstyDelay) \
                else (delay.pmf,)
            d = max(int(np.flatnonzero(q)[-1]) if np.any(q) else 0
                    for q in laws)
            kind = "bursty delays" if len(laws) == 2 else "delays"
            out += f", {side} {kind} 0..{d} steps"
            if delay.buffer != d:
                out += f" (buffer {delay.buffer})"
        if self.input_delay is not None:
            taus = self.input_delay.taus
            out += (f", input delays {taus.min():.4g}..{taus.max():.4g} s "
                    f"({taus.size} values)")
            if self.input_delay.late:
                s = np.asarray(self.input_delay.samples)
                out += f", sample delays {s.min():.4g}..{s.max():.4g} s"
        return out

    def _delay_lines(self) -> list[str]:
        """One line per delay model: the law, the buffer, and how the
        link's loss composes the loss given with the law's own."""
        lines = []
        for side, alpha in (("sensor", "α1"), ("actuator", "α2")):
            delay = getattr(self, f"{side}_delay")
            if delay is None:
                continue
            total = getattr(self, f"{side}_loss")
            if isinstance(delay, BurstyDelay):
                bad, good = (_numbers(q) for q in delay.pmfs)
                lines.append(
                    f"  {side} delay: bursty, {delay.link!r}; P(δ = c) while "
                    f"bad {bad}, while good {good}; buffer {delay.buffer} "
                    f"(the link's loss {alpha} = {total:.4g} is the laws' own)")
                continue
            given = float(getattr(self, f"{side}_link"))
            law = (f"  {side} delay: P(δ = c), c = 0..{delay.max_delay}: "
                   f"{_numbers(delay.pmf)}; buffer {delay.buffer}")
            if given and delay.loss:
                law += (f" (the link's loss {alpha} = {total:.4g} composes "
                        f"the loss {given:.4g} given and the law's own "
                        f"{delay.loss:.4g})")
            elif delay.loss:
                law += f" (the law's own loss {alpha} = {total:.4g})"
            lines.append(law)
        if self.input_delay is not None:
            lines.append(f"  input delay: τ = {_numbers(self.input_delay.taus)}"
                         f" s with probabilities "
                         f"{_numbers(self.input_delay.probabilities)}")
            if self.input_delay.late:
                lines.append(f"  sampled at s = "
                             f"{_numbers(self.input_delay.samples)} s "
                             f"(paired with the τ above)")
        return lines

    def _bursts(self) -> str:
        """The links' bursts and budgets, for ``repr`` and ``str`` (a
        budget's α is the largest long-run loss fraction it allows)."""
        out = []
        for i, what, x in ((1, "sensor", self.sensor_link),
                           (2, "actuator", self.actuator_link)):
            if isinstance(x, GilbertElliott) and not x.is_bernoulli:
                out.append(f", {what} bursts {x.burst:.4g}")
            elif isinstance(x, LossAutomaton):
                out.append(f", {what} budget '{x.name}' (α{i}: its worst "
                           f"long-run loss)")
        return "".join(out)

    def __str__(self) -> str:
        s1 = self.sensor_schedule.pattern.astype(int).tolist()
        s2 = self.actuator_schedule.pattern.astype(int).tolist()
        delays = "".join(line + "\n" for line in self._delay_lines())
        net = (f"NetworkedStateSpace: {self.name}\n"
               f"Network: period N = {self.period}, sensor loss α1 = "
               f"{self.sensor_loss:g}, actuator loss α2 = "
               f"{self.actuator_loss:g}{self._bursts()}"
               f"{', shared channel' if self.shared_channel else ''}\n"
               f"  sensor schedule (rows = phases): {s1}\n"
               f"  actuator schedule (rows = phases): {s2}\n"
               f"{delays}"
               f"Plant (nmeas = {self.nmeas}, ncon = {self.ncon}):\n")
        return net + ct.StateSpace.__str__(
            ct.StateSpace(self.A, self.B, self.C, self.D, self.dt,
                          inputs=self.input_labels, outputs=self.output_labels,
                          states=self.state_labels, name=self.name))


def _numbers(values: Any) -> str:
    """A short list of numbers for humans: four significant digits."""
    return "[" + ", ".join(f"{x:.4g}" for x in np.ravel(values)) + "]"


def _restore_nss(args: dict) -> NetworkedStateSpace:
    # the schedule was warned about when the plant was built
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScheduleWarning)
        return NetworkedStateSpace(**args)


def _matrices(sys: ct.StateSpace) -> tuple:
    return tuple(np.array(X, float) for X in (sys.A, sys.B, sys.C, sys.D))


def _continuous(value: Any, P: NetworkedStateSpace) -> ct.StateSpace | None:
    """``continuous=`` checked: a continuous-time plant whose zero-order-hold
    sampling at ``P.dt`` gives ``P``'s matrices (a copy is kept)."""
    if value is None:
        return None
    if isinstance(value, (tuple, list)) and len(value) == 4:
        value = ct.ss(*value)
    if not isinstance(value, ct.StateSpace) or not value.isctime(strict=True):
        raise ControlArgument(
            f"continuous: expected the continuous-time control.StateSpace "
            f"that was sampled, got {value!r}")
    if P.dt is True:
        raise ValueError("continuous: the sampled plant needs dt = h > 0")
    A, B, C, D = _matrices(value)
    if A.shape != P.A.shape or B.shape != P.B.shape or C.shape != P.C.shape:
        raise ControlDimension(
            f"continuous: {A.shape[0]} states, {B.shape[1]} inputs and "
            f"{C.shape[0]} outputs, the plant has {P.nstates}, {P.ninputs} "
            f"and {P.noutputs}")
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(M * float(P.dt))[:n]
    scale = 1.0 + np.abs(E).max()
    if not (np.allclose(E, np.hstack([P.A, P.B]), rtol=1e-9,
                        atol=1e-12 * scale)
            and np.array_equal(C, P.C) and np.array_equal(D, P.D)):
        raise ValueError(
            f"continuous: the plant's matrices are not its zero-order-hold "
            f"sampling at dt = {P.dt}; give continuous=None with new matrices")
    return ct.ss(A, B, C, D, name=value.name, inputs=value.input_labels,
                 outputs=value.output_labels, states=value.state_labels)


def _count(value: Any, name: str, total: int, what: str) -> int:
    if value is None:
        raise ControlArgument(f"{name}: required (number of {what} that belong "
                              f"to the controller, as in control.hinfsyn)")
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, np.integer)):
        raise ControlArgument(f"{name}: expected an int, got {value!r}")
    if not 1 <= value <= total:
        raise ControlDimension(f"{name}: expected 1 <= {name} <= {total} "
                               f"(the plant has {total} {what}), got {value}")
    return int(value)


def nss(*args: Any, **kwargs: Any) -> NetworkedStateSpace:
    """Create a networked generalized plant.

    ``nss(sys, nmeas=..., ncon=..., ...)`` or
    ``nss(A, B, C, D[, dt], nmeas=..., ncon=..., ...)``.

    Parameters
    ----------
    *args : control.StateSpace, or array_like A, B, C, D and optional dt
        Either one positional argument ``sys``, a generalized plant (a
        :class:`control.StateSpace`, or an LTI system converted with
        :func:`control.ss`) with inputs ``[w; u]`` and outputs ``[z; y]``,
        whose signal names and name are kept; or its discrete-time matrices
        ``A, B, C, D`` and optionally the sampling period ``dt`` (True or a
        float > 0, default True).
    **kwargs
        The keywords of :class:`NetworkedStateSpace`: ``nmeas`` and ``ncon``
        (required ints, the numbers of measurements ``y`` and controls
        ``u``, the last outputs and inputs); the network
        ``sensor_schedule``, ``actuator_schedule``, ``sensor_loss``,
        ``actuator_loss`` and ``shared_channel``; the delays
        ``sensor_delay`` and ``actuator_delay`` (a
        :func:`~control_ncs.random_delay`, its pmf ``[P(δ = 0), P(δ = 1),
        …]``, or a :func:`~control_ncs.bursty_delay`; the freshest packet
        wins, :ref:`theory-delays`), which compose with a loss on the same
        link: a packet is lost with probability ``sensor_loss``, else
        delayed by the pmf, whose own ``1 - Σ pmf`` is lost too, so
        ``P.sensor_loss`` is the link's total loss, ``P.sensor_link`` the
        loss model given and ``P.sensor_delay`` the delay model
        (:ref:`theory-links-compose`); and ``name``, ``inputs``,
        ``outputs``, ``states``. With a continuous-time ``sys``, ``dt=h``
        samples it with a zero-order hold (:func:`control.sample_system`),
        keeping ``sys`` as ``continuous`` (for the cost between the
        samples), and ``input_delay=(taus, probabilities)`` adds sub-sample
        delays of the control input: applied ``τ`` after the sample, ``τ``
        i.i.d. from ``taus`` in ``[0, h)`` (:class:`InputDelay`,
        :ref:`theory-delays`). ``timing=(pairs, probabilities)`` adds
        sampling jitter too: Jitterbug's timing of a period as a joint pmf
        over pairs ``(s, τ)``, ``0 ≤ s ≤ τ < h``, both measured from the
        period's start ``kh``: the measurement is sampled at ``kh + s``,
        the command applied at ``kh + τ``, the pair i.i.d. over the periods
        (independent sampling and computation delays are the product of
        their pmfs; a pair ``(0, τ)`` is ``input_delay``'s ``τ``;
        :ref:`theory-sampling-jitter`). Give one of the two. Anything else
        raises ``TypeError``.

    Returns
    -------
    NetworkedStateSpace

    Raises
    ------
    ValueError
        Continuous-time plant without ``dt``, matrices with complex, string, non-finite or
        overflowing (``> 1e150``) entries, bad schedule, a loss that is not
        a real number in ``[0, 1]`` (bools and strings included),
        ``D22`` nonzero (``D21``, noise or references in ``y``, is
        allowed), shared-channel conflicts; a delay pmf that is not
        probabilities, or a delay beyond ``MAX_BUFFER`` steps; a schedule
        that lets only some nodes of a delayed link send.
    ControlDimension
        Inconsistent shapes, ``nmeas``/``ncon`` out of range.
    ControlArgument
        ``nmeas``/``ncon`` missing or not an int; ``shared_channel`` not a
        bool; a Gilbert–Elliott loss on a delayed link, or a loss beside a
        bursty delay (write the laws per channel state instead).
    TypeError
        Unknown keyword.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).

    Examples
    --------
    The paper's schedule with two sensors, ``N = 4``:

    >>> P = ncs.nss([[1.1, 0.1], [0, 0.9]], [[1, 0], [0, 1]],
    ...         [[1, 0], [1, 0], [0, 1]], [[0.5, 0], [0, 0], [0, 0]],
    ...         nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2], sensor_loss=0.1)
    >>> P.period, [P.sensor_schedule.senders(k).tolist() for k in range(4)]
    (4, [[1], [0], [], [1]])

    A sensor link that loses 10 % of the packets and delays the others by
    up to two steps (the pmf's own loss is 10 % too):

    >>> Q = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, name="Q",
    ...             sensor_loss=0.1, sensor_delay=[0.5, 0.3, 0.1])
    >>> Q
    <NetworkedStateSpace Q: 1 states, w:1 u:1 z:1 y:1, period 1, α1=0.19, α2=0, sensor delays 0..2 steps, dt=True>
    >>> Q.sensor_link, Q.sensor_delay
    (0.1, RandomDelay(pmf=[0.5, 0.3, 0.1], buffer=2; loss=0.1))
    """
    if len(args) == 1:
        sys = args[0]
        if not isinstance(sys, ct.StateSpace):
            if isinstance(sys, ct.LTI):
                sys = ct.ss(sys)
            else:
                raise ControlArgument(f"sys: expected a control.StateSpace, got "
                                      f"{type(sys).__name__}")
        delays = kwargs.pop("input_delay", None)
        timing = kwargs.pop("timing", None)
        if delays is not None and timing is not None:
            raise ValueError("input_delay, timing: give one (timing's pairs "
                             "(0, τ) are input_delay's delays τ)")
        continuous = sys.isctime(strict=True)
        cont = sys
        sys = _sampled(sys, kwargs.pop("dt", None))
        if delays is not None:
            kwargs["input_delay"] = parse_timing(cont, continuous, sys.dt,
                                                 delays, kwargs.get("ncon"))
        if timing is not None:
            kwargs["input_delay"] = parse_timing(cont, continuous, sys.dt,
                                                 timing, kwargs.get("ncon"),
                                                 "timing")
        if continuous:
            kwargs.setdefault("continuous", cont)
        kwargs.setdefault("inputs", list(sys.input_labels))
        kwargs.setdefault("outputs", list(sys.output_labels))
        kwargs.setdefault("states", list(sys.state_labels))
        kwargs.setdefault("name", sys.name)
        return NetworkedStateSpace(sys.A, sys.B, sys.C, sys.D, sys.dt, **kwargs)
    if len(args) in (4, 5):
        return NetworkedStateSpace(*args, **kwargs)
    raise ControlArgument(f"nss: expected (sys) or (A, B, C, D[, dt]), got "
                          f"{len(args)} positional arguments")


def _sampled(sys: ct.StateSpace, dt: Any) -> ct.StateSpace:
    """A continuous-time plant sampled with a zero-order hold at ``dt``;
    a discrete-time one as it is (``dt`` must then be absent or equal)."""
    if dt is None:
        if sys.isctime(strict=True):
            raise ValueError(
                "dt: the plant is continuous-time; give the sampling period: "
                "nss(sys, ..., dt=h) samples it with a zero-order hold (or "
                "sample it first with control.sample_system(sys, h, method))")
        return sys
    h = discrete_dt(dt)
    if h is True:
        raise ValueError("dt: a continuous-time plant needs a sampling "
                         "period > 0 to be sampled, got True")
    if sys.isctime(strict=True):
        return ct.sample_system(sys, h, method="zoh", name=sys.name)
    if sys.dt is True or not np.isclose(float(sys.dt), h, rtol=1e-12,
                                        atol=0.0):
        raise ValueError(f"dt: the plant is discrete-time with dt = "
                         f"{sys.dt!r}; dt={dt!r} would resample it (sample "
                         f"a continuous-time plant instead)")
    return sys
