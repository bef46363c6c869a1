"""Errata of the seed paper that no other test shows (docs/errata.md).

Each test states the corrected formula against a ground truth computed here
from the definitions, independently of the package's kernels, and shows the
paper's formula missing it. The other errata cite their tests on the errata
page.
"""

import itertools

import numpy as np
import control as ct

import control_ncs as cn

ALPHA1, ALPHA2 = 0.2, 0.3
ETA = 0.1


def _plant_and_gain():
    """A seeded 3-state plant (w, z scalar; y = x) and a static gain."""
    rng = np.random.default_rng(17)
    n, m2 = 3, 2
    A = 0.6 * rng.standard_normal((n, n))
    B1 = rng.standard_normal((n, 1))
    B2 = rng.standard_normal((n, m2))
    C1 = rng.standard_normal((1, n))
    D11 = np.array([[1.5]])
    D12 = rng.standard_normal((1, m2))
    K = 0.3 * rng.standard_normal((m2, n))
    sys = ct.ss(A, np.hstack([B1, B2]), np.vstack([C1, np.eye(n)]),
                np.vstack([np.hstack([D11, D12]), np.zeros((n, 1 + m2))]),
                True)
    P = cn.nss(sys, nmeas=n, ncon=m2, sensor_loss=ALPHA1,
               actuator_loss=ALPHA2)
    return (A, B1, B2, C1, D11, D12), K, P


def _network_modes():
    """(probability, θ1 θ2) of the paper's four modes (eq. 14)."""
    for t1, t2 in itertools.product((0, 1), repeat=2):
        p = (ALPHA1 if t1 == 0 else 1 - ALPHA1) * \
            (ALPHA2 if t2 == 0 else 1 - ALPHA2)
        yield p, t1 * t2


def _storage_minus_supply(mats, K, Pc, x, w):
    """``E V(x⁺) - V(x) - (2wᵀ E z - 2η wᵀw)`` by summing over the modes."""
    A, B1, B2, C1, D11, D12 = mats
    expected_next, expected_z = 0.0, np.zeros(1)
    for p, g in _network_modes():
        x_next = (A + g * B2 @ K) @ x + B1 @ w
        expected_next += p * x_next @ Pc @ x_next
        expected_z = expected_z + p * ((C1 + g * D12 @ K) @ x + D11 @ w)
    return expected_next - x @ Pc @ x - (2 * w @ expected_z - 2 * ETA * w @ w)


def _theta(mats, K, Pc, rows, output):
    """``Θ`` assembled from the rows ``[A_i, B_i]`` of a Schur complement
    and the output matrix ``C`` of the supply term."""
    A, B1, B2, C1, D11, D12 = mats
    n = A.shape[0]
    theta = sum(R.T @ Pc @ R for R in rows)
    theta[:n, :n] -= Pc
    theta[:n, n:] -= output.T
    theta[n:, :n] -= output
    theta[n:, n:] += 2 * ETA * np.eye(1) - D11 - D11.T
    return theta


def _samples():
    rng = np.random.default_rng(3)
    return [(rng.standard_normal(3), rng.standard_normal(1))
            for _ in range(5)]


def _storage():
    rng = np.random.default_rng(5)
    M = rng.standard_normal((3, 3))
    return M @ M.T + np.eye(3)


def test_package_theta_is_the_expected_storage_increment_minus_supply():
    mats, K, P = _plant_and_gain()
    Pc = _storage()
    theta, = cn.verify.dissipation_matrices(cn.feedback(P, K), Pc, ETA)
    for x, w in _samples():
        v = np.concatenate([x, w])
        assert np.isclose(v @ theta @ v,
                          _storage_minus_supply(mats, K, Pc, x, w),
                          rtol=1e-10, atol=1e-10)


def test_paper_eq15_without_sqrt_alpha_on_b1_misses_the_expectation():
    """Erratum 1: every mode row of eq. 15 carries ``B1`` unweighted."""
    mats, K, _ = _plant_and_gain()
    A, B1, B2, C1, D11, D12 = mats
    Pc = _storage()
    q = (1 - ALPHA1) * (1 - ALPHA2)
    weighted = [np.sqrt(p) * np.hstack([A + g * B2 @ K, B1])
                for p, g in _network_modes()]
    paper = [np.hstack([np.sqrt(p) * (A + g * B2 @ K), B1])
             for p, g in _network_modes()]
    mean_output = C1 + q * D12 @ K
    right = _theta(mats, K, Pc, weighted, mean_output)
    wrong = _theta(mats, K, Pc, paper, mean_output)
    gaps = []
    for x, w in _samples():
        v = np.concatenate([x, w])
        truth = _storage_minus_supply(mats, K, Pc, x, w)
        assert np.isclose(v @ right @ v, truth, rtol=1e-10, atol=1e-10)
        gaps.append(abs(v @ wrong @ v - truth))
    assert min(gaps) > 1e-3


def test_supply_term_needs_the_mean_output_matrix():
    """Erratum 2: the supply is linear in ``z``; its expectation sees
    ``C1 + q D12 K``, not the loop-closed ``C1 + D12 K`` of every row."""
    mats, K, _ = _plant_and_gain()
    A, B1, B2, C1, D11, D12 = mats
    Pc = _storage()
    rows = [np.sqrt(p) * np.hstack([A + g * B2 @ K, B1])
            for p, g in _network_modes()]
    unweighted = _theta(mats, K, Pc, rows, C1 + D12 @ K)
    gaps = [abs(np.concatenate([x, w]) @ unweighted @ np.concatenate([x, w])
                - _storage_minus_supply(mats, K, Pc, x, w))
            for x, w in _samples()]
    assert min(gaps) > 1e-3


def _periodic_system():
    """Two phases, ``a_0 = 2`` then ``a_1 = 0.1``: stable over a period
    (``a_0 a_1 = 0.2``) although phase 0 expands."""
    A = np.array([[[[2.0]]], [[[0.1]]]])
    return cn.jss(A, [[0.1]], [[0.1]], [[1.0]], [[1.0], [1.0]])


def test_periodic_loop_is_certified_with_a_time_indexed_storage():
    """Erratum 3: the certificate needs ``X_k`` and ``X_{k+1}``."""
    result = cn.passivity_certificate(_periodic_system())
    assert result.passive
    P = np.asarray(result.certificate.P)
    assert cn.verify.check_certificate(
        _periodic_system(), P, result.eta).verdict
    assert not np.isclose(P[0, 0, 0], P[1, 0, 0], rtol=1e-3)


def test_no_time_invariant_storage_certifies_the_periodic_loop():
    """Erratum 3: with one ``X`` for every phase, phase 0's Lyapunov block
    ``(a_0² - 1) p`` is positive for every ``p > 0``."""
    sys = _periodic_system()
    for p in np.logspace(-8, 8, 81):
        thetas = cn.verify.dissipation_matrices(
            sys, np.full((2, 1, 1), p), 0.0)
        assert max(np.linalg.eigvalsh(T).max() for T in thetas) > 0
