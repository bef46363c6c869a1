"""The Monte Carlo engine behind :func:`control_ncs.simulate`.

Draws sample paths of a :class:`~control_ncs.jump.JumpStateSpace`
(:ref:`theory-jump-system`) for many trials at once: the random streams, the
low-rank step of all trials, the time-major storage, chunks and threads. The
public functions and their result types are in :mod:`control_ncs.responses`.

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
depend on ``chunk`` or ``workers``, the first ``k`` trials of a run are the
run with ``trials=k``, and adding noise does not change the mode sequences
(common random numbers when comparing designs). "Does not depend" is
bit for bit where the BLAS computes every column of a product alike
(OpenBLAS, numpy's own builds; see :func:`columnwise_product`), and to
rounding (relative 1e-12) with any BLAS.

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
Besides its result, a chunk holds one byte per trial, step and mode
besides the base mode for its mode draws, ``2r`` floats per trial and step
for white noise (``r = rank W``, none without noise), and an ensemble
response one chunk's storage. :func:`simulate` returns every path
(``trials · T · (n + p + m)`` floats, plus ``rank`` rows of ``s`` per step)
in place, or, with ``signals=``, only the paths asked for, each step of a
chunk passing through one working slab (:class:`Kept`: 1.0–1.1× the
returned arrays, against 1.2× for every path; docs/benchmarks.md); the
ensemble responses keep only
``keep_paths`` full paths and accumulate mean and covariance chunk by chunk,
so their memory is bounded unless quantiles are asked for (exact quantiles
need every trial's outputs, ``p · trials · T`` floats; pass
``quantiles=()`` for bounded memory).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Iterator, NamedTuple

import numpy as np
from control.exception import ControlArgument
from scipy.special import ndtri

from ._checks import positive_int
from ._tasks import progress_bar, progress_check
from .jump import JumpStateSpace, as_jump
from .meancov import covariance, initial_mean, input_signal, time_grid

__all__: list[str] = []

#: Streams keyed by the run's entropy (fixed: changing them changes results).
_MODES, _NOISE, _INITIAL = 0, 1, 2
#: Working memory of one chunk (its random numbers), in floats (32 MB).
CHUNK_FLOATS = 1 << 22
#: Trials per chunk: one step touches its rows of the storage for every
#: trial of the chunk, ``rows × chunk`` floats, kept within a core's cache.
STEP_FLOATS = 1 << 15
#: OpenBLAS multiplies on one thread up to m·n·k = 2**18 (default build) and
#: on all threads above. A product per step that waits for a second thread
#: stalls for whole scheduler slices on a busy machine (measured 5-80×
#: slower), so each product covers at most that many trials' columns (but
#: at least MIN_COLUMNS, where call overhead would dominate).
GEMM_SERIAL, MIN_COLUMNS = 1 << 18, 16


# -- arguments ----------------------------------------------------------------
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


def root_entropy(seed: Any) -> list[int]:
    """The run's entropy: four 63-bit integers drawn from ``seed``."""
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
class Run:
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


def prepare(sys: Any, timepts: Any, inputs: Any, initial_state: Any, *,
            trials: Any, seed: Any, noise_covariance: Any,
            initial_covariance: Any, chunk: Any) -> Run:
    """Check every argument of a run once, at the public boundary."""
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
    run = Run(sys, _phases(sys.modes), t, w, x0, noise, spread,
               root_entropy(seed), trials, trials)
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
    #: per mode, the index in ``parts`` of the part it uses (-1: the base);
    #: Markov modes are not merged, so modes with equal matrices share a part
    part_of: np.ndarray


def _phases(modes: Any) -> list[_Phase]:
    n, m = modes.B.shape[-2:]
    eps = np.finfo(float).eps
    phases = []
    for k in range(modes.period):
        M = np.concatenate([np.concatenate([modes.C[k], modes.D[k]], axis=2),
                            np.concatenate([modes.A[k], modes.B[k]], axis=2)],
                           axis=1)
        p_k = modes.probabilities[k]
        # a Markov chain may visit a mode of zero stationary probability
        # (from its initial law): keep every mode then
        live = (np.flatnonzero(p_k > 0) if modes.is_iid
                else np.arange(p_k.size))
        base = live[np.argmax(p_k[live])]
        Us: list[np.ndarray] = []
        Vs: list[np.ndarray] = []
        parts: list[tuple[int, slice]] = []
        r = 0
        part_of = np.full(p_k.size, -1)
        for i in live:
            # (i.i.d. masks draw one mode per part: share parts only for
            # Markov modes, which are never merged)
            same = [] if modes.is_iid else [
                j for j, (i0, _) in enumerate(parts)
                if np.array_equal(M[i], M[i0])]
            if same:
                part_of[i] = same[0]
                continue
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
            Us.append(Ui)
            Vs.append(Vi)
            part_of[i] = len(parts)
            parts.append((int(i), slice(r, r + rank)))
            r += rank
        G = np.concatenate([M[base]] + Us, axis=1)
        V = np.concatenate(Vs) if Vs else np.zeros((0, n + m))
        phases.append(_Phase(G, V, tuple(parts), part_of))
    return phases


#: Trials whose mode draws are read at once when building a chunk's masks
#: (the uniforms are transient: ``DRAW_TRIALS · T`` floats).
DRAW_TRIALS = 256


def _mode_masks(run: Run, a: int, c: int) -> np.ndarray:
    """``mask[t, j]``: True for the trials in the ``j``-th non-base mode of
    phase ``t mod N`` at step ``t``; shape (T, q, c), one byte per entry."""
    phases = run.phases
    q = max(len(ph.parts) for ph in phases)
    T, N = run.time.size, len(phases)
    if q == 0:                          # one mode per phase: nothing to draw
        return np.empty((T, 0, c), dtype=bool)
    if not run.sys.modes.is_iid:
        return _markov_masks(run, a, c, q)
    cdf = np.cumsum(run.sys.modes.probabilities, axis=1)
    cdf /= cdf[:, -1:]
    lower = np.concatenate([np.zeros((N, 1)), cdf[:, :-1]], axis=1)
    mask = np.empty((T, q, c), dtype=bool)
    for j0 in range(0, c, DRAW_TRIALS):
        cols = slice(j0, min(j0 + DRAW_TRIALS, c))
        # mode i iff cdf[i-1] <= u < cdf[i] (searchsorted(cdf, u, 'right')
        # == i)
        draws = run.uniforms(_MODES, a + j0, cols.stop - j0, T).T
        for k, ph in enumerate(phases):
            u = draws[k::N]
            for j, (i, _) in enumerate(ph.parts):
                lo, hi, out = lower[k, i], cdf[k, i], mask[k::N, j, cols]
                if lo <= 0.0:
                    np.less(u, hi, out=out)
                elif hi >= 1.0:
                    np.greater_equal(u, lo, out=out)
                else:
                    np.logical_and(u >= lo, u < hi, out=out)
    return mask


def _markov_masks(run: Run, a: int, c: int, q: int) -> np.ndarray:
    """As :func:`_mode_masks` for Markov modes (:ref:`theory-markov`): per
    trial the chain starts from ``modes.start()`` and moves by ``T_k``; uniform
    ``t`` of a trial draws its mode at step ``t`` (inverse CDF), so the stream
    is
    the i.i.d. engine's."""
    modes = run.sys.modes
    T, N, M = run.time.size, modes.period, modes.count
    cdf = np.cumsum(modes.transitions(), axis=2)           # (N, M, M)
    cdf /= cdf[:, :, -1:]
    # row i of T_k shifted into [i, i+1]: one searchsorted of σ + u in the
    # flattened rows finds mode j iff cdf[σ, j-1] <= u < cdf[σ, j]
    flat = (cdf + np.arange(M)[:, None]).reshape(N, M * M)
    start = np.cumsum(modes.start())
    start /= start[-1]
    draws = np.ascontiguousarray(run.uniforms(_MODES, a, c, T).T)  # (T, c)
    mask = np.empty((T, q, c), dtype=bool)
    which = np.arange(q)[:, None]
    sigma = np.minimum(np.searchsorted(start, draws[0], side="right"), M - 1)
    for t in range(T):
        if t:
            k = (t - 1) % N
            pos = np.searchsorted(flat[k], draws[t] + sigma, side="right")
            # M entries per row below σ were counted
            sigma = np.minimum(pos - M * sigma, M - 1)
        part = run.phases[t % N].part_of[sigma]
        np.equal(part[None], which, out=mask[t], casting="unsafe")
    return mask


def _default_chunk(run: Run) -> int:
    rows = Storage.rows(run)
    q = max(len(ph.parts) for ph in run.phases)
    r = 0 if run.noise is None else run.noise.shape[1]
    by_memory = CHUNK_FLOATS // (run.time.size * (1 + q + 2 * r) + 1)
    return max(1, min(by_memory, STEP_FLOATS // rows))


@dataclass
class Storage:
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
    def layout(run: Run) -> tuple[int, int, int]:
        """``n``, ``m`` and the first row of ``z`` in a slab."""
        n, n_m = run.x0.size, run.phases[0].V.shape[1]
        return n, n_m - n, n_m + max(ph.V.shape[0] for ph in run.phases)

    @staticmethod
    def rows(run: Run) -> int:
        n, _, zrow = Storage.layout(run)
        return zrow + run.phases[0].G.shape[0] - n

    @classmethod
    def empty(cls, run: Run, trials: int) -> Storage:
        shape = (run.time.size + 1, cls.rows(run), trials)
        try:
            slabs = np.empty(shape)
        except (MemoryError, ValueError):
            gib = math.prod(shape) * 8 / 2**30
            raise ValueError(
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


def simulate_chunk(run: Run, a: int, b: int, store: Storage,
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
        slabs[0, :n] += columnwise_product(
            run.spread, run.normals(_INITIAL, a, c, r0).T)
    mask = _mode_masks(run, a, c)
    width = max(MIN_COLUMNS, GEMM_SERIAL // max(ph.G.size for ph in phases))
    blocks = [slice(j, j + width) for j in range(0, c, width)]
    for t in range(T):
        G, V, parts, _ = phases[t % N]
        row = t * R
        r = V.shape[0]
        if r:
            s = flat[row + n + m:row + n + m + r]
            columnwise_product(V, flat[row:row + n + m], out=s)
            if len(parts) == 1:
                s *= mask[t, 0]
            else:
                for q, (_, rows) in enumerate(parts):
                    s[rows] *= mask[t, q]
        into, out = flat[row:row + n + m + r], flat[row + zrow:row + R + n]
        for cols in blocks:
            columnwise_product(G, into[:, cols], out=out[:, cols])
        if bar is not None:
            bar.update(1)


#: The signals a run can keep, in the order of their rows in a slab.
SIGNALS = ("states", "inputs", "outputs")


def signal_names(signals: Any) -> tuple:
    """The signals a run keeps, as a tuple of :data:`SIGNALS` names."""
    names = (signals,) if isinstance(signals, str) else signals
    try:
        names = tuple(names)
    except TypeError:
        names = ()
    if not names or not all(isinstance(k, str) and k in SIGNALS
                            for k in names):
        raise ValueError(
            f"signals: expected 'states', 'outputs' or 'inputs', or a "
            f"sequence of them, got {signals!r}")
    return tuple(k for k in SIGNALS if k in names)


@dataclass
class Kept:
    """Some signals of ``trials`` trials, each its own time-major array.

    ``arrays[name]`` is (T, rows, trials) for ``name`` in :data:`SIGNALS`
    kept; the (signal, trial, time) views of :meth:`views` are what
    :class:`~control_ncs.responses.SamplePaths` holds. A run that keeps
    only some signals never stores the others: :func:`simulate_kept`
    advances each chunk through one step's working slab and copies the
    kept rows out, so memory is the kept arrays plus one slab per chunk.
    """

    arrays: dict

    @classmethod
    def empty(cls, run: Run, trials: int, names: tuple) -> Kept:
        n, m, zrow = Storage.layout(run)
        p = Storage.rows(run) - zrow
        rows = dict(states=n, inputs=m, outputs=p)
        T = run.time.size
        size = sum(rows[k] for k in names) * T * trials
        try:
            arrays = {k: np.empty((T, rows[k], trials)) for k in names}
        except (MemoryError, ValueError):
            raise ValueError(
                f"trials, timepts: {trials} paths of {T} steps of "
                f"{', '.join(names)} need {size * 8 / 2**30:.3g} GiB; ask "
                f"for fewer trials, steps or signals") from None
        return cls(arrays)

    def views(self) -> dict:
        return {k: v.transpose(1, 2, 0) for k, v in self.arrays.items()}


def simulate_kept(run: Run, a: int, b: int, kept: Kept, bar: Any = None
                  ) -> None:
    """:func:`simulate_chunk` for trials ``a .. b-1`` keeping only the
    signals of ``kept`` (columns ``a .. b-1``): the same draws and products
    on a one-step slab ``[ξ_t; w_t; s_t]``, the kept rows copied out."""
    n, m, zrow = Storage.layout(run)
    c, T = b - a, run.time.size
    phases = run.phases
    N = len(phases)
    R = zrow
    slab = np.empty((R, c))
    zx = np.empty((phases[0].G.shape[0], c))
    p = zx.shape[0] - n
    white = None
    if run.noise is not None:
        r = run.noise.shape[1]
        white = np.matmul(run.noise, run.normals(_NOISE, a, c, T * r)
                          .reshape(c, T, r).transpose(1, 2, 0))
    slab[:n] = run.x0[:, None]
    if run.spread is not None:
        r0 = run.spread.shape[1]
        slab[:n] += columnwise_product(
            run.spread, run.normals(_INITIAL, a, c, r0).T)
    mask = _mode_masks(run, a, c)
    width = max(MIN_COLUMNS, GEMM_SERIAL // max(ph.G.size for ph in phases))
    blocks = [slice(j, j + width) for j in range(0, c, width)]
    x_out = kept.arrays.get("states")
    u_out = kept.arrays.get("inputs")
    z_out = kept.arrays.get("outputs")
    for t in range(T):
        G, V, parts, _ = phases[t % N]
        slab[n:n + m] = run.w[:, t, None]
        if white is not None:
            slab[n:n + m] += white[t]
        r = V.shape[0]
        if r:
            s = slab[n + m:n + m + r]
            columnwise_product(V, slab[:n + m], out=s)
            if len(parts) == 1:
                s *= mask[t, 0]
            else:
                for q, (_, rows) in enumerate(parts):
                    s[rows] *= mask[t, q]
        into = slab[:n + m + r]
        for cols in blocks:
            columnwise_product(G, into[:, cols], out=zx[:, cols])
        if x_out is not None:
            x_out[t, :, a:b] = slab[:n]
        if u_out is not None:
            u_out[t, :, a:b] = slab[n:n + m]
        if z_out is not None:
            z_out[t, :, a:b] = zx[:p]
        slab[:n] = zx[p:]
        if bar is not None:
            bar.update(1)


def columnwise_product(A: np.ndarray, X: np.ndarray,
                       out: np.ndarray | None = None) -> np.ndarray:
    """``A @ X``, each column computed alike whatever the width of ``X``.

    numpy hands a one-column product to ``gemv``, which sums in another
    order than ``gemm``: a trial alone in its chunk (or block) would differ
    in the last bits from the same trial beside others. A lone column is
    therefore multiplied beside a zero column, so that the paths do not
    depend on ``chunk`` (bit-identical with OpenBLAS, whose ``gemm`` treats
    every column alike).
    """
    if X.shape[1] != 1:
        return np.matmul(A, X, out=out)
    pair = np.zeros((X.shape[0], 2))
    pair[:, :1] = X
    col = np.matmul(A, pair)[:, :1]
    if out is None:
        return col
    out[...] = col
    return out


def run_chunks(run: Run, store: Storage | Kept, workers: int | None = None,
               progress: bool = False) -> None:
    """Simulate every trial of ``run`` into ``store`` (trial ``i`` in column
    ``i``), chunk by chunk, on ``workers`` threads (default one; at most
    one per chunk); a :class:`Kept` store keeps
    only its signals (:func:`simulate_kept`)."""
    chunks = list(run.chunks())
    workers = min(1 if workers is None else workers, len(chunks))
    with progress_bar(progress_check(progress), len(chunks) * run.time.size,
                      "simulate", "step") as bar:
        if isinstance(store, Kept):
            kept = store

            def one(ab: tuple[int, int], bar: Any = None) -> None:
                simulate_kept(run, ab[0], ab[1], kept, bar)
        else:
            whole = store

            def one(ab: tuple[int, int], bar: Any = None) -> None:
                simulate_chunk(run, ab[0], ab[1], whole, ab[0], bar)
        if workers <= 1:
            for ab in chunks:
                one(ab, bar)
        else:
            # Chunks write disjoint trial columns of ``store`` and draw from
            # their own random streams, so the order of completion does not
            # matter (tests/test_simulate.py checks equality with one
            # worker). Measured (n = 32, 5000 trials, 2 cores): 1.3x.
            # The bar is advanced here, in the calling thread, once per
            # finished chunk (tqdm's counter is not updated under a lock).
            with ThreadPoolExecutor(workers) as pool:
                try:
                    for _ in pool.map(one, chunks):
                        if bar is not None:
                            bar.update(run.time.size)
                except BaseException:
                    pool.shutdown(wait=True, cancel_futures=True)
                    raise


class Statistics(NamedTuple):
    """Ensemble statistics over all trials (time is the last axis)."""

    mean: np.ndarray             # (p, T) sample mean of the outputs
    cov: np.ndarray              # (p, p, T) sample covariance, ddof=1
    quantiles: np.ndarray        # (levels, p, T)
    states_mean: np.ndarray      # (n, T) sample mean of the states


def ensemble_statistics(run: Run, levels: tuple, kept: Storage,
                        progress: bool = False, desc: str = "ensemble"
                        ) -> Statistics:
    """Simulate ``run`` chunk by chunk into one chunk's storage, keep its
    first trials in ``kept`` and accumulate the statistics, so that memory
    stays bounded unless quantiles (which need every trial) are asked for."""
    T = run.time.size
    store = Storage.empty(run, run.chunk)
    n, zrow = store.n, store.zrow
    p = store.slabs.shape[1] - zrow
    keep = kept.slabs.shape[2]
    try:
        everything = np.empty((p, run.trials, T)) if levels else None
    except (MemoryError, ValueError):
        raise ValueError(
            f"quantiles: exact quantiles keep every trial's outputs "
            f"({p * run.trials * T} floats); pass quantiles=() for bounded "
            f"memory") from None
    count, mean, M2 = 0, np.zeros((T, p)), np.zeros((T, p, p))
    states_sum = np.zeros((T, n))
    nchunks = -(-run.trials // run.chunk)
    with progress_bar(progress_check(progress), nchunks * T, desc,
                      "step") as bar:
        for a, b in run.chunks():
            c = b - a
            simulate_chunk(run, a, b, store, 0, bar)
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
    qv = np.quantile(everything, levels, axis=1) if everything is not None \
        else np.zeros((0, p, T))
    return Statistics(mean.T.copy(), cov.transpose(1, 2, 0).copy(), qv,
                      (states_sum / count).T.copy())
