"""Seeded generators and independent reference routines shared by the tests.

Everything random takes a ``numpy.random.Generator`` (never the global RNG).
The samplers here are written from the definitions (theory: conventions, §10), not from
the package's moment or stability code, so that tests can compare the two.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse.linalg

from control_ncs import ScheduleWarning, jss, nss


# --------------------------------------------------------------------------
# plants and jump systems
# --------------------------------------------------------------------------
def random_matrix(rng, rows, cols, scale=1.0):
    return scale * rng.standard_normal((rows, cols))


def random_stable_matrix(rng, n, radius):
    """A random ``n × n`` matrix with spectral radius exactly ``radius``."""
    A = rng.standard_normal((n, n))
    rho = np.max(np.abs(np.linalg.eigvals(A)))
    return A * (radius / rho)


def random_plant(rng, n=2, m1=1, m2=1, p1=None, *, radius=1.1, dt=True,
                 **network):
    """A random discrete-time networked plant with ``C2 = I`` (``y = x``).

    ``A`` has spectral radius ``radius``; ``B1, B2, C1, D11, D12`` are
    standard normal; ``p1`` defaults to ``m1``. Network keywords (schedules,
    losses, ``shared_channel``) go to :func:`control_ncs.nss`.
    """
    p1 = m1 if p1 is None else p1
    A = random_stable_matrix(rng, n, radius)
    B1 = random_matrix(rng, n, m1)
    B2 = random_matrix(rng, n, m2)
    C1 = random_matrix(rng, p1, n)
    D11 = random_matrix(rng, p1, m1, 0.5)
    D12 = random_matrix(rng, p1, m2, 0.5)
    B = np.hstack([B1, B2])
    C = np.vstack([C1, np.eye(n)])
    D = np.vstack([np.hstack([D11, D12]), np.zeros((n, m1 + m2))])
    with warnings.catch_warnings():
        # random schedules may leave a node silent: that is what is drawn
        warnings.simplefilter("ignore", ScheduleWarning)
        return nss(A, B, C, D, dt, nmeas=n, ncon=m2, **network)


def scalar_plant(a, b=1.0, *, bw=1.0, c=1.0, d=0.0, d12=0.0, dt=True,
                 **network):
    """``x⁺ = a x + bw w + b u``, ``z = c x + d w + d12 u``, ``y = x``."""
    return nss([[a]], [[bw, b]], [[c], [1.0]], [[d, d12], [0.0, 0.0]], dt,
               nmeas=1, ncon=1, **network)


def random_jump(rng, n=3, N=1, M=2, m=1, p=1, *, radius=0.9, dt=True):
    """A random ``N``-periodic jump system with ``M`` modes per phase.

    Mode matrices are random with spectral radius ``radius``; probabilities
    are random (Dirichlet) per phase.
    """
    A = np.array([[random_stable_matrix(rng, n, radius) for _ in range(M)]
                  for _ in range(N)])
    B = rng.standard_normal((N, M, n, m))
    C = rng.standard_normal((N, M, p, n))
    D = rng.standard_normal((N, M, p, m))
    prob = rng.dirichlet(np.ones(M), size=N)
    return jss(A, B, C, D, prob, dt)


def plant_state_selector(CL, n):
    """Matrix ``S`` with ``x = S ξ`` for a closed loop built by ``feedback``.

    Uses the state names: ``x̂`` coordinates end in ``_hat`` and ``e`` in
    ``_err`` (predictor, ``x = x̂ + e``); otherwise the plant state is the
    first ``n`` coordinates (static, with ``u⁻`` after it for 'hold').
    """
    names = CL.jump_states
    S = np.zeros((n, len(names)))
    hat = [i for i, s in enumerate(names) if s.endswith("_hat")]
    err = [i for i, s in enumerate(names) if s.endswith("_err")]
    if hat:
        assert len(hat) == len(err) == n
        S[np.arange(n), hat] = 1.0
        S[np.arange(n), err] = 1.0
    else:
        S[np.arange(n), np.arange(n)] = 1.0
    return S


# --------------------------------------------------------------------------
# an independent Monte Carlo sampler of a jump system (theory: jump system)
# --------------------------------------------------------------------------
def sample_jump(sys, steps, trials, rng, *, x0=None, inputs=None,
                noise_covariance=None, initial_covariance=None):
    """Sample paths of ``ξ⁺ = A_ki ξ + B_ki w``, ``z = C_ki ξ + D_ki w``.

    At each step ``t`` a mode is drawn independently for every trial with
    the probabilities of phase ``t mod N``; ``w = inputs[:, t] + v`` with
    ``v ~ N(0, noise_covariance)`` white. Returns ``(states, outputs)`` of
    shapes ``(trials, n, steps)``, ``(trials, p, steps)`` (the same time
    points as :func:`control_ncs.moments` with ``timepts=steps``).
    """
    modes = sys.modes
    N = modes.period
    n = modes.A.shape[-1]
    m = modes.B.shape[-1]
    p = modes.C.shape[-2]
    w_det = np.zeros((m, steps)) if inputs is None else \
        np.broadcast_to(np.asarray(inputs, float), (m, steps))
    x = np.zeros((trials, n)) if x0 is None else np.tile(np.asarray(x0, float),
                                                          (trials, 1))
    if initial_covariance is not None:
        x = x + rng.multivariate_normal(np.zeros(n), initial_covariance, trials)
    xs = np.empty((trials, n, steps))
    zs = np.empty((trials, p, steps))
    for t in range(steps):
        k = t % N
        idx = rng.choice(modes.count, size=trials, p=modes.probabilities[k])
        w = np.tile(w_det[:, t], (trials, 1))
        if noise_covariance is not None:
            w = w + rng.multivariate_normal(np.zeros(m), noise_covariance,
                                            trials)
        A, B = modes.A[k][idx], modes.B[k][idx]
        C, D = modes.C[k][idx], modes.D[k][idx]
        xs[:, :, t] = x
        zs[:, :, t] = np.einsum("tij,tj->ti", C, x) + np.einsum("tij,tj->ti",
                                                                D, w)
        x = np.einsum("tij,tj->ti", A, x) + np.einsum("tij,tj->ti", B, w)
    return xs, zs


# --------------------------------------------------------------------------
# statistics
# --------------------------------------------------------------------------
def assert_mean_within(samples, exact, n_se, axis=0, floor=1e-12):
    """``|sample mean - exact| <= n_se`` standard errors, elementwise.

    The standard error is the sample standard deviation over ``axis``
    divided by ``sqrt(count)``; ``floor`` absorbs rounding where the
    sample is (numerically) deterministic.
    """
    samples = np.asarray(samples, float)
    count = samples.shape[axis]
    mean = samples.mean(axis=axis)
    se = samples.std(axis=axis, ddof=1) / np.sqrt(count)
    scale = floor * np.maximum(1.0, np.abs(exact))
    dev = np.abs(mean - exact)
    bad = dev > n_se * se + scale
    assert not bad.any(), (
        f"sample mean off by more than {n_se} standard errors at "
        f"{np.argwhere(bad)[:5].tolist()}: worst z-score "
        f"{np.max(dev / np.maximum(se, 1e-300)):.2f}")
    return np.max(np.where(se > 0, dev / np.where(se > 0, se, 1), 0.0))


def assert_cov_within(samples, exact_cov, n_se, floor=1e-12):
    """Sample covariance of ``samples`` ``(trials, n, T)`` within ``n_se``
    standard errors of ``exact_cov`` ``(n, n, T)``, entry by entry.

    The standard error of entry ``(i, j)`` is that of the mean of the
    products ``(x_i - x̄_i)(x_j - x̄_j)`` (the centring's effect is
    O(1/trials), negligible here).
    """
    centred = samples - samples.mean(axis=0)
    prods = np.einsum("sit,sjt->sijt", centred, centred)
    return assert_mean_within(prods, exact_cov, n_se, floor=floor)


def fourth_moment_rate(sys):
    """Per-step growth rate of ``E‖ξ‖⁴`` of the unforced system:
    ``ρ(Π_k Σ_i p A⊗A⊗A⊗A)^(1/N)`` (small ``n``: the ``n⁴``-vector).

    Sample standard errors of ``‖ξ_t‖²`` are trustworthy only while
    ``E‖ξ‖⁴ / (E‖ξ‖²)²`` stays moderate, i.e. while this rate is close to
    ``ms_radius(sys)²`` over the horizon of a Monte Carlo test: lossy loops
    are heavy-tailed (the few paths that keep losing dominate).

    The operator is applied factor by factor (``O(n⁵)`` per mode, never
    the ``n⁴ × n⁴`` matrix) and its largest eigenvalues found by ARPACK
    from a fixed start; :func:`dense_fourth_moment_rate` is the dense
    route it is checked against.
    """
    A, p = sys.modes.A, sys.modes.probabilities
    n = A.shape[-1]

    def apply(v):
        X = v.reshape(n, n, n, n)
        for k in range(sys.period):
            Y = np.zeros_like(X)
            for i in range(A.shape[1]):
                if p[k, i] == 0:
                    continue
                Z = X
                for _ in range(4):
                    # contract the leading index with A, append it last:
                    # four turns give (A⊗A⊗A⊗A) x in the original order
                    Z = np.tensordot(Z, A[k, i], axes=([0], [1]))
                Y += p[k, i] * Z
            X = Y
        return X.ravel()

    size = n ** 4
    if size <= 16:
        return dense_fourth_moment_rate(sys)
    op = scipy.sparse.linalg.LinearOperator((size, size), matvec=apply,
                                            dtype=float)
    values = scipy.sparse.linalg.eigs(
        op, k=min(6, size - 2), which="LM", v0=np.ones(size),
        ncv=min(size - 1, 40), return_eigenvectors=False)
    return np.max(np.abs(values)) ** (1 / sys.period)


def dense_fourth_moment_rate(sys):
    """:func:`fourth_moment_rate` on the dense ``n⁴ × n⁴`` matrix."""
    A, p = sys.modes.A, sys.modes.probabilities
    n = A.shape[-1]
    T = np.eye(n**4)
    for k in range(sys.period):
        Tk = sum(p[k, i] * np.kron(np.kron(A[k, i], A[k, i]),
                                   np.kron(A[k, i], A[k, i]))
                 for i in range(A.shape[1]))
        T = Tk @ T
    return np.max(np.abs(np.linalg.eigvals(T))) ** (1 / sys.period)


def kron_ms_radius(phases):
    """``ρ(Π_k Σ_i p_i A_i ⊗ A_i)^(1/N)`` (theory: mean-square stability, Kronecker form), written
    independently of ``control_ncs.ms_radius``: ``phases[k]`` lists
    ``(p_i, A_i, ...)`` per mode."""
    n = phases[0][0][1].shape[0]
    T = np.eye(n * n)
    for phase in phases:
        T = sum(p * np.kron(A, A) for p, A, *_ in phase) @ T
    return float(np.max(np.abs(np.linalg.eigvals(T)))) ** (1 / len(phases))
