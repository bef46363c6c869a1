"""simulate(signals=...): keeping only some sample paths gives the same
paths as keeping all of them, and holds memory for those paths only."""

import tracemalloc

import numpy as np
import pytest

import control_ncs as cn
from control_ncs import montecarlo
from control_ncs.responses import simulate
from helpers import random_jump

SUBSETS = ["outputs", "states", "inputs", ("outputs", "states"),
           ["inputs", "outputs"], ("states", "inputs")]


def _markov():
    rng = np.random.default_rng(3)
    base = random_jump(rng, n=4, N=2, M=3, m=2, p=2)
    m = base.modes
    T = [[[0.7, 0.2, 0.1], [0.3, 0.5, 0.2], [0.1, 0.1, 0.8]],
         [[0.5, 0.5, 0.0], [0.2, 0.6, 0.2], [0.0, 0.3, 0.7]]]
    return cn.jss(m.A, m.B, m.C, m.D, transition=T)


def _iid():
    rng = np.random.default_rng(4)
    return random_jump(rng, n=4, N=3, M=3, m=2, p=2)


def _run(sys, **kw):
    return simulate(sys, 17, [[1.0], [0.5]], np.ones(4), trials=53, seed=8,
                    noise_covariance=0.3 * np.eye(2),
                    initial_covariance=0.1 * np.eye(4), chunk=10, **kw)


@pytest.mark.parametrize("make", [_iid, _markov], ids=["iid", "markov"])
@pytest.mark.parametrize("signals", SUBSETS, ids=str)
def test_kept_paths_are_the_paths_of_the_whole_run(make, signals):
    sys = make()
    whole = _run(sys)
    part = _run(sys, signals=signals, workers=2)
    names = [signals] if isinstance(signals, str) else list(signals)
    for name in ("states", "outputs", "inputs"):
        got = getattr(part, name)
        if name in names:
            # the same draws and the same products: bit for bit
            assert np.array_equal(got, getattr(whole, name)), name
        else:
            assert got.shape == (0, 53, 17), name


def test_a_run_keeping_outputs_holds_memory_for_the_outputs_only():
    rng = np.random.default_rng(0)
    sys = random_jump(rng, n=12, N=1, M=2, m=1, p=1)
    tracemalloc.start()
    try:
        paths = simulate(sys, 300, 1.0, np.ones(12), trials=10000, seed=1,
                         signals="outputs", workers=1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # the paths asked for, plus a chunk's mode draws (one byte per trial
    # and step), one step's slab and the trace labels: not the 12 states
    # and the input
    kept = paths.outputs.nbytes                     # 1 · 10000 · 300 floats
    whole = (12 + 1 + 1) * kept
    assert kept <= peak < 1.2 * kept < whole / 10


def test_kept_signals_are_labelled_and_counted():
    sys = _iid()
    part = _run(sys, signals=("outputs",))
    assert part.noutputs == 2 and part.nstates == 0 and part.ninputs == 0
    assert list(part.output_labels) == list(_run(sys).output_labels)
    assert part.trials == 53
    part.plot(paths=3)


@pytest.mark.parametrize("signals", [(), "state", ["outputs", "x"], 3, None])
def test_bad_signals_raise_naming_the_argument(signals):
    with pytest.raises(ValueError, match="^signals: "):
        _run(_iid(), signals=signals)


def test_mode_masks_do_not_depend_on_how_many_trials_are_drawn_at_once(
        monkeypatch):
    sys = _iid()
    whole = _run(sys)
    monkeypatch.setattr(montecarlo, "DRAW_TRIALS", 3)
    for name in ("states", "outputs", "inputs"):
        assert np.array_equal(getattr(_run(sys), name),
                              getattr(whole, name)), name
