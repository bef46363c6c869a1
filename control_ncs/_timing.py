"""Sub-sample timing of a sampled continuous plant: when the sample is
taken and when the command is applied within the period
(:ref:`theory-delays`, :ref:`theory-sampling-jitter`).

:class:`InputDelay` holds the joint pmf of the pairs ``(s, τ)`` and the
sampled matrices each pair needs (:func:`input_delay_sampling` for the
delayed hold, the state at the late sample); :func:`parse_timing` reads
``nss``'s ``input_delay=`` and ``timing=``; :func:`timing_chain` is the
pairs as a chain of the loop's modes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
import scipy.linalg
from control.exception import ControlArgument, ControlDimension

from ._checks import real_array
from .links import LinkChain

__all__: list[str] = []


@dataclass(frozen=True, eq=False)
class InputDelay:
    """Sub-sample timing of a sampled continuous plant.

    The measurement of period ``k`` is sampled ``s`` after ``kh`` and the
    command computed from it is applied ``τ`` after ``kh`` (``0 ≤ s ≤ τ <
    h``), the pair ``(s, τ)`` drawn i.i.d. from a joint pmf; then
    ``x[k+1] = Φ x[k] + B1 w[k] + Γ0(τ) u[k] + Γ1(τ) u[k-1]`` and
    ``y[k] = C2 x(kh + s)`` with ``x(kh + s) = e^{As} x[k] + Γs u[k-1] +
    Γws w[k]`` (the noise held over the period; in continuous time the
    noise gathered until the sample, :ref:`theory-delays`,
    :ref:`theory-sampling-jitter`; :func:`input_delay_sampling`). Made by
    :func:`nss` with ``input_delay=(taus, probabilities)`` (``s = 0``) or
    ``timing=(pairs, probabilities)``.

    Attributes
    ----------
    taus, probabilities : ndarray, shape (M,)
    gamma0, gamma1 : ndarray, shape (M, n, ncon)
    samples : ndarray, shape (M,)
        The sampling delays ``s`` (zeros without sampling jitter).
    sample_state, sample_input, sample_noise : ndarray
        Shapes (M, n, n), (M, n, ncon), (M, n, nw): ``e^{As}``, ``Γs =
        ∫_0^s e^{Ar} dr B2`` and ``Γws = ∫_0^s e^{Ar} dr B1``, the state at
        the sample from the state, the held input and the held noise.

    Examples
    --------
    >>> import control as ct
    >>> import control_ncs as ncs
    >>> G = ct.ss([[-1.0]], [[0.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
    ...           [0.0, 0.0]])
    >>> P = ncs.nss(G, nmeas=1, ncon=1, dt=0.5,
    ...             input_delay=([0.0, 0.25], [0.5, 0.5]))
    >>> P.input_delay.gamma1[:, 0, 0].round(4).tolist()
    [0.0, 0.1723]
    >>> Q = ncs.nss(G, nmeas=1, ncon=1, dt=0.5,
    ...             timing=([(0.0, 0.0), (0.1, 0.25)], [0.5, 0.5]))
    >>> Q.input_delay.samples.tolist(), Q.input_delay.late
    ([0.0, 0.1], True)
    """

    taus: np.ndarray
    probabilities: np.ndarray
    gamma0: np.ndarray
    gamma1: np.ndarray
    samples: np.ndarray | None = None
    sample_state: np.ndarray | None = None
    sample_input: np.ndarray | None = None
    sample_noise: np.ndarray | None = None

    @property
    def late(self) -> bool:
        """True when some sample is taken after the period's start."""
        return self.samples is not None and bool(np.any(self.samples > 0))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, InputDelay) and all(
            _same(getattr(self, f), getattr(other, f))
            for f in ("taus", "probabilities", "gamma0", "gamma1", "samples",
                      "sample_state", "sample_input", "sample_noise"))

    __hash__ = None  # type: ignore[assignment]


def _same(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is b
    return bool(np.array_equal(a, b))


def parse_timing(sys: ct.StateSpace, continuous: bool, h: Any, value: Any,
                 ncon: Any, name: str = "input_delay") -> InputDelay:
    """``input_delay=(taus, probabilities)`` or ``timing=(pairs,
    probabilities)`` of ``nss`` as an InputDelay."""
    what = "taus" if name == "input_delay" else "pairs"
    if not continuous:
        raise ValueError(f"{name}: sub-sample timing needs the "
                         f"continuous-time plant and dt=h (nss samples it)")
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError(f"{name}: expected ({what}, probabilities), got "
                         f"{value!r}")
    if name == "input_delay":
        taus = real_array(value[0], "input_delay taus", ndim=(0, 1)).ravel()
        samples = np.zeros_like(taus)
    else:
        pairs = real_array(value[0], "timing pairs", ndim=(1, 2))
        if pairs.ndim == 1 and pairs.size == 2:
            pairs = pairs[None]
        if pairs.ndim != 2 or pairs.shape[1] != 2:
            raise ControlDimension(f"timing: expected pairs (s, tau) of shape "
                                   f"(M, 2), got {pairs.shape}")
        samples, taus = pairs[:, 0].copy(), pairs[:, 1].copy()
        if np.any(samples < 0) or np.any(samples > taus):
            raise ValueError(f"timing: each pair (s, tau) needs 0 <= s <= "
                             f"tau (the sample before the actuation), got "
                             f"{pairs.tolist()}")
    probs = real_array(value[1], f"{name} probabilities",
                       ndim=(0, 1)).ravel()
    if taus.size != probs.size or taus.size == 0:
        raise ControlDimension(f"{name}: {taus.size} {what} and "
                               f"{probs.size} probabilities")
    if np.any(probs < 0) or abs(probs.sum() - 1.0) > 1e-9:
        raise ValueError(f"{name}: the probabilities must be >= 0 and "
                         f"sum to 1, got {probs.tolist()}")
    if not isinstance(ncon, (int, np.integer)) or isinstance(ncon, bool) \
            or not 0 < ncon <= sys.ninputs:
        raise ControlArgument(f"ncon: {name} needs the number of "
                              f"controls ncon")
    A, B = np.asarray(sys.A, float), np.asarray(sys.B, float)
    m1 = sys.ninputs - ncon
    try:
        _, G0, G1 = input_delay_sampling(A, B[:, m1:], float(h), taus)
    except ValueError as err:
        raise ValueError(f"{name}: {err}") from None
    # the state at the sample: e^{As} x + ∫_0^s e^{Ar} dr [B1 B2] [w; u_prev]
    flows = [_zoh(A, B, float(t)) for t in samples]
    Es = np.array([E for E, _ in flows])
    Gs = np.array([G for _, G in flows])
    return InputDelay(taus, probs, G0, G1, samples, Es, Gs[:, :, m1:],
                      Gs[:, :, :m1])


def _zoh(A: np.ndarray, B: np.ndarray, t: float
         ) -> tuple[np.ndarray, np.ndarray]:
    """``(e^{At}, ∫_0^t e^{As} ds B)`` from one exponential of ``[[A, B],
    [0, 0]] t``."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(M * t)
    return E[:n, :n], E[:n, n:]


def timing_chain(delay: Any, N: int, ahead: bool) -> LinkChain:
    """The sub-sample timing as a chain over the pairs ``(s, τ)``, i.i.d.
    with their joint pmf, emitting ``c·M + d``: ``c`` the pair of the
    period (its ``τ`` delays the input), ``d`` the pair whose ``s`` delays
    the sample the mode reads. The static gain reads this period's sample
    (``d = c``). A controller with memory reads, at the end of step ``k``,
    the sample of period ``k + 1``: when the sampling delays differ, the
    chain runs on consecutive pairs ``(c, d)`` (Markov: ``(c, d) → (d,
    e)`` with probability ``p_e``), so that a joint pmf keeps its
    dependence between ``s`` and ``τ`` of one period."""
    p = np.asarray(delay.probabilities, float)
    M = p.size
    if not ahead or np.unique(delay.samples).size == 1:
        return LinkChain(np.tile(p, (N, M, 1)),
                         np.tile(np.arange(M) * (M + 1), (N, 1)),
                         M * M - 1, tuple(f"timing {i}" for i in range(M)))
    T = np.zeros((M * M, M * M))
    for c in range(M):
        for d in range(M):
            T[c * M + d, d * M:(d + 1) * M] = p
    return LinkChain(np.tile(T, (N, 1, 1)), np.tile(np.arange(M * M), (N, 1)),
                     M * M - 1, tuple(f"timing {c},{d}" for c in range(M)
                                      for d in range(M)))


def input_delay_sampling(A: Any, B: Any, h: float, taus: Any
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sampled ``ẋ = A x + B u`` whose input is applied ``τ`` late.

    The input computed at sample ``k`` is applied ``τ ∈ [0, h)`` after it,
    so over one period the previous input acts first
    (:ref:`theory-delays`, sub-sample delays)::

        x[k+1] = Φ x[k] + Γ0(τ) u[k] + Γ1(τ) u[k-1]
        Φ = e^{A h},  Γ0(τ) = ∫_0^{h-τ} e^{A s} ds B,
        Γ1(τ) = e^{A (h-τ)} ∫_0^τ e^{A s} ds B

    from one matrix exponential of ``[[A, B], [0, 0]]`` per interval.

    Parameters
    ----------
    A, B : array_like
        The continuous-time dynamics and input matrices.
    h : float
        The sampling period.
    taus : array_like, shape (M,)
        The delays, each in ``[0, h)``.

    Returns
    -------
    Phi : ndarray, shape (n, n)
    Gamma0, Gamma1 : ndarray, shape (M, n, m)
    """
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    n, m = B.shape
    taus = np.atleast_1d(np.asarray(taus, float))
    if not np.all((taus >= 0) & (taus < h)):
        raise ValueError(f"taus: expected delays in [0, h) with h = {h}, "
                         f"got {taus.tolist()}")

    def flow(t: float) -> tuple[np.ndarray, np.ndarray]:
        # expm([[A, B], [0, 0]] t) = [[e^{At}, ∫_0^t e^{As} ds B], [0, I]]
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        E = scipy.linalg.expm(M * t)
        return E[:n, :n], E[:n, n:]

    Phi, _ = flow(h)
    Gamma0 = np.empty((taus.size, n, m))
    Gamma1 = np.empty((taus.size, n, m))
    for i, tau in enumerate(taus):
        Erest, Gamma0[i] = flow(h - tau)
        Gamma1[i] = Erest @ flow(tau)[1]
    return Phi, Gamma0, Gamma1
