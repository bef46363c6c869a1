"""Sample paths and ensemble responses (control_ncs.responses and its engine
control_ncs.montecarlo).

Statistical checks use fixed seeds and tolerances of a few standard errors
estimated from the same sample.
"""

import pickle

import matplotlib.pyplot as plt
import numpy as np
import pytest
import control as ct
from control.exception import ControlArgument, ControlDimension

import control_ncs as cn
from control_ncs import _tasks, montecarlo
from control_ncs._tasks import tqdm_check
from control_ncs.plots import plot_ensemble
from control_ncs.responses import (EnsembleResponse, SamplePaths,
                                   default_steps, forced_response,
                                   impulse_response, initial_response,
                                   simulate, step_response)
from helpers import random_jump

# A generalized plant with two disturbances, two performance outputs and one
# control input (inputs [w; u], outputs [z; y], y = x).
A = [[1.1, 0.2], [0.0, 0.9]]
B = [[0.5, 0.1, 1.0], [1.0, 0.0, 0.5]]
C = [[1, 0], [0, 1], [1, 0], [0, 1]]
D = [[0.2, 0, 0], [0, 0.1, 0.3], [0, 0, 0], [0, 0, 0]]
K = [[-0.8, -0.3]]
LOSSES = dict(sensor_loss=0.1, actuator_loss=0.2)
W_SINGULAR = [[1.0, 1.0], [1.0, 1.0]]          # rank one


def plant(**network):
    return cn.nss(A, B, C, D, 0.1, nmeas=2, ncon=1, **LOSSES, **network)


def closed_loop(kind):
    """Closed loops of every kind: controller, actuator, schedule."""
    if kind == "static-zero":
        CL = cn.feedback(plant(), K)
    elif kind == "static-hold":
        CL = cn.feedback(plant(), K, actuator="hold")
    elif kind == "predictor-zero":
        CL = cn.feedback(plant(), K, controller="predictor")
    elif kind == "predictor-hold":
        CL = cn.feedback(plant(), [[-0.8, -0.3, 0.0]], controller="predictor",
                         actuator="hold")
    elif kind == "static-scheduled":          # N = 2, one sensor per step
        CL = cn.feedback(plant(sensor_schedule=[1, 2]), K)
    elif kind == "predictor-shared-channel":  # N = 3, one message per step
        CL = cn.feedback(plant(sensor_schedule=[1, 2, 0],
                               actuator_schedule=[0, 0, 1],
                               shared_channel=True), K, controller="predictor")
    else:
        raise ValueError(kind)
    assert cn.ms_radius(CL) < 1
    return CL


KINDS = ["static-zero", "static-hold", "predictor-zero", "predictor-hold",
         "static-scheduled", "predictor-shared-channel"]


@pytest.fixture(autouse=True)
def _close_figures():
    plt.close("all")
    yield
    plt.close("all")


def assert_within_standard_errors(sample, exact, values, k=5.0):
    """``|sample - exact| <= k·SE + tiny``, SE from the per-trial ``values``
    (trial axis 1)."""
    se = values.std(axis=1, ddof=1) / np.sqrt(values.shape[1])
    err = np.abs(sample - exact)
    worst = np.max(err - k * se)
    assert worst <= 1e-9, f"{np.max(err / np.maximum(se, 1e-300)):.2f} SE off"


def check_moments(paths, exact_mean, exact_cov, k=5.0):
    """Sample mean and covariance of ``paths`` [signal, trial, time] against
    exact ones, each within ``k`` standard errors."""
    assert_within_standard_errors(paths.mean(axis=1), exact_mean, paths, k)
    dev = paths - paths.mean(axis=1, keepdims=True)
    products = np.einsum("ict,jct->ijct", dev, dev)
    q = products.shape[0]
    products = products.reshape(q * q, products.shape[2], -1)
    sample_cov = products.mean(axis=1)
    assert_within_standard_errors(sample_cov, exact_cov.reshape(q * q, -1),
                                  products, k)


# -- convergence to the exact moments (theory: moments) --------------------------------
@pytest.mark.parametrize("noise", [None, W_SINGULAR], ids=["no-noise", "noise"])
@pytest.mark.parametrize("kind", KINDS)
def test_sample_mean_and_covariance_converge_to_exact_moments(kind, noise):
    # Rare runs of losses make these distributions heavy-tailed; horizon and
    # sample size keep the sample's own standard errors trustworthy.
    CL = closed_loop(kind)
    T = 8
    w = np.vstack([np.ones(T), 0.5 * np.sin(np.arange(T))])
    x0 = np.linspace(1.0, -0.5, CL.nstates)
    paths = simulate(CL, T, w, x0, trials=10000, seed=11,
                     noise_covariance=noise)
    exact = cn.moments(CL, T, w, x0, noise_covariance=noise)
    check_moments(paths.states, exact.states_mean, exact.states_cov)
    check_moments(paths.outputs, exact.outputs_mean, exact.outputs_cov)


def test_random_initial_state_matches_exact_moments():
    CL = closed_loop("static-zero")
    P0 = [[0.5, 0.1], [0.1, 0.2]]
    paths = simulate(CL, 6, trials=20000, seed=3, initial_state=[1.0, 0.0],
                     initial_covariance=P0)
    exact = cn.moments(CL, 6, initial_state=[1.0, 0.0], initial_covariance=P0)
    check_moments(paths.states, exact.states_mean, exact.states_cov)


def test_realised_inputs_are_deterministic_part_plus_white_noise():
    CL = closed_loop("static-zero")
    w = np.array([[1.0], [-0.5]])
    paths = simulate(CL, 8, w, trials=3000, seed=5,
                     noise_covariance=W_SINGULAR)
    exact_w = np.broadcast_to(w, (2, 8))
    check_moments(paths.inputs, exact_w,
                  np.broadcast_to(np.array(W_SINGULAR)[..., None], (2, 2, 8)))
    # rank one: both channels carry the same noise
    np.testing.assert_allclose(paths.inputs[0] - 1.0, paths.inputs[1] + 0.5,
                               atol=1e-12)


def test_noise_free_inputs_are_the_given_signal():
    CL = closed_loop("static-zero")
    w = np.vstack([np.arange(6.0), np.ones(6)])
    paths = simulate(CL, 6, w, trials=4, seed=0)
    assert np.array_equal(paths.inputs, np.repeat(w[:, None], 4, axis=1))


def test_deterministic_statespace_reproduces_forced_response():
    G = ct.ss([[0.5, 0.1], [0.0, 0.8]], [[1.0], [0.5]], [[1.0, -1.0]], [[0.2]],
              0.1)
    u = np.sin(np.arange(15))
    paths = simulate(G, 15, u, [1.0, 2.0], trials=3, seed=0)
    ref = ct.forced_response(G, np.arange(15) * 0.1, u, [1.0, 2.0])
    for i in range(3):
        np.testing.assert_allclose(paths.outputs[0, i], ref.outputs,
                                   atol=1e-12)


def test_each_noisy_trial_replays_through_forced_response():
    # the realised inputs are exactly what drove each trial (noise in B and D)
    G = ct.ss([[0.5, 0.1], [0.0, 0.8]], [[1.0, 0.0], [0.5, 1.0]],
              [[1.0, -1.0]], [[0.2, 0.3]], True)
    paths = simulate(G, 10, trials=3, seed=2, noise_covariance=np.eye(2))
    for i in range(3):
        ref = ct.forced_response(G, np.arange(10), paths.inputs[:, i])
        np.testing.assert_allclose(paths.outputs[0, i], ref.outputs[0],
                                   atol=1e-12)


def test_paths_are_shaped_signal_trial_time_with_trace_labels():
    CL = closed_loop("predictor-zero")
    paths = simulate(CL, 7, trials=5, seed=0)
    assert isinstance(paths, ct.TimeResponseData)
    assert paths.outputs.shape == (2, 5, 7)
    assert paths.states.shape == (CL.nstates, 5, 7)
    assert paths.inputs.shape == (2, 5, 7)
    assert paths.trials == paths.ntraces == 5
    assert paths.trace_labels == [f"trial {i}" for i in range(5)]
    assert paths.trace_types == ["forced"] * 5
    assert paths.output_labels == CL.jump_outputs


def test_one_trial_keeps_the_trial_axis():
    paths = simulate(closed_loop("static-zero"), 5, trials=1, seed=0)
    assert paths.outputs.shape == (2, 1, 5)


# -- reproducibility -----------------------------------------------------------
def run(seed, **kw):
    kw.setdefault("trials", 50)
    return simulate(closed_loop("static-scheduled"), 9, [[1.0], [0.0]],
                    [0.3, -0.2], seed=seed, noise_covariance=0.1 * np.eye(2),
                    **kw)


def test_same_seed_gives_identical_paths():
    a, b = run(4), run(4)
    assert np.array_equal(a.outputs, b.outputs)
    assert np.array_equal(a.states, b.states)
    assert np.array_equal(a.inputs, b.inputs)


def test_different_seeds_give_different_paths():
    assert not np.allclose(run(4).outputs, run(5).outputs)


def test_generator_is_used_and_advanced():
    rng = np.random.default_rng(7)
    before = rng.bit_generator.state
    first = run(rng)
    assert rng.bit_generator.state != before
    assert not np.allclose(run(rng).outputs, first.outputs)


def test_int_seed_is_the_generator_it_seeds():
    assert np.array_equal(run(7).outputs,
                          run(np.random.default_rng(7)).outputs)


def test_global_random_state_is_untouched():
    np.random.seed(123)
    before = np.random.get_state()
    run(None)
    run(1)
    step_response(closed_loop("static-zero"), 5, input=0, trials=10, seed=2)
    after = np.random.get_state()
    assert before[0] == after[0]
    assert np.array_equal(before[1], after[1])
    assert before[2:] == after[2:]


def blas_name():
    try:
        return np.show_config(mode="dicts")["Build Dependencies"]["blas"][
            "name"].lower()
    except Exception:           # older numpy: no dict form
        return ""


def assert_same_paths(a, b):
    """Bit-identical where the BLAS computes a column of a product the same
    way whatever the product's width (OpenBLAS, numpy's wheels); otherwise
    equal to rounding, as documented."""
    for name in ("outputs", "states", "inputs"):
        x, y = getattr(a, name), getattr(b, name)
        if "openblas" in blas_name():
            assert np.array_equal(x, y), (name, np.max(np.abs(x - y)))
        else:
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("chunk", [1, 2, 7, 17, 64, 1000])
def test_chunking_does_not_change_the_paths(chunk):
    # 120 = 17·7 + 1: chunks of 7 and 17 end with a one-trial chunk
    whole = run(9, trials=120)
    assert_same_paths(run(9, trials=120, chunk=chunk), whole)


@pytest.mark.parametrize("chunk", [1, 3])
def test_chunking_does_not_change_random_initial_states(chunk):
    CL = closed_loop("predictor-hold")
    args = dict(trials=10, seed=4, initial_covariance=0.2 * np.eye(CL.nstates))
    assert_same_paths(simulate(CL, 6, chunk=chunk, **args),
                      simulate(CL, 6, **args))


@pytest.mark.parametrize("workers", [2, 3, None])
def test_worker_threads_do_not_change_the_paths(workers):
    # many small chunks, so that several threads really run side by side
    one = run(5, trials=150, chunk=7, workers=1)
    many = run(5, trials=150, chunk=7, workers=workers)
    for name in ("outputs", "states", "inputs"):
        assert np.array_equal(getattr(many, name), getattr(one, name)), name


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_bad_workers_raise_naming_the_argument(workers):
    with pytest.raises(ValueError, match="^workers: "):
        run(5, trials=10, workers=workers)


def test_first_trials_do_not_depend_on_the_number_of_trials():
    few, many = run(3, trials=1), run(3, trials=200)
    assert_same_paths(few, run(3, trials=1, chunk=1))
    for name in ("outputs", "states", "inputs"):
        x, y = getattr(many, name)[:, :1], getattr(few, name)
        if "openblas" in blas_name():
            assert np.array_equal(x, y), name
        else:
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-14)


def reference_paths(sys, T, inputs, x0, trials, seed):
    """Trial by trial and step by step, from the documented mode stream
    (trial ``i`` reads uniforms ``i·T .. i·T+T-1``, mode ``i`` of phase
    ``k`` where the cumulative probabilities first exceed the uniform),
    driven by the realised ``inputs`` [input, trial, time]."""
    entropy = montecarlo.root_entropy(seed)
    modes = sys.modes
    cdf = np.cumsum(modes.probabilities, axis=1)
    cdf /= cdf[:, -1:]
    n, p = modes.A.shape[-1], modes.C.shape[-2]
    X, Z = np.empty((n, trials, T)), np.empty((p, trials, T))
    for j in range(trials):
        bits = np.random.PCG64(np.random.SeedSequence(entropy,
                                                      spawn_key=(0,)))
        bits.advance(j * T)
        u = np.random.Generator(bits).random(T)
        x = np.array(x0, dtype=float)
        for t in range(T):
            k = t % sys.period
            i = np.searchsorted(cdf[k], u[t], side="right")
            w = inputs[:, j, t]
            X[:, j, t] = x
            Z[:, j, t] = modes.C[k, i] @ x + modes.D[k, i] @ w
            x = modes.A[k, i] @ x + modes.B[k, i] @ w
    return X, Z


def test_paths_follow_the_documented_streams_mode_by_mode():
    # Three phases: dense (full-rank) mode differences, a mode that never
    # occurs, and a phase with one possible mode.
    rng = np.random.default_rng(42)
    base = random_jump(rng, n=3, N=3, M=4, m=2, p=2)
    prob = [[0.5, 0.3, 0.2, 0.0], [0.0, 0.6, 0.0, 0.4], [0.0, 0.0, 1.0, 0.0]]
    m = base.modes
    sys = cn.jss(m.A, m.B, m.C, m.D, prob)
    T, x0 = 13, [1.0, -0.5, 0.2]
    paths = simulate(sys, T, [[1.0], [0.3]], x0, trials=40, seed=6,
                     noise_covariance=0.5 * np.eye(2))
    X, Z = reference_paths(sys, T, paths.inputs, x0, 40, 6)
    np.testing.assert_allclose(paths.states, X, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(paths.outputs, Z, rtol=1e-10, atol=1e-12)


def test_products_split_by_trials_give_the_same_paths(monkeypatch):
    whole = run(9, trials=120, chunk=120)
    monkeypatch.setattr(montecarlo, "GEMM_SERIAL", 1)
    monkeypatch.setattr(montecarlo, "MIN_COLUMNS", 7)   # 18 products
    split = run(9, trials=120, chunk=120)       # the last product: 1 column
    assert_same_paths(split, whole)


def test_ensemble_statistics_do_not_depend_on_chunk_beyond_rounding():
    CL = closed_loop("static-hold")
    args = dict(input=0, trials=50, seed=8, noise_covariance=W_SINGULAR)
    one, many = (step_response(CL, 12, chunk=1, **args),
                 step_response(CL, 12, chunk=16, **args))
    assert_same_paths(one.paths, many.paths)
    np.testing.assert_allclose(one.sample_mean, many.sample_mean, rtol=1e-12,
                               atol=1e-14)
    np.testing.assert_allclose(one.sample_cov, many.sample_cov, rtol=1e-11,
                               atol=1e-14)
    assert np.array_equal(one.quantile_values, many.quantile_values)


def test_ensemble_paths_are_the_sample_paths_of_the_same_seed():
    CL = closed_loop("static-hold")
    kw = dict(trials=50, seed=8, noise_covariance=0.1 * np.eye(2))
    r = forced_response(CL, 9, [[1.0], [0.0]], keep_paths=None, chunk=16,
                        **kw)
    paths = simulate(CL, 9, [[1.0], [0.0]], **kw)
    np.testing.assert_allclose(r.paths.outputs, paths.outputs, rtol=1e-12,
                               atol=1e-14)
    np.testing.assert_allclose(r.paths.inputs, paths.inputs, rtol=1e-12,
                               atol=1e-14)


def test_noise_does_not_change_the_mode_sequences():
    # ξ1 records the modes (×2 or ×0.5), ξ2 only the noise
    sys = cn.jss([np.diag([2.0, 0.0]), np.diag([0.5, 0.0])], [[0.0], [1.0]],
                 np.eye(2), np.zeros((2, 1)), [0.5, 0.5])
    quiet = simulate(sys, 10, initial_state=[1.0, 0.0], trials=30, seed=2)
    noisy = simulate(sys, 10, initial_state=[1.0, 0.0], trials=30, seed=2,
                     noise_covariance=[[4.0]])
    assert np.array_equal(quiet.states[0], noisy.states[0])
    assert not np.allclose(quiet.states[1], noisy.states[1])


def test_bad_seed_is_rejected():
    with pytest.raises(ControlArgument, match="seed"):
        run("abc")


# -- argument checks -----------------------------------------------------------
def test_unknown_keyword_raises_type_error():
    CL = closed_loop("static-zero")
    with pytest.raises(TypeError, match="bogus"):
        simulate(CL, 5, bogus=1)
    for f in (step_response, impulse_response):
        with pytest.raises(TypeError, match="bogus"):
            f(CL, 5, input=0, bogus=1)
    with pytest.raises(TypeError, match="bogus"):
        initial_response(CL, 5, bogus=1)
    with pytest.raises(TypeError, match="bogus"):
        forced_response(CL, 5, bogus=1)


@pytest.mark.parametrize("trials", [0, 2.5, True])
def test_bad_trial_count_is_rejected(trials):
    with pytest.raises(ValueError, match="trials"):
        simulate(closed_loop("static-zero"), 5, trials=trials)


@pytest.mark.parametrize("W, error", [
    ([[1.0, 0.0], [0.0, -1.0]], ValueError),          # not PSD
    ([[1.0, 0.5], [0.0, 1.0]], ValueError),           # not symmetric
    (np.eye(3), ControlDimension),
])
def test_bad_noise_covariance_is_rejected(W, error):
    with pytest.raises(error, match="noise_covariance"):
        simulate(closed_loop("static-zero"), 5, noise_covariance=W)


def test_continuous_time_system_is_rejected():
    with pytest.raises(ValueError, match="discrete"):
        simulate(ct.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]]), 5)


def test_timepts_must_be_spaced_by_dt():
    with pytest.raises(ValueError, match="timepts"):
        simulate(closed_loop("static-zero"), [0.0, 0.1, 0.3])


# -- progress and memory -------------------------------------------------------
@pytest.mark.skipif(not tqdm_check(), reason="tqdm not installed")
@pytest.mark.parametrize("workers", [1, 2])
def test_progress_bar_is_shown(capsys, workers):
    simulate(closed_loop("static-zero"), 5, trials=10, seed=0, chunk=4,
             workers=workers, progress=True)
    err = capsys.readouterr().err
    assert "simulate" in err and "15/15" in err      # 3 chunks × 5 steps


def test_progress_without_tqdm_raises_a_clear_error(monkeypatch):
    monkeypatch.setattr(_tasks, "tqdm_check", lambda: False)
    with pytest.raises(ImportError, match="tqdm"):
        simulate(closed_loop("static-zero"), 5, trials=2, progress=True)


def test_ensemble_keeps_few_paths_but_uses_every_trial():
    CL = closed_loop("static-zero")
    kw = dict(trials=300, seed=8, noise_covariance=0.2 * np.eye(2))
    r = step_response(CL, 10, input=0, keep_paths=10, chunk=64, **kw)
    full = simulate(CL, 10, [[1.0], [0.0]], **kw)
    assert r.paths.ntraces == 10 and r.trials == 300
    np.testing.assert_allclose(r.paths.outputs, full.outputs[:, :10],
                               atol=1e-12)
    np.testing.assert_allclose(r.sample_mean, full.outputs.mean(axis=1),
                               atol=1e-12)
    cov = np.einsum("ict,jct->ijt",
                    full.outputs - full.outputs.mean(axis=1, keepdims=True),
                    full.outputs - full.outputs.mean(axis=1, keepdims=True))
    np.testing.assert_allclose(r.sample_cov, cov / 299, atol=1e-12)
    np.testing.assert_allclose(r.quantile_values,
                               np.quantile(full.outputs, [0.05, 0.95], axis=1),
                               atol=1e-12)
    np.testing.assert_allclose(r.states_sample_mean, full.states.mean(axis=1),
                               atol=1e-12)


def test_no_quantiles_means_no_band():
    r = step_response(closed_loop("static-zero"), 8, input=0, trials=20,
                      seed=0, quantiles=())
    assert r.quantile_values.shape == (0, 2, 8)
    cplt = r.plot()
    assert all(len(ax.get_lines()) == 2 for ax in cplt.axes[:, 0])


# -- ensemble responses --------------------------------------------------------
@pytest.mark.parametrize("kind", ["static-zero", "predictor-hold",
                                  "static-scheduled",
                                  "predictor-shared-channel"])
def test_step_response_sample_statistics_match_exact(kind):
    r = step_response(closed_loop(kind), 12, input=0, trials=8000, seed=21,
                      keep_paths=None)
    assert isinstance(r, EnsembleResponse)
    check_moments(r.paths.outputs, r.exact_mean, r.exact.outputs_cov)
    variance = np.einsum("iit->it", r.exact.outputs_cov)
    np.testing.assert_allclose(r.exact_std, np.sqrt(np.maximum(variance, 0)))
    assert np.all(r.quantile_values[0] <= r.sample_mean + 1e-12)
    assert np.all(r.sample_mean <= r.quantile_values[1] + 1e-12)


def test_step_is_one_at_every_step_of_every_phase():
    CL = closed_loop("predictor-shared-channel")
    r = step_response(CL, 9, input=1, trials=5, seed=0)
    assert np.array_equal(r.inputs, np.vstack([np.zeros(9), np.ones(9)]))
    np.testing.assert_allclose(
        r.exact_mean, cn.moments(CL, 9, r.inputs).outputs_mean)


def test_exact_step_and_impulse_means_are_python_control_of_the_face():
    CL = closed_loop("static-hold")
    t = np.arange(15) * CL.dt
    s = step_response(CL, t, input=0, trials=10, seed=0)
    np.testing.assert_allclose(s.exact_mean,
                               ct.step_response(CL, t, input=0).outputs[:, 0],
                               atol=1e-12)
    i = impulse_response(CL, t, input=1, trials=10, seed=0)
    np.testing.assert_allclose(
        i.exact_mean, ct.impulse_response(CL, t, input=1).outputs[:, 0],
        atol=1e-12)
    assert i.inputs[1, 0] == pytest.approx(1 / CL.dt)


def test_initial_response_decays_to_zero_in_the_mean():
    CL = closed_loop("predictor-zero")
    x0 = np.ones(CL.nstates)
    r = initial_response(CL, 60, x0, trials=500, seed=1)
    assert np.all(r.inputs == 0)
    assert np.max(np.abs(r.exact_mean[:, -1])) < 1e-3
    assert np.max(np.abs(r.sample_mean[:, -1])) < 1e-3


def test_forced_response_with_white_noise_only():
    CL = closed_loop("static-zero")
    r = forced_response(CL, 15, trials=3000, seed=2,
                        noise_covariance=W_SINGULAR, keep_paths=None)
    assert np.all(r.exact_mean == 0)
    check_moments(r.paths.outputs, r.exact_mean, r.exact.outputs_cov)


def test_several_inputs_need_a_chosen_input():
    CL = closed_loop("static-zero")
    with pytest.raises(ControlArgument, match="input"):
        step_response(CL, 5, trials=2)
    by_name = step_response(CL, 5, input="w[1]", trials=3, seed=0)
    by_index = step_response(CL, 5, input=1, trials=3, seed=0)
    assert np.array_equal(by_name.paths.outputs, by_index.paths.outputs)
    with pytest.raises(ValueError, match="input"):
        step_response(CL, 5, input=2, trials=2)


def test_single_input_system_needs_no_input():
    sys = cn.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    r = step_response(sys, 10, trials=5, seed=0)
    assert np.array_equal(r.inputs, np.ones((1, 10)))


def test_default_horizon_follows_the_mean_square_rate():
    CL = closed_loop("static-zero")
    rho = cn.ms_radius(CL)
    steps = default_steps(CL)
    assert steps == max(20, int(np.ceil(np.log(1e-4) / np.log(rho))))
    assert step_response(CL, input=0, trials=2, seed=0).time.size == steps


def test_default_horizon_is_whole_periods_and_bounded():
    CL = closed_loop("predictor-shared-channel")
    assert default_steps(CL) % 3 == 0 and 20 <= default_steps(CL) <= 1002
    fast = cn.jss([[[0.01]]], [[1.0]], [[1.0]], [[0.0]], [1.0])
    assert default_steps(fast) == 20
    unstable = cn.jss([[[1.5]]], [[1.0]], [[1.0]], [[0.0]], [1.0])
    assert default_steps(unstable) == 50


def test_responses_pickle():
    r = step_response(closed_loop("static-zero"), 6, input=0, trials=5,
                      seed=0)
    back = pickle.loads(pickle.dumps(r))
    assert np.array_equal(back.sample_mean, r.sample_mean)
    assert isinstance(back.paths, SamplePaths)
    assert np.array_equal(back.paths.outputs, r.paths.outputs)


# -- plots (headless, Agg) ------------------------------------------------------
RESPONSES = {
    "step": lambda CL: step_response(CL, 10, input=0, trials=50, seed=0),
    "impulse": lambda CL: impulse_response(CL, 10, input=1, trials=50, seed=0),
    "initial": lambda CL: initial_response(CL, 10, np.ones(CL.nstates),
                                           trials=50, seed=0),
    "forced": lambda CL: forced_response(CL, 10, [[1.0], [0.5]], trials=50,
                                         seed=0, noise_covariance=np.eye(2)),
}


@pytest.mark.parametrize("which", sorted(RESPONSES))
def test_ensemble_plot_draws_one_line_per_statistic(which):
    r = RESPONSES[which](closed_loop("static-scheduled"))
    cplt = r.plot()
    assert isinstance(cplt, ct.ControlPlot)
    assert cplt.axes.shape == (2, 1)
    for ax in cplt.axes[:, 0]:
        assert len(ax.get_lines()) == 4      # exact, sample, 5 %, 95 %
    labels = [line.get_label() for line in cplt.lines[0, 0]]
    assert any("exact mean" in s for s in labels)


def test_ensemble_plot_through_time_response_plot_with_inputs():
    r = step_response(closed_loop("static-zero"), 10, input=0, trials=30,
                      seed=0, quantiles=(0.1, 0.5, 0.9))
    cplt = ct.time_response_plot(r.to_response(), plot_inputs=True,
                                 overlay_traces=True)
    assert cplt.axes.shape == (4, 1)         # 2 outputs, 2 inputs
    assert all(len(ax.get_lines()) == 5 for ax in cplt.axes[:, 0])


@pytest.mark.parametrize("paths, expected", [(None, 30), (20, 20), (5, 5)])
def test_sample_paths_plot_overlays_the_trials(paths, expected):
    p = simulate(closed_loop("predictor-zero"), 8, trials=30, seed=0)
    cplt = p.plot(paths=paths)
    assert cplt.axes.shape == (2, 1)
    assert all(len(ax.get_lines()) == expected for ax in cplt.axes[:, 0])


def test_sample_paths_plot_default_draws_twenty():
    p = simulate(closed_loop("predictor-zero"), 8, trials=30, seed=0)
    cplt = p.plot()
    assert all(len(ax.get_lines()) == 20 for ax in cplt.axes[:, 0])


def test_python_control_plots_sample_paths_in_its_own_layout():
    p = simulate(closed_loop("static-zero"), 6, trials=3, seed=0)
    cplt = ct.time_response_plot(p, plot_inputs=True)
    assert cplt.axes.shape == (4, 3)         # (outputs + inputs) × trials
    assert all(len(ax.get_lines()) == 1 for ax in cplt.axes.ravel())


@pytest.mark.parametrize("which", sorted(RESPONSES))
def test_plot_ensemble_draws_means_band_and_paths(which):
    r = RESPONSES[which](closed_loop("predictor-hold"))
    cplt = plot_ensemble(r, paths=5)
    assert cplt.axes.shape == (2, 1)
    for i, ax in enumerate(cplt.axes[:, 0]):
        assert len(ax.get_lines()) == 5 + 2
        assert len(ax.collections) == 1                      # the band
        assert len(cplt.lines[i, 0]) == 7
    labels = [t.get_text() for t in cplt.legend[0, 0].get_texts()]
    assert labels[0] == "sample paths"
    assert any("5–95% band" in s for s in labels)
    assert any("exact mean" in s for s in labels)


def test_plot_ensemble_on_given_axes_without_band():
    r = step_response(closed_loop("static-zero"), 10, input=0, trials=3,
                      seed=0)
    fig, axes = plt.subplots(2, 1)
    cplt = plot_ensemble(r, ax=axes, paths=10, band=False, legend=False)
    assert cplt.figure is fig
    for ax in axes:
        assert len(ax.get_lines()) == 3 + 2      # only 3 paths exist
        assert len(ax.collections) == 0
    with pytest.raises(ControlDimension, match="ax"):
        plot_ensemble(r, ax=axes[0])
