"""The second-moment kernel's building blocks: the Stein solver with its
Schur form computed once, the extended-precision sandwich products, and the
one-BLAS-thread guard that must leave the process's BLAS state as it found
it."""

import threading

import numpy as np
import pytest
import scipy.linalg as sl
from hypothesis import given, settings, strategies as st
from threadpoolctl import threadpool_info

from control_ncs import _blas
from control_ncs._stein import Stein
from control_ncs.stability import _sandwich, phase_map


def _random(n, seed, radius):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    return A * (radius / np.max(np.abs(np.linalg.eigvals(A))))


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 2**32 - 1),
       radius=st.floats(0.0, 1.5), mu=st.floats(0.3, 3.0))
def test_stein_solver_matches_scipy(n, seed, radius, mu):
    Phi = _random(n, seed, radius) if radius > 0 else np.zeros((n, n))
    rng = np.random.default_rng(seed + 1)
    F = rng.standard_normal((n, n))
    F = F @ F.T
    X = Stein(Phi)(mu, F)
    scale = max(1.0, np.linalg.norm(Phi, 2) ** 2 / mu)
    # the residual of the equation itself, independent of scipy's route
    res = mu * X - Phi @ X @ Phi.T - F
    sep = np.min(np.abs(mu - np.outer(*(2 * [np.linalg.eigvals(Phi)]))))
    if sep > 1e-3:
        assert np.abs(res).max() <= 1e-9 * scale * np.abs(F).max() / \
            min(1.0, sep)
        expected = sl.solve_discrete_lyapunov(Phi / np.sqrt(mu), F / mu)
        assert np.allclose(X, expected, rtol=1e-8,
                           atol=1e-8 * np.abs(expected).max() / min(1, sep))


def test_stein_solver_reuses_its_transform_across_right_hand_sides():
    Phi = _random(30, 4, 0.95)
    solver = Stein(Phi)
    rng = np.random.default_rng(5)
    for mu in (1.0, 1.0, 0.97, 1.0):
        F = rng.standard_normal((30, 30))
        F = F + F.T
        X = solver(mu, F)
        assert solver.mu == mu
        assert np.abs(mu * X - Phi @ X @ Phi.T - F).max() < 1e-10 * \
            np.abs(F).max() * np.abs(X).max()


def test_stein_solver_with_a_jordan_block_and_complex_pairs():
    # a defective Φ (Jordan block) and a rotation: Schur handles both
    J = np.array([[0.9, 1.0, 0.0, 0.0], [0.0, 0.9, 0.0, 0.0],
                  [0.0, 0.0, 0.0, -0.8], [0.0, 0.0, 0.8, 0.0]])
    F = np.eye(4)
    X = Stein(J)(1.0, F)
    assert np.abs(X - J @ X @ J.T - F).max() < 1e-12 * np.abs(X).max()


@pytest.mark.parametrize("n", [2, 12])        # Kronecker form, transform
def test_stein_solver_singular_equation_gives_nan_then_recovers(n):
    # Φ = -I, μ = 1: μ - Φ⊗Φ = 0, and the bilinear transform
    # (Φ/√μ + I)⁻¹ does not exist either
    solver = Stein(-np.eye(n))
    assert np.isnan(solver(1.0, np.eye(n))).all()
    X = solver(4.0, np.eye(n))            # 4X - X = I
    assert np.allclose(X, np.eye(n) / 3, rtol=1e-14)


@pytest.mark.parametrize("n", [3, 8, 11, 20])
def test_stein_solver_solves_its_equation_on_either_route(n):
    rng = np.random.default_rng(n)
    Phi = rng.standard_normal((n, n))
    Phi *= 0.9 / np.max(np.abs(np.linalg.eigvals(Phi)))
    F = rng.standard_normal((n, n))
    F = F @ F.T
    solver = Stein(Phi)
    for mu in (1.0, 0.85, 1.0):
        X = solver(mu, F)
        assert np.allclose(mu * X - Phi @ X @ Phi.T, F, rtol=1e-10,
                           atol=1e-10 * np.abs(F).max())


def test_extended_sandwich_equals_the_products_mode_by_mode():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((3, 7, 7)).astype(np.longdouble)
    Q = rng.standard_normal((7, 7)).astype(np.longdouble)
    Qs = rng.standard_normal((3, 7, 7)).astype(np.longdouble)
    for Qx, per in ((Q, [Q] * 3), (Qs, list(Qs))):
        out = _sandwich(A, Qx)
        assert out.dtype == np.longdouble
        for i in range(3):
            assert np.array_equal(out[i], A[i] @ per[i] @ A[i].T)


def test_phase_map_skips_dead_modes_without_copying_live_ones():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((3, 5, 5))
    Q = np.eye(5)
    w = np.array([0.5, 0.0, 0.5])
    expected = 0.5 * (A[0] @ A[0].T + A[2] @ A[2].T)
    assert np.allclose(phase_map(A, w, Q, False), expected, rtol=1e-14)
    assert np.allclose(phase_map(A, np.array([0.2, 0.3, 0.5]), Q, False),
                       sum(p * a @ a.T for p, a in zip([0.2, 0.3, 0.5], A)),
                       rtol=1e-14)


def _blas_threads():
    return [d["num_threads"] for d in threadpool_info()
            if d["user_api"] == "blas"]


def test_serial_blas_restores_the_thread_counts_on_exit_and_on_error():
    before = _blas_threads()
    with _blas.serial_blas(1000):
        assert set(_blas_threads()) == {1}
        with _blas.serial_blas(1000):          # nested: still one thread
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {1}
    assert _blas_threads() == before
    with pytest.raises(RuntimeError):
        with _blas.serial_blas(1000):
            raise RuntimeError("inside")
    assert _blas_threads() == before
    assert _blas._open == 0


def test_serial_blas_leaves_small_kernels_alone():
    before = _blas_threads()
    with _blas.serial_blas(_blas.SERIAL_MIN_STATES - 1):
        assert _blas_threads() == before


def test_serial_blas_in_other_threads_changes_nothing():
    # only the main thread sets the limit (OpenBLAS ignores the call from
    # other threads, or older releases apply it process-wide and racy)
    before = _blas_threads()
    inside, leave = threading.Barrier(5), threading.Barrier(5)

    def work():
        with _blas.serial_blas(1000):
            inside.wait()
            leave.wait()

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    inside.wait()                 # four blocks are open in other threads
    during = _blas_threads()
    with _blas.serial_blas(1000):  # the main thread's block still limits
        assert set(_blas_threads()) == {1}
    leave.wait()
    for t in threads:
        t.join()
    assert during == before
    assert _blas_threads() == before
    assert _blas._open == 0
