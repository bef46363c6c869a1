"""The mean-square radius comes with a certified bracket (theory: mss)."""

import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import given, settings, strategies as st
from scipy.sparse.linalg import eigs

import control as ct
from control_ncs import CertificationError, is_mss, jss, ms_radius
from control_ncs.stability import dense_monodromy, second_moment_operator

from benchmarks.bench_stability import lightly_damped_loop
from helpers import random_jump

SLOW = settings(max_examples=30, deadline=None)
seeds = st.integers(0, 2**32 - 1)


def kronecker_monodromy(sys):
    """The second-moment monodromy as a dense matrix, written here
    independently of the package: per phase ``Σ_i p_i A_i ⊗ A_i``, or for
    Markov modes the block ``(j, i) = T[i, j] A_i ⊗ A_i``."""
    A, N = sys.modes.A, sys.period
    M, n = A.shape[1], A.shape[-1]
    markov = not sys.modes.is_iid
    size = n * n * (M if markov else 1)
    out = np.eye(size)
    for k in range(N):
        step = np.zeros((size, size))
        for i in range(M):
            K = np.kron(A[k, i], A[k, i])
            if markov:
                T = sys.modes.transitions()[k]
                for j in range(M):
                    step[j * n * n:(j + 1) * n * n,
                         i * n * n:(i + 1) * n * n] += T[i, j] * K
            else:
                step += sys.modes.probabilities[k, i] * K
        out = step @ out
    return out


def dense_radius_with_error(sys):
    """``ρ`` per period from all eigenvalues, and a bound on its rounding
    (``10·eps·‖T‖·cond(λ)``, left and right eigenvectors)."""
    T = kronecker_monodromy(sys)
    w, vl, vr = sla.eig(T, left=True, right=True)
    i = int(np.argmax(np.abs(w)))
    cond = 1.0 / max(abs(np.vdot(vl[:, i], vr[:, i])), 1e-300)
    err = 10 * np.finfo(float).eps * np.linalg.norm(T, 2) * cond
    return float(abs(w[i])), float(err)




def single_ritz_value(sys):
    """What a Krylov eigensolver gives when asked for one eigenvalue of
    largest modulus from ``I`` (ARPACK, k = 1): a point, no proof."""
    op = second_moment_operator(sys)
    n = sys.modes.A.shape[-1]
    return float(abs(eigs(op, k=1, which="LM", v0=np.eye(n).ravel(),
                          tol=1e-10, ncv=min(n * n - 1, 30), maxiter=5000,
                          return_eigenvectors=False)[0]))


def test_one_ritz_value_misses_the_radius_the_bracket_proves():
    # 20 states, the matrix-free route (the default above 24 states); the
    # dense spectral radius is the reference
    sys = lightly_damped_loop(20, seed=0)
    res = ms_radius(sys, method="matrix-free", bracket=True)
    dense, err = dense_radius_with_error(sys)
    assert res.lower - err <= dense <= res.upper + err
    assert res.width <= 1e-10
    point = single_ritz_value(sys)
    assert point < res.lower            # the old answer lies outside
    assert res.lower <= res.radius <= res.upper


def test_sixty_state_loop_with_close_top_eigenvalues_is_bracketed():
    sys = lightly_damped_loop(60, seed=1)
    res = ms_radius(sys, bracket=True)
    assert res.route == "matrix-free"
    point = single_ritz_value(sys)
    assert not res.lower <= point <= res.upper
    assert res.lower <= res.radius <= res.upper
    assert res.width <= 1e-10
    # the upper end's certificate, checked here: X ≻ 0, 𝒯(X) ≺ upper·X
    X = res.certificate
    A, p = sys.modes.A[0], sys.modes.probabilities[0]
    TX = sum(p[i] * A[i] @ X @ A[i].T for i in range(2))
    L = np.linalg.cholesky(X)
    G = np.linalg.solve(L, np.linalg.solve(L, TX).T)
    assert np.linalg.eigvalsh(0.5 * (G + G.T)).max() < res.upper


@SLOW
@given(seed=seeds, n=st.integers(2, 4), N=st.integers(1, 3),
       M=st.integers(1, 3), radius=st.floats(0.3, 1.3),
       markov=st.booleans(), method=st.sampled_from(["dense",
                                                     "matrix-free"]))
def test_bracket_contains_the_dense_radius_and_is_narrow(seed, n, N, M,
                                                         radius, markov,
                                                         method):
    rng = np.random.default_rng(seed)
    sys = random_jump(rng, n=n, N=N, M=M, radius=radius)
    if markov and M > 1:
        T = rng.dirichlet(np.ones(M), size=(N, M))
        sys = jss(sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D,
                  transition=T)
    res = ms_radius(sys, method=method, bracket=True)
    dense, err = dense_radius_with_error(sys)
    lo, hi = res.lower ** N, res.upper ** N
    assert lo - err <= dense <= hi + err
    assert res.width <= 1e-10
    assert res.lower <= res.radius <= res.upper


@SLOW
@given(seed=seeds, n=st.integers(1, 4), N=st.integers(1, 3),
       M=st.integers(1, 3), markov=st.booleans())
def test_the_dense_monodromy_is_the_product_of_kronecker_matrices(
        seed, n, N, M, markov):
    """The package's dense monodromy (the period applied to every unit
    matrix by batched products) equals the product of the phases'
    Kronecker matrices written in this file."""
    rng = np.random.default_rng(seed)
    sys = random_jump(rng, n=n, N=N, M=M, radius=1.1)
    if markov and M > 1:
        T = rng.dirichlet(np.ones(M), size=(N, M))
        sys = jss(sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D,
                  transition=T)
    ref = kronecker_monodromy(sys)
    np.testing.assert_allclose(dense_monodromy(sys), ref,
                               atol=1e-12 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("offset, verdict", [(-1e-10, True), (1e-10, False)])
def test_a_deterministic_loop_a_hair_from_the_edge_is_decided(offset,
                                                              verdict):
    # ρ(A)² = 1 + offset exactly in floating point terms of the bracket
    r = np.sqrt(1 + offset)
    R = np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])
    sys = ct.ss(r * R, [[1.0], [0.0]], [[1.0, 0.0]], [[0.0]], True)
    res = ms_radius(sys, bracket=True)
    assert res.route == "deterministic"
    assert res.lower <= 1 + offset <= res.upper
    assert res.stable is verdict
    assert is_mss(sys) is verdict


def test_a_bracket_that_contains_one_decides_nothing():
    sys = jss([[[1.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [1.0, 0.0])
    res = ms_radius(sys, bracket=True)
    assert res.lower <= 1.0 <= res.upper
    assert res.stable is None and res.status == "not_verified"
    with pytest.raises(CertificationError, match="undecided") as info:
        is_mss(sys)
    assert info.value.reason == "not_verified"


def test_a_lossy_loop_at_one_minus_1e9_is_stable_and_one_beyond_is_not():
    # x⁺ = x w.p. p, else 0: ρ = p exactly
    for p, verdict in ((1 - 1e-9, True), (1 + 0.0, None)):
        sys = jss([[[1.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [p, 1 - p])
        assert ms_radius(sys, bracket=True).stable is verdict
    bursty = jss([[[1.0 + 1e-9]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
                 transition=[[1.0, 0.0], [0.5, 0.5]])
    assert ms_radius(bursty, bracket=True).stable is False


def test_a_system_whose_moments_vanish_in_one_period_has_radius_zero():
    S = np.diag([1.0, 1.0], 1)
    sys = jss([[S], [S], [S]], np.zeros((3, 1)), np.zeros((1, 3)), [[0.0]],
              [[1.0]] * 3)
    res = ms_radius(sys, method="matrix-free", bracket=True)
    assert (res.lower, res.upper, res.route) == (0.0, 0.0, "zero")


def test_bracket_refuses_a_non_bool():
    sys = jss([[[0.5]]], [[1.0]], [[1.0]], [[0.0]], [1.0])
    with pytest.raises(ValueError, match="bracket"):
        ms_radius(sys, bracket="yes")


def test_a_radius_below_the_float_range_of_the_probes_is_bracketed_by_zero():
    # 𝒯(I) is subnormal (ρ ≈ 4.7e-316): the bracket is [0, 1e-150], stable
    sys = jss([[[0.0]], [[3.058071450654324e-158]]], [[1.0]], [[1.0]],
              [[0.0]], [0.5, 0.5])
    res = ms_radius(sys, bracket=True)
    assert res.lower == 0.0 and 0 < res.upper <= 1.0000001e-150
    assert res.lower <= res.radius <= res.upper and res.stable is True


def test_a_badly_scaled_loop_is_bracketed_as_its_balanced_twin():
    """x = diag(1e3, 1e-3) x̃ of a well-scaled two-mode loop: rounding
    leaves the bracket of the scaled loop wide, the balanced coordinates
    decide it; the certificate is the scaled loop's own (checked here)."""
    A = 0.7 * np.array([[[0.5, 0.5], [0.2, 0.6]], [[0.9, 0.0], [0.3, 1.1]]])
    T = np.diag([1e3, 1e-3])
    Ti = np.linalg.inv(T)
    p = np.array([0.6, 0.4])
    well = jss(A, np.zeros((2, 2, 1)), np.zeros((2, 1, 2)),
               np.zeros((2, 1, 1)), p)
    bad = jss(np.array([T @ a @ Ti for a in A]), np.zeros((2, 2, 1)),
              np.zeros((2, 1, 2)), np.zeros((2, 1, 1)), p)
    want = ms_radius(well, bracket=True)
    got = ms_radius(bad, bracket=True)
    assert got.status == "certified" and got.width < 1e-9
    assert got.lower <= want.upper and want.lower <= got.upper
    X = got.certificate
    image = sum(q * (T @ a @ Ti) @ X @ (T @ a @ Ti).T for q, a in zip(p, A))
    # 𝒯(X) ≺ upper X, decided on the congruence that makes X the identity
    R = np.linalg.cholesky(X)
    Ri = np.linalg.inv(R)
    gap = got.upper * np.eye(2) - Ri @ image @ Ri.T
    assert np.linalg.eigvalsh(0.5 * (gap + gap.T)).min() > 0


def test_a_passivity_certificate_measures_its_loop_once(monkeypatch):
    """Its necessary condition and its exact check read one bracket
    (radius_memo); outside a certificate every call computes, so the
    figures and timings of ms_radius stay its own."""
    import control_ncs as ncs
    from control_ncs import stability
    A = np.array([[[0.5, 0.2], [0.0, 0.3]], [[0.9, 0.1], [0.2, 0.4]]])
    sys = jss(A, np.ones((2, 2, 1)), np.ones((2, 1, 2)),
              np.full((2, 1, 1), 3.0),
              transition=[[0.7, 0.3], [0.4, 0.6]])
    calls = []
    real = stability._bracket
    monkeypatch.setattr(stability, "_bracket",
                        lambda *a: calls.append(1) or real(*a))
    res = ncs.passivity_certificate(sys, None, method="lmi")
    assert res.certificate.verified and len(calls) == 1
    assert res.certificate.ms_radius == ms_radius(sys)
    ms_radius(sys)
    assert len(calls) == 3 and stability._MEMO.get() is None
