"""Monte Carlo sample paths and ensemble responses of a jump system.

A :class:`~control_ncs.jump.JumpStateSpace` (MATH §10) draws its mode
independently at every step. :func:`simulate` draws many such realisations
at once and returns them as a multi-trace :class:`control.TimeResponseData`
(one trace per trial). :func:`step_response`, :func:`impulse_response`,
:func:`initial_response` and :func:`forced_response` mirror python-control's
functions of the same names: they return an :class:`EnsembleResponse` with
the sample mean, quantile bands and, beside them, the *exact* mean and
standard deviation of MATH §7 (:func:`control_ncs.moments.moments`), so
that every picture shows how far sampling is from the truth.
:func:`plot_ensemble` draws the usual figure: exact mean, sample mean, band
and a few sample paths.

Random numbers
--------------
``seed`` (``None``, an int, a :class:`numpy.random.SeedSequence`, a bit
generator or a :class:`numpy.random.Generator`; never the global NumPy
state) is turned into a :class:`numpy.random.Generator` by
:func:`numpy.random.default_rng`, which draws four 63-bit integers of
entropy for the run (so a Generator passed in is advanced, and ``seed=5`` is
the same run as ``seed=numpy.random.default_rng(5)``). That entropy keys
three independent PCG64 streams -- modes, white noise, initial state -- and
trial ``i`` reads its own consecutive block of each stream (``T`` uniforms
for its modes, ``T·r`` for its noise, ``r = rank W``), reached by
:meth:`numpy.random.PCG64.advance`. Gaussians come from those uniforms by the
inverse normal CDF, so every draw costs exactly one word of its stream. Hence
a trial's path depends only on the seed and its index: the result does not
depend on ``chunk``, the first ``k`` trials of a run are the run with
``trials=k``, and adding noise does not change the mode sequences (common
random numbers when comparing designs).

Engine and memory
-----------------
Trials are processed in chunks of ``chunk`` trials, time step by time step
(no Python loop over trials). The modes of a phase differ by low rank (a
lost message removes a term ``B_u K``): with ``M_i - M_b = U_i V_i`` for the
base mode ``b`` (``M = [C D; A B]``), one step of all trials is the product
``[z; ξ⁺] = [M_b U] [ξ; w; s]`` with ``s = V_i [ξ; w]`` kept for the trials in
mode ``i`` and zeroed for the others -- no grouping of trials by mode. The
paths are stored time-major, one ``[ξ; w; s; z]`` × trials slab per step,
and each product writes ``z_t`` and ``ξ_{t+1}`` in place; the
``[signal, trial, time]`` arrays of :class:`SamplePaths` are views of that
storage, so every value is written once and never transposed or copied.
Besides its result, a run holds ``O(chunk · T · (1 + q + 2r))`` floats for
its random numbers (``q`` modes per phase besides the base mode), and an
ensemble response one chunk's storage.
:func:`simulate` returns every path (``trials · T · (n + p + m)`` floats,
plus ``rank`` rows of ``s`` per step); the ensemble responses keep only
``keep_paths`` full paths and accumulate mean and covariance chunk by chunk,
so their memory is bounded unless quantiles are asked for (exact quantiles
need every trial's outputs, ``p · trials · T`` floats; pass
``quantiles=()`` for bounded memory).
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Iterator, NamedTuple, Sequence

import numpy as np
import control as ct
import matplotlib.pyplot as plt
from control.exception import ControlArgument, ControlDimension
from scipy.special import ndtri

from ._checks import no_extra_kwargs, positive_int
from .jump import JumpStateSpace, as_jump
from .moments import (MomentsResponse, covariance, initial_mean, input_signal,
                      moments, real_values, time_grid)
from .stability import ms_radius

__all__ = ["simulate", "SamplePaths", "EnsembleResponse", "forced_response",
           "step_response", "impulse_response", "initial_response",
           "plot_ensemble", "default_steps", "tqdm_check"]

#: Streams keyed by the run's entropy (fixed: changing them changes results).
_MODES, _NOISE, _INITIAL = 0, 1, 2
#: Working memory of one chunk (its random numbers), in floats (32 MB).
_CHUNK_FLOATS = 1 << 22
#: Trials per chunk: one step touches its rows of the storage for every
#: trial of the chunk, ``rows × chunk`` floats, kept within a core's cache.
_STEP_FLOATS = 1 << 15
#: OpenBLAS multiplies on one thread up to m·n·k = 2**18 (default build) and
#: on all threads above. A product per step that waits for a second thread
#: stalls for whole scheduler slices on a busy machine (measured 5-80×
#: slower), so each product covers at most that many trials' columns (but
#: at least _MIN_COLUMNS, where call overhead would dominate).
_GEMM_SERIAL, _MIN_COLUMNS = 1 << 18, 16
#: Default horizon: steps until the mean-square transient has decayed by this
#: factor (an RMS factor of 1 %), within [_MIN_STEPS, _MAX_STEPS].
_SETTLE, _MIN_STEPS, _MAX_STEPS, _UNSTABLE_STEPS = 1e-4, 20, 1000, 50


@functools.cache
def tqdm_check() -> bool:
    """True when the optional package ``tqdm`` (progress bars) is installed."""
    try:
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


# -- the result types ---------------------------------------------------------
class SamplePaths(ct.TimeResponseData):
    """Sample paths of a jump system: a multi-trace time response.

    A :class:`control.TimeResponseData` with one trace per trial:
    ``outputs`` ``[output, trial, time]``, ``states`` ``[state, trial,
    time]`` and ``inputs`` ``[input, trial, time]``, where the inputs are the
    realised ``w`` of each trial (deterministic part plus sampled white
    noise), so that every path can be replayed. It differs from its base
    class only in :meth:`plot`'s defaults, and in memory layout: ``x``,
    ``y`` and ``u`` are views of one time-major array (see the module
    notes), not C-contiguous; ``numpy.ascontiguousarray`` makes a
    contiguous copy where one is needed. Any one of them keeps that whole
    array alive, including the scratch rows of the step (one per unit of
    rank by which the modes differ): to keep only the outputs of a large
    run, keep ``numpy.array(paths.outputs)``.

    Attributes
    ----------
    trials : int
        Number of sample paths (``ntraces``).
    """

    @property
    def trials(self) -> int:
        return self.ntraces

    def plot(self, *args: Any, paths: int | None = 20,
             **kwargs: Any) -> ct.ControlPlot:
        """Plot sample paths with :func:`control.time_response_plot`.

        Defaults differ from python-control's so that many traces stay
        readable: all trials overlaid in one axes per output
        (``overlay_traces=True``), thin solid lines, no legend, no inputs
        (pass ``plot_inputs=True`` to add them).

        Parameters
        ----------
        paths : int or None, optional
            Plot only the first ``paths`` trials (an int >= 1; default 20;
        None = all).
        *args, **kwargs
            Passed to :func:`control.time_response_plot`.

        Returns
        -------
        control.ControlPlot
        """
        paths = positive_int(paths, "paths", allow_none=True)
        data = self
        if paths is not None and paths < self.ntraces:
            data = _sample_paths(self.t, self.y[:, :paths], self.x[:, :paths],
                                 self.u[:, :paths], self)
        kwargs.setdefault("overlay_traces", True)
        kwargs.setdefault("plot_inputs", False)
        kwargs.setdefault("show_legend", False)
        if not args:
            kwargs.setdefault("trace_props", [
                {"linestyle": "-", "linewidth": 0.8, "alpha": 0.6}])
        return ct.time_response_plot(data, *args, **kwargs)


def _sample_paths(t, y, x, u, like) -> SamplePaths:
    n = y.shape[1]
    return SamplePaths(
        t, y, x, u, issiso=False, squeeze=False, multi_trace=True,
        output_labels=like.output_labels, state_labels=like.state_labels,
        input_labels=like.input_labels,
        trace_labels=[f"trial {i}" for i in range(n)],
        trace_types=["forced"] * n, plot_inputs=False, sysname=like.sysname,
        title=like.title)


@dataclass
class EnsembleResponse:
    """Monte Carlo statistics of a response, beside the exact moments.

    Statistics are over all ``trials``; arrays have time as the last axis.

    Attributes
    ----------
    time : ndarray, shape (T,)
    inputs : ndarray, shape (m, T)
        The deterministic part of ``w``.
    kind : str
        ``'step'``, ``'impulse'``, ``'initial'`` or ``'forced'``.
    trials : int
    quantiles : tuple of float
        Probabilities of :attr:`quantile_values`, ascending.
    sample_mean : ndarray, shape (p, T)
        Sample mean of the outputs.
    sample_cov : ndarray, shape (p, p, T)
        Sample covariance of the outputs (``ddof=1``; zero for one trial).
    quantile_values : ndarray, shape (len(quantiles), p, T)
        Sample quantiles of each output (``numpy.quantile``, linear).
    states_sample_mean : ndarray, shape (n, T)
    exact : MomentsResponse
        Exact mean and covariance (MATH §7) for the same inputs, initial
        state, noise and initial covariance.
    paths : SamplePaths
        The first ``keep_paths`` sample paths.
    title : str
    """

    time: np.ndarray
    inputs: np.ndarray
    kind: str
    trials: int
    quantiles: tuple
    sample_mean: np.ndarray
    sample_cov: np.ndarray
    quantile_values: np.ndarray
    states_sample_mean: np.ndarray
    exact: MomentsResponse
    paths: SamplePaths
    title: str = ""

    @property
    def sample_std(self) -> np.ndarray:
        """Sample standard deviation of each output, shape (p, T)."""
        return np.sqrt(np.maximum(np.einsum("iit->it", self.sample_cov), 0.0))

    @property
    def standard_error(self) -> np.ndarray:
        """Standard error of :attr:`sample_mean`, ``sample_std/√trials``."""
        return self.sample_std / math.sqrt(self.trials)

    @property
    def exact_mean(self) -> np.ndarray:
        """``E z`` (MATH §7), shape (p, T)."""
        return self.exact.outputs_mean

    @property
    def exact_std(self) -> np.ndarray:
        """Exact standard deviation of each output, shape (p, T)."""
        return self.exact.outputs_std

    @property
    def output_labels(self) -> list[str]:
        return list(self.paths.output_labels)

    def to_response(self) -> ct.TimeResponseData:
        """The statistics as a multi-trace :class:`control.TimeResponseData`.

        Traces: exact mean, sample mean, then one per quantile; the inputs
        of every trace are the deterministic ``w``.
        """
        traces = [self.exact_mean, self.sample_mean, *self.quantile_values]
        y = np.stack(traces, axis=1)
        labels = ["exact mean", f"sample mean ({self.trials} trials)"] + \
            [f"{100 * q:g}% quantile" for q in self.quantiles]
        u = np.repeat(self.inputs[:, None, :], len(traces), axis=1)
        return ct.TimeResponseData(
            self.time, y, None, u, issiso=False, squeeze=False,
            multi_trace=True, output_labels=self.output_labels,
            input_labels=list(self.paths.input_labels), trace_labels=labels,
            trace_types=[self.kind] * len(traces), plot_inputs=False,
            sysname=self.paths.sysname, title=self.title)

    def plot(self, *args: Any, **kwargs: Any) -> ct.ControlPlot:
        """Plot the statistics with :func:`control.time_response_plot`.

        One axes per output with ``2 + len(quantiles)`` lines: exact mean
        (solid), sample mean (dashed), quantiles (dotted). Keywords are
        passed on (e.g. ``plot_inputs=True``, ``overlay_traces=False``).
        For a band with sample paths use :func:`plot_ensemble`.

        Returns
        -------
        control.ControlPlot
        """
        kwargs.setdefault("overlay_traces", True)
        if not args:
            kwargs.setdefault("trace_props", [
                {"linestyle": "-"}, {"linestyle": "--"}]
                + [{"linestyle": ":"}] * len(self.quantiles))
        return ct.time_response_plot(self.to_response(), *args, **kwargs)


# -- argument checks ----------------------------------------------------------
def _psd_factor(value: Any, size: int, name: str) -> np.ndarray | None:
    """``L`` (size × rank) with ``L Lᵀ = value``; None for a zero matrix.

    By the symmetric eigendecomposition, so a singular (rank-deficient)
    covariance is fine and costs only ``rank`` draws per step.
    """
    W = covariance(value, size, name)
    if W is None:
        return None
    lam, V = np.linalg.eigh(W)
    scale = max(1.0, float(np.max(np.abs(W), initial=0.0)))
    tol = 1e-12 * max(scale, float(np.max(np.abs(lam), initial=0.0)))
    keep = lam > tol
    if not keep.any():
        return None
    return V[:, keep] * np.sqrt(lam[keep])


def _root_entropy(seed: Any) -> list[int]:
    bad = ControlArgument(
        f"seed: expected None, an int >= 0, a numpy.random.SeedSequence, a bit "
        f"generator or a numpy.random.Generator, got {seed!r}")
    if isinstance(seed, (bool, np.bool_)):
        raise bad
    try:
        rng = np.random.default_rng(seed)
    except (TypeError, ValueError):
        raise bad from None
    return [int(v) for v in rng.integers(0, 2**63, size=4, dtype=np.int64)]


# -- the engine ---------------------------------------------------------------
@dataclass
class _Run:
    """A validated run: everything but the trial range."""

    sys: JumpStateSpace
    phases: list                 # _Phase per phase k
    time: np.ndarray
    w: np.ndarray                # (m, T) deterministic part of w
    x0: np.ndarray               # (n,)
    noise: np.ndarray | None     # (m, r): white part of w is noise @ ξ
    spread: np.ndarray | None    # (n, r0): random part of ξ_0
    entropy: list
    trials: int
    chunk: int

    def uniforms(self, stream: int, first: int, rows: int, width: int
                 ) -> np.ndarray:
        """Rows ``first .. first+rows-1`` of a stream read as (trial, width)."""
        bits = np.random.PCG64(np.random.SeedSequence(self.entropy,
                                                      spawn_key=(stream,)))
        if first:
            bits.advance(first * width)   # one 64-bit word per uniform
        return np.random.Generator(bits).random((rows, width))

    def normals(self, stream: int, first: int, rows: int, width: int
                ) -> np.ndarray:
        u = self.uniforms(stream, first, rows, width)
        return ndtri(np.maximum(u, 2.0**-54))  # random() may return 0.0

    def chunks(self) -> Iterator[tuple[int, int]]:
        for a in range(0, self.trials, self.chunk):
            yield a, min(a + self.chunk, self.trials)


def _prepare(sys: Any, timepts: Any, inputs: Any, initial_state: Any, *,
             trials: Any, seed: Any, noise_covariance: Any,
             initial_covariance: Any, chunk: Any) -> _Run:
    sys = as_jump(sys)
    n = sys.modes.A.shape[-1]
    m = sys.modes.B.shape[-1]
    t = time_grid(sys, timepts)
    w = input_signal(inputs, m, t.size)
    x0 = initial_mean(initial_state, n)
    noise = _psd_factor(noise_covariance, m, "noise_covariance")
    spread = _psd_factor(initial_covariance, n, "initial_covariance")
    trials = positive_int(trials, "trials")
    chunk = positive_int(chunk, "chunk", allow_none=True)
    run = _Run(sys, _phases(sys.modes), t, w, x0, noise, spread,
               _root_entropy(seed), trials, trials)
    run.chunk = min(trials, _default_chunk(run) if chunk is None else chunk)
    return run


class _Phase(NamedTuple):
    """One phase's step as a single product: ``[z; ξ⁺] = G [ξ; w; s]``.

    ``G = [M_b, U]`` holds the base mode's ``M_b = [C D; A B]`` and the left
    factors of the other modes' differences ``M_i - M_b = U_i V_i``; ``s`` is
    ``V_i [ξ; w]`` for the trials in mode ``i`` and zero for the others.
    Network modes differ by low rank (a lost message removes the rank-``m``
    term ``B_u K``), so this costs about one product per step for all
    trials, with no gather or scatter of trials by mode.
    """

    G: np.ndarray                 # (p + n, n + m + r)
    V: np.ndarray                 # (r, n + m)
    parts: tuple                  # ((mode, rows of s), ...) for the non-base modes


def _phases(modes: Any) -> list[_Phase]:
    n, m = modes.B.shape[-2:]
    eps = np.finfo(float).eps
    phases = []
    for k in range(modes.period):
        M = np.concatenate([np.concatenate([modes.C[k], modes.D[k]], axis=2),
                            np.concatenate([modes.A[k], modes.B[k]], axis=2)],
                           axis=1)
        p_k = modes.probabilities[k]
        live = np.flatnonzero(p_k > 0)
        base = live[np.argmax(p_k[live])]
        U, V, parts, r = [], [], [], 0
        for i in live:
            delta = M[i] - M[base]
            # Factor only the rows and columns where the modes differ, so a
            # signal a mode does not touch gets exact zeros (e.g. noise never
            # leaks into a state it does not drive).
            rows = np.flatnonzero(np.any(delta != 0, axis=1))
            cols = np.flatnonzero(np.any(delta != 0, axis=0))
            if i == base or rows.size == 0:
                continue
            u, sv, vt = np.linalg.svd(delta[np.ix_(rows, cols)],
                                      full_matrices=False)
            tol = max(delta.shape) * eps * max(np.linalg.norm(M[i], 2),
                                               np.linalg.norm(M[base], 2))
            rank = int(np.count_nonzero(sv > tol))
            if rank == 0:
                continue
            Ui = np.zeros((M.shape[1], rank))
            Ui[rows] = u[:, :rank] * sv[:rank]
            Vi = np.zeros((rank, n + m))
            Vi[:, cols] = vt[:rank]
            U.append(Ui)
            V.append(Vi)
            parts.append((int(i), slice(r, r + rank)))
            r += rank
        G = np.concatenate([M[base]] + U, axis=1)
        V = np.concatenate(V) if V else np.zeros((0, n + m))
        phases.append(_Phase(G, V, tuple(parts)))
    return phases


def _mode_masks(run: _Run, a: int, c: int) -> np.ndarray | None:
    """``mask[t, j]``: 1.0 for the trials in the ``j``-th non-base mode of
    phase ``t mod N`` at step ``t``, else 0.0; shape (T, q, c)."""
    phases = run.phases
    q = max(len(ph.parts) for ph in phases)
    if q == 0:
        return None
    T, N = run.time.size, len(phases)
    cdf = np.cumsum(run.sys.modes.probabilities, axis=1)
    cdf /= cdf[:, -1:]
    lower = np.concatenate([np.zeros((N, 1)), cdf[:, :-1]], axis=1)
    # mode i iff cdf[i-1] <= u < cdf[i] (searchsorted(cdf, u, 'right') == i)
    draws = run.uniforms(_MODES, a, c, T).T
    mask = np.empty((T, q, c))
    for k, ph in enumerate(phases):
        u = draws[k::N]
        for j, (i, _) in enumerate(ph.parts):
            lo, hi, out = lower[k, i], cdf[k, i], mask[k::N, j]
            if lo <= 0.0:
                np.less(u, hi, out=out)
            elif hi >= 1.0:
                np.greater_equal(u, lo, out=out)
            else:
                np.logical_and(u >= lo, u < hi, out=out)
    return mask


def _default_chunk(run: _Run) -> int:
    rows = _Storage.rows(run)
    q = max(len(ph.parts) for ph in run.phases)
    r = 0 if run.noise is None else run.noise.shape[1]
    by_memory = _CHUNK_FLOATS // (run.time.size * (1 + q + 2 * r) + 1)
    return max(1, min(by_memory, _STEP_FLOATS // rows))


@dataclass
class _Storage:
    """Paths of ``trials`` trials as one array of step slabs.

    ``slabs[t] = [ξ_t; w_t; s_t; z_t]`` (rows) × trials (columns), for
    ``t = 0..T`` (``ξ_T`` is computed but not a path value). The product of
    step ``t`` reads rows ``[ξ_t; w_t; s_t]`` of slab ``t`` and writes
    ``z_t`` and ``ξ_{t+1}``, adjacent rows, so every value is written once,
    in place, by the product that computes it: the result needs no
    transposition or copy. ``states``, ``outputs`` and ``inputs`` are
    (signal, trial, time) views of it.
    """

    slabs: np.ndarray            # (T + 1, R, trials)
    n: int
    m: int
    zrow: int                    # first row of z in a slab

    @staticmethod
    def layout(run: _Run) -> tuple[int, int, int]:
        """``n``, ``m`` and the first row of ``z`` in a slab."""
        n, n_m = run.x0.size, run.phases[0].V.shape[1]
        return n, n_m - n, n_m + max(ph.V.shape[0] for ph in run.phases)

    @staticmethod
    def rows(run: _Run) -> int:
        n, _, zrow = _Storage.layout(run)
        return zrow + run.phases[0].G.shape[0] - n

    @classmethod
    def empty(cls, run: _Run, trials: int) -> _Storage:
        shape = (run.time.size + 1, cls.rows(run), trials)
        try:
            slabs = np.empty(shape)
        except (MemoryError, ValueError):
            gib = math.prod(shape) * 8 / 2**30
            raise MemoryError(
                f"trials, timepts: {trials} paths of {run.time.size} steps "
                f"need {gib:.3g} GiB; ask for fewer trials or steps, or use an "
                f"ensemble response (step_response, ...) with keep_paths and "
                f"quantiles=() for bounded memory") from None
        return cls(slabs, *cls.layout(run))

    def views(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """States, outputs, inputs, each (signal, trial, time)."""
        T, n = self.slabs.shape[0] - 1, self.n
        s = self.slabs[:T]
        return (s[:, :n].transpose(1, 2, 0),
                s[:, self.zrow:].transpose(1, 2, 0),
                s[:, n:n + self.m].transpose(1, 2, 0))


def _simulate_chunk(run: _Run, a: int, b: int, store: _Storage,
                    first: int = 0, bar: Any = None) -> None:
    """Simulate trials ``a .. b-1`` into columns ``first + (0 .. b-a-1)``
    of ``store``."""
    n, m, zrow = store.n, store.m, store.zrow
    c, T = b - a, run.time.size
    slabs = store.slabs[:, :, first:first + c]
    flat = store.slabs.reshape(-1, store.slabs.shape[2])[:, first:first + c]
    R = slabs.shape[1]
    phases = run.phases
    N = len(phases)
    slabs[:T, n:n + m] = run.w.T[:, :, None]
    if run.noise is not None:
        r = run.noise.shape[1]
        white = run.normals(_NOISE, a, c, T * r).reshape(c, T, r)
        slabs[:T, n:n + m] += np.matmul(run.noise, white.transpose(1, 2, 0))
    slabs[0, :n] = run.x0[:, None]
    if run.spread is not None:
        r0 = run.spread.shape[1]
        slabs[0, :n] += run.spread @ run.normals(_INITIAL, a, c, r0).T
    mask = _mode_masks(run, a, c)
    width = max(_MIN_COLUMNS, _GEMM_SERIAL // max(ph.G.size for ph in phases))
    blocks = [slice(j, j + width) for j in range(0, c, width)]
    for t in range(T):
        G, V, parts = phases[t % N]
        row = t * R
        r = V.shape[0]
        if r:
            s = flat[row + n + m:row + n + m + r]
            np.matmul(V, flat[row:row + n + m], out=s)
            if len(parts) == 1:
                s *= mask[t, 0]
            else:
                for q, (_, rows) in enumerate(parts):
                    s[rows] *= mask[t, q]
        into, out = flat[row:row + n + m + r], flat[row + zrow:row + R + n]
        if len(blocks) == 1:
            np.matmul(G, into, out=out)
        else:
            for cols in blocks:
                np.matmul(G, into[:, cols], out=out[:, cols])
        if bar is not None:
            bar.update(1)


def _progress_bar(progress: bool, total: int, desc: str):
    if not isinstance(progress, (bool, np.bool_)):
        raise ControlArgument(f"progress: expected True or False, got "
                              f"{progress!r}")
    if not progress:
        return contextlib.nullcontext(None)
    if not tqdm_check():
        raise ImportError("progress=True needs the optional package tqdm: "
                          "pip install tqdm (or control_ncs[progress])")
    from tqdm.auto import tqdm
    return tqdm(total=total, desc=desc, unit="step")


def _signal_labels(sys: JumpStateSpace) -> dict:
    return dict(output_labels=sys.jump_outputs, state_labels=sys.jump_states,
                input_labels=sys.jump_inputs, sysname=sys.name)


def _empty_paths(run: _Run, trials: int, title: str
                 ) -> tuple[SamplePaths, _Storage]:
    """Paths to be filled in place, and the storage they view."""
    # TimeResponseData copies the arrays it is given (np.array), which for
    # millions of trial-steps costs as much as simulating them: it is built
    # on zero-length placeholders and the views of the storage are attached.
    s = run.sys
    n, m, p = (len(s.jump_states), len(s.jump_inputs), len(s.jump_outputs))
    store = _Storage.empty(run, trials)     # first: it may not fit
    paths = SamplePaths(
        run.time[:0], np.empty((p, trials, 0)), np.empty((n, trials, 0)),
        np.empty((m, trials, 0)), issiso=False, squeeze=False,
        multi_trace=True, trace_labels=[f"trial {i}" for i in range(trials)],
        trace_types=["forced"] * trials, plot_inputs=False, title=title,
        **_signal_labels(s))
    paths.t = run.time
    paths.x, paths.y, paths.u = store.views()
    return paths, store


# -- public functions ---------------------------------------------------------
def simulate(sys: Any, timepts: Any, inputs: Any = None,
             initial_state: Any = None, *, trials: int = 100, seed: Any = None,
             noise_covariance: Any = None, initial_covariance: Any = None,
             chunk: int | None = None, workers: int | None = None,
             progress: bool = False, **kwargs: Any) -> SamplePaths:
    """Monte Carlo sample paths of a jump system.

    Simulates ``ξ[t+1] = A[k,i] ξ[t] + B[k,i] w[t]``,
    ``z[t] = C[k,i] ξ[t] + D[k,i] w[t]`` (``k = t mod N``) with the mode ``i``
    of every trial drawn at every step with probability
    ``sys.modes.probabilities[k, i]``. All trials advance together, one
    matrix product per step for all modes (see the module notes).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
        E.g. any closed loop of :func:`control_ncs.feedback` (static or
        predictor controller, zero or hold actuator, any schedule).
    timepts : int or array_like
        Number of steps ``T``, or the times ``0, dt, …, (T-1)·dt`` (they
        must start at 0: step ``t`` runs phase ``t mod N``), as in
        :func:`control_ncs.moments`.
    inputs : array_like, shape (m, T), optional
        Deterministic part of ``w`` (default zero; scalars broadcast).
    initial_state : array_like, shape (n,), or scalar, optional
        Mean of ``ξ[0]`` (default zero; a scalar applies to every state).
    trials : int, optional
        Number of sample paths (default 100).
    seed : None, int, SeedSequence, bit generator or numpy.random.Generator
        Source of randomness; a Generator is advanced. The global NumPy
        random state is never used. See the module notes: a trial's path
        depends only on the seed and its index.
    noise_covariance : array_like, shape (m, m), optional
        Covariance ``W`` of a zero-mean white Gaussian part of ``w``, added
        to ``inputs`` (positive semidefinite; may be singular).
    initial_covariance : array_like, shape (n, n), optional
        Covariance of a Gaussian ``ξ[0]`` (default zero: known initial state).
    chunk : int, optional
        Trials simulated together; bounds the working memory. Default: as
        many as keep one step's data in a core's cache (about 256 kB). Does
        not change the result.
    workers : int, optional
        Threads simulating chunks side by side (numpy's matrix products
        release the GIL; each chunk writes its own trials). Default: the
        CPUs this process may use, at most one per chunk. Does not change
        the result.
    progress : bool, optional
        Show a progress bar (needs the optional package ``tqdm``).

    Returns
    -------
    SamplePaths
        A :class:`control.TimeResponseData` with ``outputs`` ``[p, trial,
        time]``, ``states`` ``[n, trial, time]`` and ``inputs`` ``[m, trial,
        time]``, the realised ``w`` (deterministic part plus sampled noise).

    Raises
    ------
    TypeError
        Unknown keyword.
    ValueError
        Bad ``timepts`` (see :func:`control_ncs.moments`), ``trials``,
        ``chunk``, ``workers``, complex or non-finite ``inputs`` or
        ``initial_state``, or a covariance that is not symmetric positive
        semidefinite.
    ControlDimension
        Arrays of the wrong shape.
    ControlArgument
        Bad ``seed`` or ``progress``.
    MemoryError
        The paths do not fit in memory (the message names the size).
    ImportError
        ``progress=True`` without ``tqdm``.

    See Also
    --------
    step_response, moments

    Examples
    --------
    ``x⁺ = 2x + u`` with ``u = -2x`` applied with probability 0.8: the state
    is either multiplied by 2 or set to 0.

    >>> from control_ncs.simulate import simulate
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> paths = simulate(sys, 4, initial_state=[1.0], trials=3, seed=0)
    >>> paths.outputs.shape
    (1, 3, 4)
    >>> bool(np.all(np.isin(paths.outputs, [0, 1, 2, 4, 8])))
    True
    """
    no_extra_kwargs("simulate", kwargs)
    run = _prepare(sys, timepts, inputs, initial_state, trials=trials,
                   seed=seed, noise_covariance=noise_covariance,
                   initial_covariance=initial_covariance, chunk=chunk)
    workers = positive_int(workers, "workers", allow_none=True)
    title = f"Sample paths of {run.sys.name} ({run.trials} trials)"
    paths, store = _empty_paths(run, run.trials, title)
    chunks = list(run.chunks())
    if workers is None:
        workers = _cpus()
    workers = min(workers, len(chunks))
    with _progress_bar(progress, len(chunks) * run.time.size,
                       "simulate") as bar:
        if workers <= 1:
            for a, b in chunks:
                _simulate_chunk(run, a, b, store, a, bar)
        else:
            # Chunks write disjoint trial columns of ``store`` and draw from
            # their own random streams, so the order of completion does not
            # matter (tests/test_simulate.py checks equality with one
            # worker). Measured (n = 32, 5000 trials, 2 cores): 1.3x.
            # The bar is advanced here, in the calling thread, once per
            # finished chunk (tqdm's counter is not updated under a lock).
            with ThreadPoolExecutor(workers) as pool:
                try:
                    for _ in pool.map(
                            lambda ab: _simulate_chunk(run, ab[0], ab[1],
                                                       store, ab[0]), chunks):
                        if bar is not None:
                            bar.update(run.time.size)
                except BaseException:
                    pool.shutdown(wait=True, cancel_futures=True)
                    raise
    return paths


def _cpus() -> int:
    """CPUs this process may run on (at least 1)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:         # not on Linux (macOS, Windows)
        # Python 3.13 counts the CPUs of this process; before, of the machine
        count = getattr(os, "process_cpu_count", os.cpu_count)()
        return count or 1


def _quantile_levels(quantiles: Any) -> tuple:
    if quantiles is None:
        raise ValueError("quantiles: expected a sequence of probabilities in "
                         "[0, 1] (() for none), got None")
    q = real_values(quantiles, "quantiles", ndim=(0, 1)).reshape(-1)
    if np.any(q < 0) or np.any(q > 1):
        raise ValueError(f"quantiles: probabilities must lie in [0, 1], got "
                         f"{q.tolist()}")
    return tuple(float(v) for v in np.sort(q))


def _ensemble(sys: Any, timepts: Any, inputs: Any, initial_state: Any, *,
              kind: str, what: str, trials: Any, seed: Any, quantiles: Any,
              noise_covariance: Any, initial_covariance: Any, keep_paths: Any,
              chunk: Any, progress: bool) -> EnsembleResponse:
    run = _prepare(sys, timepts, inputs, initial_state, trials=trials,
                   seed=seed, noise_covariance=noise_covariance,
                   initial_covariance=initial_covariance, chunk=chunk)
    levels = _quantile_levels(quantiles)
    keep = positive_int(keep_paths, "keep_paths", allow_none=True)
    keep = run.trials if keep is None else min(keep, run.trials)
    s, T = run.sys, run.time.size
    n, p = len(s.jump_states), len(s.jump_outputs)
    title = f"{what} of {s.name} ({run.trials} trials)"
    if chunk is None:       # the chunk's storage is working memory here
        per_trial = (T + 1) * _Storage.rows(run)
        run.chunk = min(run.chunk, max(1, _CHUNK_FLOATS // per_trial))
    paths, kept = _empty_paths(run, keep, title)
    store = _Storage.empty(run, run.chunk)
    zrow = store.zrow
    try:
        everything = np.empty((p, run.trials, T)) if levels else None
    except (MemoryError, ValueError):
        raise MemoryError(
            f"quantiles: exact quantiles keep every trial's outputs "
            f"({p * run.trials * T} floats); pass quantiles=() for bounded "
            f"memory") from None
    count, mean, M2 = 0, np.zeros((T, p)), np.zeros((T, p, p))
    states_sum = np.zeros((T, n))
    nchunks = -(-run.trials // run.chunk)
    with _progress_bar(progress, nchunks * T, kind) as bar:
        for a, b in run.chunks():
            c = b - a
            _simulate_chunk(run, a, b, store, 0, bar)
            slabs = store.slabs[:, :, :c]
            if a < keep:
                kept.slabs[:, :, a:min(b, keep)] = slabs[:, :, :keep - a]
            Z = slabs[:T, zrow:]                        # (T, p, trial)
            if everything is not None:
                everything[:, a:b] = Z.transpose(1, 2, 0)
            states_sum += slabs[:T, :n].sum(axis=2)
            # Chan et al.'s pairwise update of mean and scatter: exact and
            # stable, and needs one chunk at a time.
            mean_c = Z.mean(axis=2)
            dev = Z - mean_c[:, :, None]
            M2_c = np.einsum("tic,tjc->tij", dev, dev)
            delta = mean_c - mean
            total = count + c
            M2 += M2_c + np.einsum("ti,tj->tij", delta, delta) * (count * c
                                                                  / total)
            mean += delta * (c / total)
            count = total
    cov = M2 / (count - 1) if count > 1 else np.zeros_like(M2)
    qv = np.quantile(everything, levels, axis=1) if levels else \
        np.zeros((0, p, T))
    exact = moments(s, run.time, run.w, run.x0,
                    noise_covariance=None if run.noise is None
                    else run.noise @ run.noise.T,
                    initial_covariance=None if run.spread is None
                    else run.spread @ run.spread.T)
    return EnsembleResponse(
        time=run.time, inputs=run.w, kind=kind, trials=run.trials,
        quantiles=levels, sample_mean=mean.T.copy(),
        sample_cov=cov.transpose(1, 2, 0).copy(), quantile_values=qv,
        states_sample_mean=(states_sum / count).T.copy(), exact=exact,
        paths=paths, title=title)


def default_steps(sys: Any) -> int:
    """Default horizon of the ensemble responses, in steps.

    The number of steps after which ``E‖ξ‖²`` of the unforced system has
    decayed by ``1e-4`` (RMS by 1 %) at the per-step mean-square rate
    :func:`control_ncs.ms_radius` (which bounds the decay of the mean as
    well), clipped to ``[20, 1000]``; 50 steps for a system that is not
    mean-square stable. Rounded up to whole periods.
    """
    sys = as_jump(sys)
    try:
        rho = ms_radius(sys)
    except RuntimeError:
        rho = 1.0
    if not np.isfinite(rho) or rho >= 1.0:
        steps = _UNSTABLE_STEPS
    elif rho <= _SETTLE ** (1.0 / _MIN_STEPS):
        steps = _MIN_STEPS
    else:
        steps = min(_MAX_STEPS, math.ceil(math.log(_SETTLE) / math.log(rho)))
    N = sys.period
    return -(-steps // N) * N


def _steps_or_default(sys: JumpStateSpace, timepts: Any) -> Any:
    return default_steps(sys) if timepts is None else timepts


def _input_index(sys: JumpStateSpace, input: Any) -> int:
    names = sys.jump_inputs
    if input is None:
        if len(names) == 1:
            return 0
        raise ControlArgument(
            f"input: the system has {len(names)} inputs {names}; choose the "
            f"one to excite with input=<index or name> (one ensemble per input)")
    if isinstance(input, str):
        if input not in names:
            raise ValueError(f"input: no input named {input!r}; inputs are "
                             f"{names}")
        return names.index(input)
    if isinstance(input, (bool, np.bool_)) or not isinstance(
            input, (int, np.integer)) or not -len(names) <= input < len(names):
        raise ValueError(f"input: expected an index in 0..{len(names) - 1} or "
                         f"a name in {names}, got {input!r}")
    return int(input) % len(names)


_OPTIONS_DOC = """trials : int, optional
        Number of sample paths (default 1000).
    seed : None, int, SeedSequence, bit generator or numpy.random.Generator
        Randomness, as in :func:`simulate`.
    quantiles : sequence of float, optional
        Probabilities of the sample quantiles to report (default
        ``(0.05, 0.95)``: a 90 % band); ``()`` keeps memory bounded.
    noise_covariance, initial_covariance : array_like, optional
        White Gaussian part of ``w`` and random part of ``ξ[0]``, as in
        :func:`simulate`; the exact moments include them.
    keep_paths : int or None, optional
        Number of full sample paths kept in ``paths`` (default 100; None =
        all). Statistics always use every trial.
    chunk : int, optional
        Trials simulated together (memory bound); does not change results.
    progress : bool, optional
        Show a progress bar (needs ``tqdm``)."""


def forced_response(sys: Any, timepts: Any, inputs: Any = None,
                    initial_state: Any = None, *, trials: int = 1000,
                    seed: Any = None, quantiles: Sequence[float] = (0.05, 0.95),
                    noise_covariance: Any = None, initial_covariance: Any = None,
                    keep_paths: int | None = 100, chunk: int | None = None,
                    progress: bool = False, **kwargs: Any) -> EnsembleResponse:
    """Ensemble response of a jump system to a given input.

    The general form of :func:`step_response`, :func:`impulse_response` and
    :func:`initial_response`: simulates ``trials`` sample paths
    (:func:`simulate`) and returns their mean, covariance and quantiles
    beside the exact moments (:func:`control_ncs.moments`).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    timepts : int or array_like
        Number of steps, or the times ``0, dt, 2·dt, …``, as in
        :func:`simulate`.
    inputs : array_like, shape (m, T), optional
        Deterministic part of ``w`` (default zero).
    initial_state : array_like, shape (n,), optional
        Mean of ``ξ[0]`` (default zero).
    {options}

    Returns
    -------
    EnsembleResponse

    Raises
    ------
    TypeError
        Unknown keyword.

    Examples
    --------
    >>> from control_ncs.simulate import forced_response
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = forced_response(sys, 3, initial_state=[1.0], trials=2000, seed=1)
    >>> r.exact_mean.round(6).tolist()
    [[1.0, 0.4, 0.16]]
    >>> bool(np.all(abs(r.sample_mean - r.exact_mean) < 5 * r.standard_error + 1e-12))
    True
    """
    no_extra_kwargs("forced_response", kwargs)
    return _ensemble(sys, timepts, inputs, initial_state, kind="forced",
                     what="Forced response", trials=trials, seed=seed,
                     quantiles=quantiles, noise_covariance=noise_covariance,
                     initial_covariance=initial_covariance,
                     keep_paths=keep_paths, chunk=chunk, progress=progress)


def step_response(sys: Any, timepts: Any = None, *, input: int | str | None = None,
                  initial_state: Any = None, trials: int = 1000,
                  seed: Any = None, quantiles: Sequence[float] = (0.05, 0.95),
                  noise_covariance: Any = None, initial_covariance: Any = None,
                  keep_paths: int | None = 100, chunk: int | None = None,
                  progress: bool = False, **kwargs: Any) -> EnsembleResponse:
    """Ensemble step response of a jump system.

    The input ``w_j`` is 1 at every step (every phase of the period) and the
    other inputs are 0.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    timepts : int or array_like, optional
        Number of steps or times. Default: :func:`default_steps` (until the
        mean-square transient has decayed by 1e-4, whole periods, 20 to 1000
        steps; 50 if the system is not mean-square stable).
    input : int or str, optional
        Index or name of the stepped input; required when ``sys`` has more
        than one (python-control would step each in turn; here one ensemble
        is one input).
    initial_state : array_like, shape (n,), optional
        Mean of ``ξ[0]`` (default zero).
    {options}

    Returns
    -------
    EnsembleResponse

    Raises
    ------
    ControlArgument
        ``input`` missing for a system with several inputs.

    See Also
    --------
    control.step_response : of ``sys`` itself gives the exact mean (``N = 1``).

    Examples
    --------
    >>> from control_ncs.simulate import step_response
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = step_response(sys, 20, trials=500, seed=0)
    >>> round(float(r.exact_mean[0, -1]), 4)   # 1 / (1 - 0.4)
    1.6667
    >>> cplt = r.plot()
    >>> len(cplt.lines[0, 0])                  # exact, sample, 5 %, 95 %
    4
    """
    no_extra_kwargs("step_response", kwargs)
    sys = as_jump(sys)
    j = _input_index(sys, input)
    t = time_grid(sys, _steps_or_default(sys, timepts))
    w = np.zeros((len(sys.jump_inputs), t.size))
    w[j] = 1.0
    return _ensemble(sys, t, w, initial_state, kind="step",
                     what=f"Step response from {sys.jump_inputs[j]}",
                     trials=trials, seed=seed, quantiles=quantiles,
                     noise_covariance=noise_covariance,
                     initial_covariance=initial_covariance,
                     keep_paths=keep_paths, chunk=chunk, progress=progress)


def impulse_response(sys: Any, timepts: Any = None, *,
                     input: int | str | None = None, initial_state: Any = None,
                     trials: int = 1000, seed: Any = None,
                     quantiles: Sequence[float] = (0.05, 0.95),
                     noise_covariance: Any = None,
                     initial_covariance: Any = None,
                     keep_paths: int | None = 100, chunk: int | None = None,
                     progress: bool = False, **kwargs: Any) -> EnsembleResponse:
    """Ensemble impulse response of a jump system.

    As python-control does in discrete time, the impulse has unit area:
    ``w_j[0] = 1/dt`` (1 when ``dt`` is True), all other values 0.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    timepts : int or array_like, optional
        As in :func:`step_response`.
    input : int or str, optional
        Index or name of the input; required when there are several.
    initial_state : array_like, shape (n,), optional
    {options}

    Returns
    -------
    EnsembleResponse

    Examples
    --------
    >>> from control_ncs.simulate import impulse_response
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> impulse_response(sys, 4, trials=10, seed=0).exact_mean.round(4).tolist()
    [[0.0, 1.0, 0.4, 0.16]]
    """
    no_extra_kwargs("impulse_response", kwargs)
    sys = as_jump(sys)
    j = _input_index(sys, input)
    t = time_grid(sys, _steps_or_default(sys, timepts))
    w = np.zeros((len(sys.jump_inputs), t.size))
    w[j, 0] = 1.0 if sys.dt_step is True else 1.0 / sys.dt_step
    return _ensemble(sys, t, w, initial_state, kind="impulse",
                     what=f"Impulse response from {sys.jump_inputs[j]}",
                     trials=trials, seed=seed, quantiles=quantiles,
                     noise_covariance=noise_covariance,
                     initial_covariance=initial_covariance,
                     keep_paths=keep_paths, chunk=chunk, progress=progress)


def initial_response(sys: Any, timepts: Any = None, initial_state: Any = None,
                     *, trials: int = 1000, seed: Any = None,
                     quantiles: Sequence[float] = (0.05, 0.95),
                     noise_covariance: Any = None,
                     initial_covariance: Any = None,
                     keep_paths: int | None = 100, chunk: int | None = None,
                     progress: bool = False, **kwargs: Any) -> EnsembleResponse:
    """Ensemble response of a jump system to an initial state (``w = 0``).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    timepts : int or array_like, optional
        As in :func:`step_response`.
    initial_state : array_like, shape (n,) or scalar, optional
        ``ξ[0]`` (its mean if ``initial_covariance`` is given); default 0.
    {options}

    Returns
    -------
    EnsembleResponse

    Examples
    --------
    >>> from control_ncs.simulate import initial_response
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = initial_response(sys, 3, [1.0], trials=10, seed=0)
    >>> r.exact_std.round(4).tolist()        # sqrt(0.8**t - 0.4**(2t))
    [[0.0, 0.8, 0.7838]]
    """
    no_extra_kwargs("initial_response", kwargs)
    sys = as_jump(sys)
    t = time_grid(sys, _steps_or_default(sys, timepts))
    return _ensemble(sys, t, None, initial_state, kind="initial",
                     what="Initial response", trials=trials, seed=seed,
                     quantiles=quantiles, noise_covariance=noise_covariance,
                     initial_covariance=initial_covariance,
                     keep_paths=keep_paths, chunk=chunk, progress=progress)


for _f in (forced_response, step_response, impulse_response, initial_response):
    if _f.__doc__:                 # None under python -OO
        _f.__doc__ = _f.__doc__.replace("{options}", _OPTIONS_DOC)
del _f


def plot_ensemble(response: EnsembleResponse, ax: Any = None, paths: int = 5,
                  *, band: bool = True, legend: bool = True,
                  title: str | None = None) -> ct.ControlPlot:
    """Draw an ensemble response: band, sample paths, sample and exact mean.

    One axes per output, each with ``paths`` thin sample paths, the band
    between the lowest and highest quantile (``fill_between``), the sample
    mean (solid) and the exact mean of MATH §7 (dashed, black) -- so
    ``paths + 2`` lines and one filled band per axes.

    Parameters
    ----------
    response : EnsembleResponse
        From :func:`step_response`, :func:`impulse_response`,
        :func:`initial_response` or :func:`forced_response`.
    ax : matplotlib Axes or array of Axes, optional
        One axes per output; default: a new figure.
    paths : int, optional
        Number of sample paths to draw (at most those kept in
        ``response.paths``; default 5).
    band : bool, optional
        Draw the quantile band (needs at least two quantiles).
    legend : bool, optional
        Legend in the first axes.
    title : str, optional
        Figure title (default: the response's title; only for a new figure).

    Returns
    -------
    control.ControlPlot
        ``lines[i, 0]`` lists the lines of output ``i`` (paths, sample mean,
        exact mean); ``axes`` has shape (p, 1).

    Examples
    --------
    >>> from control_ncs.simulate import step_response, plot_ensemble
    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> cplt = plot_ensemble(step_response(sys, 20, trials=200, seed=0), paths=3)
    >>> len(cplt.axes[0, 0].get_lines()), len(cplt.axes[0, 0].collections)
    (5, 1)
    """
    if not isinstance(response, EnsembleResponse):
        raise ControlArgument(f"response: expected an EnsembleResponse (see "
                              f"step_response), got {type(response).__name__}")
    if isinstance(paths, (bool, np.bool_)) or not isinstance(
            paths, (int, np.integer)) or paths < 0:
        raise ValueError(f"paths: expected an int >= 0, got {paths!r}")
    p = len(response.output_labels)
    if ax is None:
        fig, axes = plt.subplots(p, 1, sharex=True, squeeze=False)
        axes = axes[:, 0]
    else:
        axes = np.asarray(ax, dtype=object).reshape(-1)
        if axes.size != p:
            raise ControlDimension(f"ax: expected {p} axes (one per output), "
                                   f"got {axes.size}")
        fig = axes[0].figure
    shown = min(int(paths), response.paths.ntraces)
    t = response.time
    lines = np.empty((p, 1), dtype=object)
    lo = hi = None
    if band and len(response.quantiles) >= 2:
        lo, hi = response.quantile_values[0], response.quantile_values[-1]
        band_label = (f"{100 * response.quantiles[0]:g}–"
                      f"{100 * response.quantiles[-1]:g}% band")
    for i, a in enumerate(axes):
        drawn = []
        if shown:
            drawn += a.plot(t, response.paths.y[i, :shown].T, color="0.55",
                            linewidth=0.7, alpha=0.8)
            drawn[0].set_label("sample paths")
        if lo is not None:
            a.fill_between(t, lo[i], hi[i], color="C0", alpha=0.25,
                           linewidth=0, label=band_label)
        drawn += a.plot(t, response.sample_mean[i], color="C0", linewidth=1.8,
                        label=f"sample mean ({response.trials} trials)")
        drawn += a.plot(t, response.exact_mean[i], color="k", linestyle="--",
                        linewidth=1.2, label="exact mean")
        a.set_ylabel(response.output_labels[i])
        lines[i, 0] = drawn
    axes[-1].set_xlabel("Time [s]")
    legends = np.full((p, 1), None, dtype=object)
    if legend:
        legends[0, 0] = axes[0].legend(loc="best", fontsize="small")
    if ax is None:
        fig.suptitle(title if title is not None else response.title)
    return ct.ControlPlot(lines, axes.reshape(p, 1), fig, legend=legends)
