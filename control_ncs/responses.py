"""Monte Carlo sample paths and ensemble responses of a jump system.

A :class:`~control_ncs.jump.JumpStateSpace` (:ref:`theory-jump-system`) draws
its mode independently at every step. :func:`simulate` draws many such
realisations at once and returns them as a multi-trace
:class:`control.TimeResponseData` (one trace per trial). :func:`step_response`,
:func:`impulse_response`,
:func:`initial_response` and :func:`forced_response` mirror python-control's
functions of the same names: they return an :class:`EnsembleResponse` with
the sample mean, quantile bands and, beside them, the *exact* mean and
standard deviation of :ref:`theory-moments` (:func:`control_ncs.moments`), so
that every picture shows how far sampling is from the truth.
:func:`control_ncs.ensemble_plot` draws the usual figure: exact mean,
sample mean, band and a few sample paths. The engine (random streams,
chunks, threads, memory) is :mod:`control_ncs.montecarlo`; its notes say
which draws a trial reads and what a run holds in memory.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._checks import no_extra_kwargs, positive_int
from ._tasks import progress_check
from .jump import JumpStateSpace, as_jump
from .meancov import MomentsResponse, moments, real_values, time_grid
from .montecarlo import (CHUNK_FLOATS, SIGNALS, Kept, Run, Storage,
                         ensemble_statistics, prepare, run_chunks,
                         signal_names)
from .stability import ms_radius

__all__ = ["simulate", "SamplePaths", "EnsembleResponse", "forced_response",
           "step_response", "impulse_response", "initial_response"]

#: Default horizon: steps until the mean-square transient has decayed by this
#: factor (an RMS factor of 1 %), within [_MIN_STEPS, _MAX_STEPS].
_SETTLE, _MIN_STEPS, _MAX_STEPS, _UNSTABLE_STEPS = 1e-4, 20, 1000, 50


# -- the result types ---------------------------------------------------------
class SamplePaths(ct.TimeResponseData):
    """Sample paths of a jump system: a multi-trace time response.

    A :class:`control.TimeResponseData` with one trace per trial:
    ``outputs`` ``[output, trial, time]``, ``states`` ``[state, trial,
    time]`` and ``inputs`` ``[input, trial, time]``, where the inputs are the
    realised ``w`` of each trial (deterministic part plus sampled white
    noise), so that every path can be replayed. It differs from its base
    class only in :meth:`plot`'s defaults, and in memory layout: ``x``,
    ``y`` and ``u`` are views of one time-major array (see
    :mod:`control_ncs.montecarlo`), not C-contiguous; ``numpy.ascontiguousarray`` makes a
    contiguous copy where one is needed. Any one of them keeps that whole
    array alive, including the scratch rows of the step (one per unit of
    rank by which the modes differ): to keep only the outputs of a large
    run, keep ``numpy.array(paths.outputs)``.

    Attributes
    ----------
    trials : int
        Number of sample paths (``ntraces``).

    See Also
    --------
    simulate : produces one.

    Examples
    --------
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> paths = ncs.simulate(sys, 4, initial_state=1.0, trials=3, seed=0)
    >>> paths.trials, paths.outputs.shape, paths.states.shape
    (3, (1, 3, 4), (1, 3, 4))
    """

    @property
    def trials(self) -> int:
        """Number of sample paths (``ntraces``).

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> ncs.simulate(sys, 4, trials=3, seed=0).trials
        3
        """
        return self.ntraces

    def __repr__(self) -> str:
        return (f"<SamplePaths of {self.sysname}: {self.ntraces} trials, "
                f"{self.noutputs} outputs, {self.nstates} states, "
                f"{self.t.size} time points>")

    def summary(self) -> str:
        """A few lines for humans: sizes and the final sample statistics.

        Returns
        -------
        str
            Per output (at most 10): sample mean and standard deviation at
            the last time point.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8],
        ...           name="loop", outputs="z")
        >>> print(ncs.simulate(sys, 4, initial_state=1.0, trials=50,
        ...                seed=0).summary())
        Sample paths of loop: 50 trials, 1 outputs, 1 states, 4 time points
          at t = 3: z: sample mean 0.16, sample std 1.12
        """
        y = self.y[:, :, -1]
        lines = [repr(self)[1:-1].replace("SamplePaths", "Sample paths", 1)]
        for i, name in enumerate(list(self.output_labels)[:10]):
            lines.append(f"  at t = {self.t[-1]:g}: {name}: sample mean "
                         f"{y[i].mean():.3g}, sample std {y[i].std():.3g}")
        return "\n".join(lines)

    def plot(self, *args: Any, paths: int | None = 20,
             **kwargs: Any) -> ct.ControlPlot:
        """Plot sample paths with :func:`control.time_response_plot`.

        Defaults differ from python-control's so that many traces stay
        readable: all trials overlaid in one axes per output
        (``overlay_traces=True``), thin solid lines, no legend, no inputs
        (pass ``plot_inputs=True`` to add them).

        Parameters
        ----------
        *args
            Passed to :func:`control.time_response_plot` (e.g. a format
            string).
        paths : int or None, optional
            Plot only the first ``paths`` trials (an int >= 1; default 20;
            None = all).
        **kwargs
            Passed to :func:`control.time_response_plot`.

        Returns
        -------
        control.ControlPlot
            One axes per output, one line per plotted trial.

        Raises
        ------
        ValueError
            ``paths`` is not an int >= 1 or None.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> paths = ncs.simulate(sys, 5, initial_state=1.0, trials=50, seed=0)
        >>> cplt = paths.plot(paths=10)
        >>> cplt.axes.shape, len(cplt.lines[0, 0])
        ((1, 1), 10)
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
        Exact mean and covariance (:ref:`theory-moments`) for the same inputs,
        initial state, noise and initial covariance.
    paths : SamplePaths
        The first ``keep_paths`` sample paths.
    title : str
        Figure title.

    See Also
    --------
    step_response, impulse_response, initial_response, forced_response :
        produce one.
    ensemble_plot : its usual figure.

    Examples
    --------
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.initial_response(sys, 3, 1.0, trials=100, keep_paths=5, seed=0)
    >>> r.kind, r.trials, r.quantiles, r.paths.trials
    ('initial', 100, (0.05, 0.95), 5)
    >>> r.sample_mean.shape, r.quantile_values.shape
    ((1, 3), (2, 1, 3))
    >>> r.exact_mean.round(6).tolist()          # E z_t = 0.4**t
    [[1.0, 0.4, 0.16]]
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
        """Sample standard deviation of each output, shape (p, T).

        The square root of the diagonal of :attr:`sample_cov` (``ddof=1``).

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> r = ncs.initial_response(sys, 3, 1.0, trials=4000, seed=0)
        >>> bool(np.all(abs(r.sample_std - r.exact_std) < 0.05))
        True
        """
        return np.sqrt(np.maximum(np.einsum("iit->it", self.sample_cov), 0.0))

    @property
    def standard_error(self) -> np.ndarray:
        """Standard error of :attr:`sample_mean`, ``sample_std/√trials``.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> r = ncs.initial_response(sys, 3, 1.0, trials=400, seed=0)
        >>> bool(np.allclose(r.standard_error, r.sample_std / 20))
        True
        """
        return self.sample_std / math.sqrt(self.trials)

    @property
    def exact_mean(self) -> np.ndarray:
        """``E z`` (:ref:`theory-moments`), shape (p, T).

        The outputs' mean of :attr:`exact`, computed without sampling.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> ncs.initial_response(sys, 3, 1.0, trials=10, seed=0).exact_mean.round(6)
        array([[1.  , 0.4 , 0.16]])
        """
        return self.exact.outputs_mean

    @property
    def exact_std(self) -> np.ndarray:
        """Exact standard deviation of each output, shape (p, T).

        From the exact covariance of :attr:`exact` (:ref:`theory-moments`).

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> r = ncs.initial_response(sys, 3, 1.0, trials=10, seed=0)
        >>> r.exact_std.round(4).tolist()        # sqrt(0.8**t - 0.4**(2t))
        [[0.0, 0.8, 0.7838]]
        """
        return self.exact.outputs_std

    @property
    def output_labels(self) -> list[str]:
        """Names of the outputs, as in the system.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8],
        ...           outputs=["z"])
        >>> ncs.initial_response(sys, 3, 1.0, trials=10, seed=0).output_labels
        ['z']
        """
        return list(self.paths.output_labels)

    def __repr__(self) -> str:
        q = ", ".join(f"{x:g}" for x in self.quantiles)
        return (f"<EnsembleResponse ({self.kind}) of {self.paths.sysname}: "
                f"{self.trials} trials, {self.sample_mean.shape[0]} outputs, "
                f"{self.time.size} time points, quantiles ({q}), "
                f"{self.paths.ntraces} paths kept>")

    def summary(self) -> str:
        """A few lines for humans: exact and sample statistics at the end.

        Returns
        -------
        str
            Per output (at most 10), at the last time point: the exact mean
            and standard deviation, the sample mean with its standard
            error, and the sample standard deviation.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8],
        ...           name="loop", outputs="z")
        >>> r = ncs.initial_response(sys, 3, 1.0, trials=400, seed=0)
        >>> print(r.summary())
        EnsembleResponse (initial) of loop: 400 trials, 1 outputs, 3 time points
          at t = 2: z: exact mean 0.16 (std 0.784); sample mean 0.16 ± 0.0392 (std 0.785)
        """
        lines = [f"EnsembleResponse ({self.kind}) of {self.paths.sysname}: "
                 f"{self.trials} trials, {self.sample_mean.shape[0]} outputs, "
                 f"{self.time.size} time points"]
        em, es = self.exact_mean[:, -1], self.exact_std[:, -1]
        sm, ss = self.sample_mean[:, -1], self.sample_std[:, -1]
        se = self.standard_error[:, -1]
        for i, name in enumerate(self.output_labels[:10]):
            lines.append(f"  at t = {self.time[-1]:g}: {name}: exact mean "
                         f"{em[i]:.3g} (std {es[i]:.3g}); sample mean "
                         f"{sm[i]:.3g} ± {se[i]:.3g} (std {ss[i]:.3g})")
        return "\n".join(lines)

    def to_response(self) -> ct.TimeResponseData:
        """The statistics as a multi-trace TimeResponseData.

        Traces: exact mean, sample mean, then one per quantile; the inputs
        of every trace are the deterministic ``w``.

        Returns
        -------
        control.TimeResponseData
            ``outputs`` of shape ``(p, 2 + len(quantiles), T)``.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> data = ncs.initial_response(sys, 3, 1.0, trials=10, seed=0).to_response()
        >>> data.outputs.shape, data.trace_labels[0]
        ((1, 4, 3), 'exact mean')
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
        For a band with sample paths use :func:`ensemble_plot`. As with
        python-control's responses, a second call draws into the current
        figure (to compare two responses); call ``plt.figure()`` first, or
        pass ``ax=``, for a figure of its own.

        Parameters
        ----------
        *args
            Passed to :func:`control.time_response_plot` (e.g. a format
            string; then the default line styles are not set).
        **kwargs
            Passed to :func:`control.time_response_plot`.

        Returns
        -------
        control.ControlPlot
            One axes per output.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> cplt = ncs.initial_response(sys, 3, 1.0, trials=10, seed=0).plot()
        >>> [line.get_linestyle() for line in cplt.lines[0, 0]]
        ['-', '--', ':', ':']
        """
        kwargs.setdefault("overlay_traces", True)
        if not args:
            kwargs.setdefault("trace_props", [
                {"linestyle": "-"}, {"linestyle": "--"}]
                + [{"linestyle": ":"}] * len(self.quantiles))
        return ct.time_response_plot(self.to_response(), *args, **kwargs)


def _signal_labels(sys: JumpStateSpace) -> dict:
    return dict(output_labels=sys.jump_outputs, state_labels=sys.jump_states,
                input_labels=sys.jump_inputs, sysname=sys.name)


def _empty_paths(run: Run, trials: int, title: str,
                 signals: tuple = SIGNALS
                 ) -> tuple[SamplePaths, Storage | Kept]:
    """Paths to be filled in place, and the storage they view: all of
    each step's rows (:class:`Storage`), or only the ``signals`` kept
    (:class:`Kept`)."""
    # TimeResponseData copies the arrays it is given (np.array), which for
    # millions of trial-steps costs as much as simulating them: it is built
    # on zero-length placeholders and the views of the storage are attached.
    s = run.sys
    store: Storage | Kept
    if set(signals) == set(SIGNALS):
        store = Storage.empty(run, trials)     # first: it may not fit
        x, y, u = store.views()
    else:
        store = Kept.empty(run, trials, signals)
        views = store.views()
        none = np.empty((0, trials, run.time.size))   # not kept: no rows
        x, y, u = (views.get(k, none)
                   for k in ("states", "outputs", "inputs"))
    labels = _signal_labels(s)
    keep = dict(states="state_labels", inputs="input_labels",
                outputs="output_labels")
    for name, key in keep.items():
        if name not in signals:
            labels[key] = None
    paths = SamplePaths(
        run.time[:0], np.empty((y.shape[0], trials, 0)),
        np.empty((x.shape[0], trials, 0)), np.empty((u.shape[0], trials, 0)),
        issiso=False, squeeze=False,
        multi_trace=True, trace_labels=[f"trial {i}" for i in range(trials)],
        trace_types=["forced"] * trials, plot_inputs=False, title=title,
        **labels)
    paths.t = run.time
    paths.x, paths.y, paths.u = x, y, u
    return paths, store


# -- public functions ---------------------------------------------------------
def simulate(sys: Any, timepts: Any, inputs: Any = None,
             initial_state: Any = None, *, trials: int = 100, seed: Any = None,
             noise_covariance: Any = None, initial_covariance: Any = None,
             chunk: int | None = None, workers: int | None = None,
             progress: bool = False, signals: Any = SIGNALS,
             **kwargs: Any) -> SamplePaths:
    """Monte Carlo sample paths of a jump system.

    Simulates ``ξ[t+1] = A[k,i] ξ[t] + B[k,i] w[t]``,
    ``z[t] = C[k,i] ξ[t] + D[k,i] w[t]`` (``k = t mod N``) with the mode ``i``
    of every trial drawn at every step with probability
    ``sys.modes.probabilities[k, i]``, or, for Markov modes
    (:ref:`theory-markov`), a chain per trial started from
    ``sys.modes.initial`` and moved by ``sys.modes.transition``. All trials
    advance together, one matrix product per step for all modes (see
    :mod:`control_ncs.montecarlo`).

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
        random state is never used. A trial's path depends only on the seed
        and its index (:mod:`control_ncs.montecarlo` says which draws it
        reads).
    noise_covariance : array_like, shape (m, m), optional
        Covariance ``W`` of a zero-mean white Gaussian part of ``w``, added
        to ``inputs`` (positive semidefinite; may be singular).
    initial_covariance : array_like, shape (n, n), optional
        Covariance of a Gaussian ``ξ[0]`` (default zero: known initial state).
    chunk : int, optional
        Trials simulated together; bounds the working memory. Default: as
        many as keep one step's data in a core's cache (about 256 kB). Does
        not change the paths (bit for bit with OpenBLAS, to rounding with
        any BLAS; see :mod:`control_ncs.montecarlo`).
    workers : int, optional
        Threads simulating chunks side by side (numpy's matrix products
        release the GIL; each chunk writes its own trials), at most one per
        chunk. Default 1: a step is a few small products, and threads that
        hand the GIL back and forth between them gain little on idle cores
        (1.3× with 2 threads, n = 32) and lose much on busy ones (2–5×
        slower with 2 threads on a loaded 2-core machine, n = 10;
        docs/benchmarks.md). Does not change the result.
    progress : bool or None, optional
        Show a progress bar (needs the optional package ``tqdm``); None:
        only where a person watches (a terminal or a notebook).
    signals : str or sequence of str, optional
        The paths to keep: ``'states'``, ``'outputs'``, ``'inputs'`` or a
        sequence of them (default all three). A run that keeps fewer never
        stores the others (memory: the kept arrays and one step per
        chunk); the paths kept are the same, bit for bit with OpenBLAS.
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword).

    Returns
    -------
    SamplePaths
        A :class:`control.TimeResponseData` with ``outputs`` ``[p, trial,
        time]``, ``states`` ``[n, trial, time]`` and ``inputs`` ``[m, trial,
        time]``, the realised ``w`` (deterministic part plus sampled noise).
        A signal not kept has no rows (shape ``(0, trials, T)``).

    Raises
    ------
    TypeError
        Unknown keyword.
    ValueError
        Bad ``timepts`` (see :func:`control_ncs.moments`), ``trials``,
        ``chunk``, ``workers``, ``signals``, complex or non-finite
        ``inputs`` or ``initial_state``, or a covariance that is not
        symmetric positive semidefinite.
    ControlDimension
        Arrays of the wrong shape.
    ControlArgument
        Bad ``seed`` or ``progress``.
    ValueError
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

    >>> from control_ncs.responses import simulate
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> paths = ncs.simulate(sys, 4, initial_state=[1.0], trials=3, seed=0)
    >>> paths.outputs.shape
    (1, 3, 4)
    >>> bool(np.all(np.isin(paths.outputs, [0, 1, 2, 4, 8])))
    True

    Keeping only the outputs of a large run:

    >>> z = ncs.simulate(sys, 4, initial_state=[1.0], trials=3, seed=0,
    ...                  signals="outputs")
    >>> z.states.shape, bool(np.array_equal(z.outputs, paths.outputs))
    ((0, 3, 4), True)
    """
    no_extra_kwargs("simulate", kwargs)
    sys = as_jump(sys)
    _check_initial_size(sys, initial_state)
    run = prepare(sys, timepts, inputs, initial_state, trials=trials,
                  seed=seed, noise_covariance=noise_covariance,
                  initial_covariance=initial_covariance, chunk=chunk)
    workers = positive_int(workers, "workers", allow_none=True)
    progress_check(progress)
    names = signal_names(signals)
    title = f"Sample paths of {run.sys.name} ({run.trials} trials)"
    paths, store = _empty_paths(run, run.trials, title, names)
    run_chunks(run, store, workers, progress)
    return paths


def _check_initial_size(sys: JumpStateSpace, initial_state: Any) -> None:
    """An initial state of the wrong size, named against ``jump_states``:
    ``sys.nstates`` is the face's order (``M·n`` for Markov modes), not
    the loop's state dimension ``n``."""
    n = len(sys.jump_states)
    size = np.size(initial_state) if np.ndim(initial_state) == 1 else None
    if size is None or size == n:
        return
    face = (f"; sys.nstates = {size} is the order of the StateSpace face "
            f"(the Markov mean: {sys.nmodes} modes × {n} states)"
            if size == sys.nstates else "")
    raise ControlDimension(
        f"initial_state: expected {n} entries, one per state of the loop "
        f"(sys.jump_states = {sys.jump_states}), got {size}{face}")


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
    sys = as_jump(sys)
    _check_initial_size(sys, initial_state)
    run = prepare(sys, timepts, inputs, initial_state, trials=trials,
                  seed=seed, noise_covariance=noise_covariance,
                  initial_covariance=initial_covariance, chunk=chunk)
    levels = _quantile_levels(quantiles)
    keep = positive_int(keep_paths, "keep_paths", allow_none=True)
    keep = run.trials if keep is None else min(keep, run.trials)
    s, T = run.sys, run.time.size
    title = f"{what} of {s.name}: mean and spread ({run.trials} trials)"
    if chunk is None:       # the chunk's storage is working memory here
        per_trial = (T + 1) * Storage.rows(run)
        run.chunk = min(run.chunk, max(1, CHUNK_FLOATS // per_trial))
    paths, kept = _empty_paths(run, keep, title)
    assert isinstance(kept, Storage)     # every signal: all rows kept
    stats = ensemble_statistics(run, levels, kept, progress, kind)
    exact = moments(s, run.time, run.w, run.x0,
                    noise_covariance=None if run.noise is None
                    else run.noise @ run.noise.T,
                    initial_covariance=None if run.spread is None
                    else run.spread @ run.spread.T)
    return EnsembleResponse(
        time=run.time, inputs=run.w, kind=kind, trials=run.trials,
        quantiles=levels, sample_mean=stats.mean, sample_cov=stats.cov,
        quantile_values=stats.quantiles, states_sample_mean=stats.states_mean,
        exact=exact, paths=paths, title=title)


def default_steps(sys: Any) -> int:
    """Default horizon of the ensemble responses, in steps.

    The number of steps after which ``E‖ξ‖²`` of the unforced system has
    decayed by ``1e-4`` (RMS by 1 %) at the per-step mean-square rate
    :func:`control_ncs.ms_radius` (which bounds the decay of the mean as
    well), clipped to ``[20, 1000]``; 50 steps for a system that is not
    mean-square stable. Rounded up to whole periods.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace

    Returns
    -------
    int
        A multiple of the period.

    Examples
    --------
    ``ms_radius = 0.8``: ``0.8^t < 1e-4`` from ``t = 42``:

    >>> from control_ncs.responses import default_steps
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> default_steps(sys)
    42
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
        Trials simulated together (memory bound). Does not change the
        sample paths (as in :func:`simulate`); the statistics, accumulated
        chunk by chunk, agree to rounding.
    progress : bool or None, optional
        Show a progress bar (needs ``tqdm``); None: only where a person
        watches (a terminal or a notebook).
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword)."""


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
    >>> from control_ncs.responses import forced_response
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.forced_response(sys, 3, initial_state=[1.0], trials=2000, seed=1)
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
    >>> from control_ncs.responses import step_response
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.step_response(sys, 20, trials=500, seed=0)
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
    >>> from control_ncs.responses import impulse_response
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> ncs.impulse_response(sys, 4, trials=10, seed=0).exact_mean.round(4).tolist()
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
    """Ensemble response to an initial state (``w = 0``).

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
    >>> from control_ncs.responses import initial_response
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.initial_response(sys, 3, [1.0], trials=10, seed=0)
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


def _with_options(doc: str) -> str:
    """``doc`` with ``{options}`` replaced by :data:`_OPTIONS_DOC`, indented
    as the placeholder is (Python 3.13 dedents docstrings when it compiles
    them, older Pythons keep the source's indentation)."""
    line = next(ln for ln in doc.splitlines() if "{options}" in ln)
    indent = line[:len(line) - len(line.lstrip())]
    lines = textwrap.dedent("    " + _OPTIONS_DOC).splitlines()
    return doc.replace("{options}", ("\n" + indent).join(lines).lstrip())


for _f in (forced_response, step_response, impulse_response, initial_response):
    if _f.__doc__:                 # None under python -OO
        _f.__doc__ = _with_options(_f.__doc__)
del _f


def _response_method(func: Any) -> Any:
    def method(self: JumpStateSpace, *args: Any, **kwargs: Any) -> Any:
        return func(self, *args, **kwargs)

    method.__name__ = func.__name__
    method.__qualname__ = f"JumpStateSpace.{func.__name__}"
    method.__doc__ = (
        f"The exact ensemble response at the base rate (any period).\n\n"
        f"``sys.{func.__name__}(...)`` is :func:`control_ncs.{func.__name__}`"
        f" ``(sys, ...)``, as python-control's ``LTI.{func.__name__}`` is\n"
        f"its module function: exact ``E z`` for every period, with Monte "
        f"Carlo\npaths and bands, where python-control's function would "
        f"simulate the\n(lifted) mean face.\n")
    return method


# python-control's LTI response methods call its own functions on the
# mean face; a jump system answers with the exact ensemble response
# (attached here, where the responses live: jump.py imports nothing above)
for _func in (forced_response, step_response, impulse_response,
              initial_response):
    setattr(JumpStateSpace, _func.__name__, _response_method(_func))
