"""Passivity analysis of Markov jump systems (theory: Markov losses, the seed's Lemma 2).

The dissipation inequality of a chain has one matrix ``Θ_{k,ℓ}`` per phase
and previous mode, with a storage ``P_{k,ℓ}``. The checks here compare it
with routes that do not share its code path:

* a chain that alternates deterministically between two modes is the
  deterministic period-2 system of those modes (i.i.d. code path, N = 2);
* a chain on identical modes is the deterministic LTI system
  (``control.get_input_ff_index``, KYP);
* a chain with equal rows and another initial law is the i.i.d. system
  (same ``Θ``, same index), though it runs through the Markov code;
* the certified index never exceeds the mean system's (deterministic
  inputs are adapted inputs, theory: passivity), and a certificate implies
  mean-square stability.
"""

from __future__ import annotations

import numpy as np
import pytest
import control as ct
from control.exception import ControlDimension
from hypothesis import HealthCheck, given, settings, strategies as st

import control_ncs as ncs
from control_ncs.verify import supply_rows

from helpers import random_stable_matrix


def _alternating(rng, n=2):
    """Two modes, each followed by the other, and the same as period 2."""
    A = np.array([random_stable_matrix(rng, n, r) for r in (0.6, 0.9)])
    B = rng.standard_normal((2, n, 1))
    C = rng.standard_normal((2, 1, n))
    D = 2.0 + rng.random((2, 1, 1))
    chain = ncs.jss(A, B, C, D, transition=[[0.0, 1.0], [1.0, 0.0]])
    periodic = ncs.jss(A[:, None], B[:, None], C[:, None], D[:, None],
                       [[1.0], [1.0]])
    return chain, periodic


@pytest.mark.parametrize("seed", range(3))
def test_alternating_chain_has_the_index_of_its_period_two_system(seed):
    chain, periodic = _alternating(np.random.default_rng(seed))
    assert not chain.modes.is_iid and periodic.period == 2
    assert ncs.ms_radius(chain) == pytest.approx(ncs.ms_radius(periodic),
                                                 rel=1e-9)
    nu_chain = ncs.get_input_ff_index(chain)
    nu_periodic = ncs.get_input_ff_index(periodic)
    assert nu_chain == pytest.approx(nu_periodic, rel=1e-5, abs=1e-6)


def test_alternating_chain_has_the_output_feedback_index_of_its_period_two_system():
    chain, periodic = _alternating(np.random.default_rng(7))
    assert ncs.get_output_fb_index(chain) == pytest.approx(
        ncs.get_output_fb_index(periodic), rel=1e-5, abs=1e-6)


def test_chain_on_identical_modes_has_the_lti_index():
    G = ct.ss([[0.5, 0.2], [0.0, -0.3]], [[1.0], [0.4]], [[1.0, 0.5]],
              [[1.5]], True)
    chain = ncs.jss(np.stack([G.A, G.A]), G.B, G.C, G.D,
                    transition=[[0.9, 0.1], [0.3, 0.7]])
    assert not chain.modes.is_iid
    assert ncs.get_input_ff_index(chain) == pytest.approx(
        ct.get_input_ff_index(G), rel=1e-5, abs=1e-6)


def _equal_rows(rng, n=2, M=3):
    A = np.array([random_stable_matrix(rng, n, r)
                  for r in rng.uniform(0.3, 0.9, M)])
    B = rng.standard_normal((M, n, 1))
    C = rng.standard_normal((M, 1, n))
    D = 2.0 + rng.random((M, 1, 1))
    p = rng.dirichlet(np.ones(M))
    other = rng.dirichlet(np.ones(M))
    chain = ncs.jss(A, B, C, D, other, transition=np.tile(p, (M, 1)))
    iid = ncs.jss(A, B, C, D, p)
    return chain, iid


def test_equal_rows_with_another_initial_law_run_the_markov_code():
    chain, iid = _equal_rows(np.random.default_rng(3))
    assert not chain.modes.is_iid and iid.modes.is_iid
    rows = supply_rows(chain.modes)
    assert rows.shape == (1, 3, 3)
    np.testing.assert_array_equal(rows[0], np.tile(iid.modes.probabilities,
                                                   (3, 1)))


def test_equal_rows_give_the_iid_dissipation_matrices_and_index():
    chain, iid = _equal_rows(np.random.default_rng(4))
    P = ncs.passivity_certificate(iid).certificate.P     # (1, n, n)
    for T in ncs.verify.dissipation_matrices(chain, np.repeat(P[:, None], 3, 1),
                                      0.1):
        np.testing.assert_allclose(
            T, ncs.verify.dissipation_matrices(iid, P, 0.1)[0], atol=1e-12)
    assert ncs.get_input_ff_index(chain) == pytest.approx(
        ncs.get_input_ff_index(iid), rel=1e-5, abs=1e-6)


def _bursty_loop(f=0.05, r=0.74, gain=-1.0):
    link = ncs.gilbert_elliott(fail=f, recover=r)
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                actuator_loss=link)
    return ncs.feedback(P, [[gain]])


def test_every_analysis_function_takes_a_bursty_closed_loop():
    CL = _bursty_loop()
    assert not CL.modes.is_iid
    result = ncs.passivity_certificate(CL)
    assert result.passive and result.certificate.verified
    M = CL.modes.count
    assert result.certificate.P.shape == (1, M, 1, 1)
    assert result.certificate.theta_max.shape == (1, M)
    nu = ncs.get_input_ff_index(CL)
    assert nu == pytest.approx(result.eta, rel=1e-4, abs=1e-6)
    assert ncs.ispassive(CL, ifp_index=nu - 1e-3)
    assert not ncs.ispassive(CL, ifp_index=nu + 1e-2)
    cert = ncs.verify.check_certificate(CL, result.certificate.P, nu - 1e-3)
    assert cert.verified
    assert ncs.verify.certified_index(CL, result.certificate.P) >= nu
    rho = ncs.get_output_fb_index(CL)
    assert np.isfinite(rho)


def test_burstiness_at_equal_average_loss_lowers_the_certified_index():
    # same stationary loss 0.2, mean bursts of 1.25 and 2.5 steps
    assert ncs.gilbert_elliott(fail=0.2, recover=0.8).loss == \
        pytest.approx(ncs.gilbert_elliott(fail=0.1, recover=0.4).loss)
    short = _bursty_loop(f=0.2, r=0.8, gain=-1.2)   # Bernoulli: i.i.d.
    long = _bursty_loop(f=0.1, r=0.4, gain=-1.2)
    assert ncs.get_input_ff_index(long) < ncs.get_input_ff_index(short)


def test_markov_certificate_needs_one_storage_per_previous_mode():
    CL = _bursty_loop()
    with pytest.raises(ControlDimension, match="previous mode"):
        ncs.verify.check_certificate(CL, np.ones((1, 3, 1, 1)), 0.0)


def test_one_storage_matrix_is_broadcast_to_every_previous_mode():
    CL = _bursty_loop()
    P = ncs.passivity_certificate(CL).certificate.P
    common = np.full((1, 1), P.max())
    thetas = ncs.verify.dissipation_matrices(CL, common, -10.0)
    assert len(thetas) == CL.modes.count


def _random_chain(rng, n, M):
    A = np.array([random_stable_matrix(rng, n, r)
                  for r in rng.uniform(0.2, 1.3, M)])
    B = rng.standard_normal((M, n, 1))
    C = rng.standard_normal((M, 1, n))
    D = rng.uniform(0.5, 2.0, (M, 1, 1))
    T = rng.dirichlet(np.ones(M) * 0.7, size=M)
    return ncs.jss(A, B, C, D, transition=T)


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(1, 3),
       M=st.integers(2, 3))
def test_certified_index_of_a_chain_is_below_its_mean_systems(seed, n, M):
    sys = _random_chain(np.random.default_rng(seed), n, M)
    if not ncs.ms_radius(sys) < 0.999:
        with pytest.raises(ncs.CertificationError):
            ncs.get_input_ff_index(sys)
        return
    result = ncs.passivity_certificate(sys)
    # the exact checks kept on the result: Θ_{k,ℓ} ≺ 0, P_{k,ℓ} ≻ 0, MSS
    cert = result.certificate
    assert cert.verified and np.all(cert.theta_max < 0)
    assert np.all(cert.P_min > 0) and cert.ms_radius < 1
    assert result.eta <= ncs.mean_input_ff_index(sys) + 1e-6


@pytest.mark.parametrize("markov", [True, False])
def test_certificate_shape_error_names_the_shape_given(markov):
    sys = (_bursty_loop() if markov
           else ncs.jss([[0.5]], [[1.0]], [[1.0]], [[1.0]], [1.0]))
    with pytest.raises(ControlDimension, match=r"got \(3, 1, 1\)$"):
        ncs.verify.check_certificate(sys, np.ones((3, 1, 1)), 0.1)
