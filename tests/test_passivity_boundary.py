"""The passivity analysis at its boundary, and its exact checks.

python-control's signatures (``ispassive(sys, ofp_index, ifp_index)``,
``get_output_fb_index``), named errors at the public boundary of
:mod:`control_ncs.verify`, errors and results that survive pickling, and the
one algebra kernel of the dissipation inequality.
"""

import pickle
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import control as ct
import pytest
from control.exception import ControlArgument, ControlDimension

import control_ncs as cn
import control_ncs.exceptions as exceptions
import control_ncs.kyp as kyp
import control_ncs.passivity as passivity
import control_ncs.verify as verify
from control_ncs import (CertificationError, SynthesisError, jss,
                         passivity_certificate)
from control_ncs.passivity import get_output_fb_index, ispassive

cvxopt = pytest.importorskip("cvxopt")


def two_z_over():
    """``G(z) = 2z/(z - 0.5) = 2 + 1/(z - 0.5)``: ``Re G ≥ 4/3`` (at
    ``z = -1``) and ``Re 1/G = 0.5 - 0.25 cos θ ≥ 1/4`` (at ``z = 1``)."""
    return ct.tf([2, 0], [1, -0.5], True)


def with_cvxopt_restored(func, *args):
    """Call a python-control passivity function, leaving cvxopt's global
    options as they were (python-control sets show_progress)."""
    saved = dict(cvxopt.solvers.options)
    try:
        return func(*args)
    finally:
        cvxopt.solvers.options.clear()
        cvxopt.solvers.options.update(saved)


def random_stable_ss(seed, n=3, m=2):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.8 / np.max(np.abs(np.linalg.eigvals(A)))
    D = 1.5 * np.eye(m) + 0.3 * rng.standard_normal((m, m))
    return ct.ss(A, rng.standard_normal((n, m)), rng.standard_normal((m, n)),
                 D, True)


def minimum_phase_ss(seed, n=3, m=2):
    """Stable with stable zeros (``A - BD⁻¹C`` Schur): an output-feedback
    index exists (with ``ν = 0``) only then, as ``ρ → -∞`` leaves the
    zero dynamics to ``P`` alone."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.8 / np.max(np.abs(np.linalg.eigvals(A)))
    B, C = 0.3 * rng.standard_normal((n, m)), rng.standard_normal((m, n))
    D = 1.5 * np.eye(m) + 0.3 * rng.standard_normal((m, m))
    assert np.abs(np.linalg.eigvals(A - B @ np.linalg.solve(D, C))).max() < 1
    return ct.ss(A, B, C, D, True)


def switching_feedthrough():
    """``z = D_i w`` with ``D = 0`` or ``2`` (probability 1/2 each) and a
    decoupled stable state. ``E(2wz - 2ρz²) = 2w²(D̄ - ρ E D²) =
    2w²(1 - 2ρ)``: the output-feedback index is 1/2. The mean output
    matrix would give ``2w²(1 - ρ)``, index 1."""
    return jss([[[0.5]]], [[0.0]], [[0.0]], [[[0.0]], [[2.0]]], [0.5, 0.5])


# -- 1. python-control's signatures ---------------------------------------------
def test_second_positional_argument_of_ispassive_is_ofp_index_as_in_control():
    G = two_z_over()
    assert with_cvxopt_restored(ct.ispassive, G, 0.3) is False
    assert ispassive(G, 0.3) is False
    assert with_cvxopt_restored(ct.ispassive, G, 0.2) is True
    assert ispassive(G, 0.2) is True


@pytest.mark.parametrize("ofp, ifp", [(0.0, 1.3), (0.0, 1.4), (0.1, 0.0),
                                      (-0.5, 0.0), (0.0, -0.5), (0.0, 0.0)])
def test_ispassive_agrees_with_control_when_one_index_is_zero(ofp, ifp):
    G = two_z_over()
    assert ispassive(G, ofp, ifp) == with_cvxopt_restored(
        ct.ispassive, G, ofp, ifp)
    assert ispassive(G, ofp_index=ofp, ifp_index=ifp) == ispassive(G, ofp,
                                                                    ifp)


def test_output_fb_index_matches_closed_form():
    rho = get_output_fb_index(two_z_over(), strict=True)
    assert 0.25 - 1e-5 < rho < 0.25
    # python-control's (non-strict) meaning: the supremum itself
    assert get_output_fb_index(two_z_over()) == pytest.approx(0.25, abs=1e-12)


def test_output_fb_index_of_an_unstable_system_is_negative_in_python_controls_sense():
    """``G = (z - 0.2)/(z - 1.2)``: ``min Re 1/G = -1/4`` at ``z = 1``,
    and ``G (1 + G/4)⁻¹ = 0.8 (z - 0.2)/(z - 1)`` is positive real (a
    boundary pole with residue 0.64): dissipative for ``yu + y²/4`` with
    a storage ``xᵀPx ⪰ 0``, though unstable (no stochastic index)."""
    G = ct.ss([[1.2]], [[1.0]], [[1.0]], [[1.0]], True)
    assert get_output_fb_index(G) == pytest.approx(-0.25, abs=1e-9)
    assert ispassive(G, -0.25) and not ispassive(G, -0.24)


@pytest.mark.parametrize("seed", range(3))
def test_output_fb_index_equals_python_control_on_random_systems(seed):
    G = minimum_phase_ss(seed)
    ours = get_output_fb_index(G)
    theirs = float(with_cvxopt_restored(ct.get_output_fb_index, G))
    assert ours == pytest.approx(theirs, rel=1e-4, abs=1e-6)


def test_output_fb_index_is_certified_exactly():
    G = minimum_phase_ss(2)
    result = passivity_certificate(G, 0.0, ofp_index=None)
    cert = result.certificate
    assert result.passive and cert.verified
    assert result.ofp_index == cert.ofp_index
    again = cn.verify.check_certificate(
        G, cert.P, 0.0, ofp_index=result.ofp_index)
    assert again.verified and again.theta_max.max() < 0
    assert ispassive(G, result.ofp_index - 1e-4)
    assert not ispassive(G, result.ofp_index + 1e-3)


def test_output_fb_index_of_jump_system_uses_every_modes_output():
    J = switching_feedthrough()
    assert 0.5 - 1e-5 < get_output_fb_index(J) < 0.5
    # the mean system (D̄ = 1) has index 1: the mean output matrix would
    # certify levels the jump system does not have
    assert get_output_fb_index(J.mean()) == pytest.approx(1.0, abs=1e-4)
    assert ispassive(J.mean(), 0.7) and not ispassive(J, 0.7)


def test_unstable_zero_dynamics_refute_every_output_feedback_level():
    G = random_stable_ss(0)
    zeros = np.linalg.eigvals(G.A - G.B @ np.linalg.solve(G.D, G.C))
    assert np.abs(zeros).max() > 1.01
    with pytest.raises(RuntimeError, match="infeasible"):
        with_cvxopt_restored(ct.get_output_fb_index, G)
    with pytest.raises(CertificationError, match="zero dynamics") as info:
        get_output_fb_index(G)
    assert info.value.reason == exceptions.INFEASIBLE


def test_feedthrough_refutes_an_output_feedback_level_without_a_solve():
    result = passivity_certificate(switching_feedthrough(), 0.0,
                                   ofp_index=0.6)
    assert not result.passive and result.reason == exceptions.FEEDTHROUGH
    assert result.report is None


def test_output_fb_index_on_a_lossy_loop_is_exactly_certified():
    rng = np.random.default_rng(11)
    A = rng.standard_normal((2, 2, 2))
    A *= 0.7 / np.abs(np.linalg.eigvals(A)).max()
    C = rng.standard_normal((2, 1, 2))
    J = jss(A, rng.standard_normal((2, 1)), C, [[[1.0]], [[1.5]]],
            [0.3, 0.7])
    result = passivity_certificate(J, 0.0, ofp_index=None)
    assert result.passive and result.method == "lmi"
    rho = result.ofp_index
    assert cn.verify.check_certificate(J, result.certificate.P, 0.0,
                                ofp_index=rho).verified
    assert not ispassive(J, rho + 1e-3 * max(1.0, abs(rho)))


@pytest.mark.parametrize("rho", [0.1, -0.2])
def test_input_index_at_a_fixed_output_level_matches_the_frequency_test(rho):
    """KYP for the supply ``2wz - 2ρz² - 2ηw²`` of a stable SISO system:
    the largest ``η`` is ``min_θ Re G - ρ |G|²``."""
    G = two_z_over()
    theta = np.linspace(0.0, np.pi, 200001)
    Gz = 2 + 1 / (np.exp(1j * theta) - 0.5)
    nu = float(np.min(Gz.real - rho * np.abs(Gz) ** 2))
    result = passivity_certificate(G, None, ofp_index=rho)
    assert result.passive and result.method == "lmi"
    assert result.ofp_index == rho == result.certificate.ofp_index
    assert nu - 1e-5 < result.eta < nu + 1e-9
    assert cn.verify.check_certificate(G, result.certificate.P, result.eta,
                                ofp_index=rho).verified


def test_riccati_method_refuses_an_output_feedback_level():
    with pytest.raises(ControlArgument, match="ofp_index"):
        passivity_certificate(two_z_over(), 0.0, ofp_index=0.1,
                              method="riccati")


def test_both_indices_maximised_is_a_named_error():
    with pytest.raises(ControlArgument, match="ifp_index, ofp_index"):
        passivity_certificate(two_z_over(), None, ofp_index=None)


@pytest.mark.parametrize("value", [np.nan, "high", None])
def test_ispassive_rejects_a_non_numeric_index(value):
    with pytest.raises(ValueError, match="ofp_index"):
        ispassive(two_z_over(), value)


def test_transfer_functions_are_accepted_wherever_control_accepts_them():
    G = two_z_over()
    S = ct.ss(G)
    assert cn.get_input_ff_index(G) == cn.get_input_ff_index(S)
    assert cn.frequency_ff_index(G) == cn.frequency_ff_index(S)
    assert cn.mean_input_ff_index(G) == cn.mean_input_ff_index(S)
    P = passivity_certificate(S).certificate.P
    assert cn.verify.check_certificate(G, P, 1.3).verified
    assert cn.verify.certified_index(G, P) == cn.verify.certified_index(S, P)


# -- 2. named errors at the boundary of verify ------------------------------------
def stable_ss():
    return ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)


CHECKS = [lambda G, P: cn.verify.certified_index(G, P),
          lambda G, P: cn.verify.certify_index(G, P),
          lambda G, P: cn.verify.dissipation_matrices(G, P, 0.0),
          lambda G, P: cn.verify.check_certificate(G, P, 0.0)]


@pytest.mark.parametrize("check", CHECKS)
def test_wrong_shaped_certificate_is_a_control_dimension_naming_P(check):
    with pytest.raises(ControlDimension, match="^P:"):
        check(stable_ss(), np.eye(2))


@pytest.mark.parametrize("check", CHECKS)
def test_string_certificate_is_a_value_error_naming_P(check):
    with pytest.raises(ValueError, match="^P:"):
        check(stable_ss(), "identity")


@pytest.mark.parametrize("check", CHECKS)
def test_string_system_is_a_control_argument_naming_sys(check):
    with pytest.raises(ControlArgument, match="^sys:"):
        check("plant", np.eye(1))


@pytest.mark.parametrize("check", CHECKS)
def test_non_square_system_is_a_control_dimension(check):
    G = ct.ss([[0.5]], [[1.0, 1.0]], [[1.0]], [[1.0, 0.0]], True)
    with pytest.raises(ControlDimension, match="^sys:"):
        check(G, np.eye(1))


@pytest.mark.parametrize("decay", [5, -1, 0, np.nan, "fast"])
def test_check_certificate_rejects_a_decay_outside_0_1(decay):
    with pytest.raises(ValueError, match="^decay:"):
        cn.verify.check_certificate(stable_ss(), [[1.0]], 0.3, decay=decay)


def test_decay_above_one_would_verify_an_eta_above_the_index():
    """Before: decay=5 verified η = 0.5 > 1/3 (the index), a false proof."""
    G = stable_ss()
    assert not cn.verify.check_certificate(G, [[1.0]], 0.5).verified
    with pytest.raises(ValueError, match="^decay:"):
        cn.verify.check_certificate(G, [[1.0]], 0.5, decay=5)


@pytest.mark.parametrize("eta", [np.nan, np.inf, "high", None])
def test_check_certificate_rejects_a_non_finite_eta(eta):
    with pytest.raises(ValueError, match="^eta:"):
        cn.verify.check_certificate(stable_ss(), [[1.0]], eta)


@pytest.mark.parametrize("check", [
    lambda: cn.verify.certified_index(stable_ss(), [[1.0]], decay=2.0),
    lambda: cn.verify.certify_index(stable_ss(), [[1.0]], decay=-0.5),
    lambda: cn.verify.dissipation_matrices(
        stable_ss(), [[1.0]], 0.0, decay=0.0)])
def test_every_check_rejects_a_decay_outside_0_1(check):
    with pytest.raises(ValueError, match="^decay:"):
        check()


# -- 3. errors and results survive pickling ---------------------------------------
@pytest.mark.parametrize("cls", [CertificationError, SynthesisError])
def test_error_round_trips_through_pickle_with_reason_and_figures(cls):
    err = cls("no certificate", exceptions.NOT_VERIFIED,
              dict(theta_max=[1e-3], status="optimal"))
    again = pickle.loads(pickle.dumps(err))
    assert type(again) is cls
    assert str(again) == "no certificate"
    assert again.reason == exceptions.NOT_VERIFIED
    assert again.figures == dict(theta_max=[1e-3], status="optimal")


def test_error_raised_in_a_process_pool_worker_reaches_the_caller():
    unstable = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[2.0]], [0.3, 0.7])
    with ProcessPoolExecutor(max_workers=1) as pool:
        future = pool.submit(cn.get_input_ff_index, unstable)
        with pytest.raises(CertificationError) as info:
            future.result()
    assert info.value.reason == exceptions.NOT_MSS
    assert info.value.figures["ms_radius"] == pytest.approx(1.2)


def test_one_reason_for_not_mean_square_stable_on_every_path():
    G = ct.ss([[1.2]], [[1.0]], [[1.0]], [[1.0]], True)
    assert passivity_certificate(G, 0.0).reason == exceptions.NOT_MSS
    with pytest.raises(CertificationError) as info:
        cn.get_input_ff_index(G)
    assert info.value.reason == exceptions.NOT_MSS
    with pytest.raises(CertificationError) as info:
        get_output_fb_index(G, strict=True)
    assert info.value.reason == exceptions.NOT_MSS
    assert set(exceptions.REASONS) >= {"not_mss", "infeasible",
                                       "solver_failed", "inaccurate",
                                       "not_verified", "feedthrough"}


def test_the_package_exports_the_exceptions_of_exceptions_py():
    import control_ncs
    assert control_ncs.CertificationError is exceptions.CertificationError
    assert control_ncs.SynthesisError is exceptions.SynthesisError
    assert issubclass(SynthesisError, CertificationError)


def test_certificate_and_passivity_result_round_trip_through_pickle():
    result = passivity_certificate(random_stable_ss(2))
    again = pickle.loads(pickle.dumps(result))
    assert again.passive == result.passive and again.eta == result.eta
    assert again.reason == result.reason and again.method == result.method
    assert again.report == result.report
    cert, back = result.certificate, again.certificate
    assert isinstance(back, verify.Certificate)
    np.testing.assert_array_equal(back.P, cert.P)
    np.testing.assert_array_equal(back.theta_max, cert.theta_max)
    assert back.figures() == cert.figures()
    assert back.failures == cert.failures


# -- 4./5. one kernel, one feedthrough bound, the KYP engine in kyp.py ----------------
def test_kernel_is_the_expected_dissipation_of_the_supply_rate():
    """``[ξ; w]ᵀ Θ [ξ; w] = E V(ξ⁺) - r² V(ξ) - E(2wᵀz - 2ρ zᵀz - 2η wᵀw)``,
    the expectation taken mode by mode, for random data."""
    rng = np.random.default_rng(0)
    M, n, m = 3, 3, 2
    p = rng.dirichlet(np.ones(M))
    A, B = rng.standard_normal((M, n, n)), rng.standard_normal((M, n, m))
    C, D = rng.standard_normal((M, m, n)), rng.standard_normal((M, m, m))
    P, Pn = (X @ X.T for X in rng.standard_normal((2, n, n)))
    eta, rho, r = 0.3, 0.7, 0.9
    T = verify.dissipation_blocks(p, A, B, C, D, P, Pn, eta, ofp_index=rho,
                                  decay=r)
    for _ in range(5):
        x, w = rng.standard_normal(n), rng.standard_normal(m)
        expected = -r ** 2 * x @ P @ x
        for i in range(M):
            xn, z = A[i] @ x + B[i] @ w, C[i] @ x + D[i] @ w
            expected += p[i] * (xn @ Pn @ xn
                                - (2 * w @ z - 2 * rho * z @ z
                                   - 2 * eta * w @ w))
        v = np.concatenate([x, w])
        assert v @ T @ v == pytest.approx(expected, rel=1e-10)


def test_certified_index_is_the_schur_complement_supremum_of_the_kernel():
    G = stable_ss()
    T0 = cn.verify.dissipation_matrices(G, [[1.0]], 0.0)[0]
    sup = verify.ifp_supremum(T0, 1)
    assert sup == cn.verify.certified_index(G, [[1.0]]) == pytest.approx(1 / 3)
    assert cn.verify.check_certificate(G, [[1.0]], sup - 1e-9).verified
    assert not cn.verify.check_certificate(G, [[1.0]], sup + 1e-9).verified


def test_feedthrough_bound_is_the_smallest_eigenvalue_over_phases():
    p = np.array([[0.5, 0.5], [1.0, 0.0]])
    D = np.array([[[[0.0]], [[2.0]]], [[[0.8]], [[5.0]]]])
    assert verify.feedthrough_bound(p, D) == (0.8, 1)
    bound, phase = verify.feedthrough_bound(p, D, ofp_index=0.25)
    # phase 0: (2·1 - 2·0.25·(0.5·0 + 0.5·4))/2 = 0.5;
    # phase 1: (1.6 - 0.5·0.64)/2 = 0.64
    assert (bound, phase) == (pytest.approx(0.5), 0)


def test_frequency_machinery_lives_in_kyp():
    assert not hasattr(passivity, "FrequencyResponse")
    G = stable_ss()
    resp = kyp.FrequencyResponse(G.A, G.B, G.C, G.D)
    assert kyp.frequency_minimum(resp) == pytest.approx(1 / 3, abs=1e-12)
    assert cn.frequency_ff_index(G) == kyp.frequency_minimum(resp)


# -- review findings: no refutation without a proof ---------------------------
def test_floor_level_with_an_output_feedback_index_is_not_refused_for_feedthrough():
    # the floor of a very negative ifp_index sits below the feedthrough bound
    # *with* rho; it used to be computed without rho and be refused there
    G = ct.ss(0.5, 1.0, 1.0, 1.0, True)
    res = cn.passivity_certificate(G, -1e9, ofp_index=1e7)
    assert res.passive and res.eta == -1e9
    assert cn.verify.check_certificate(
        G, [[2e8]], -1e9, ofp_index=1e7).verified


def test_a_maximised_margin_within_solver_tolerance_of_zero_refutes_nothing():
    # static-gain loop x⁺ = (2 - 1.5θ)x + w, z = x + w, actuator loss 0.1:
    # its certified index is 0.3519238534011 (a scalar optimum over P); just
    # below it a certificate exists (checked exactly), so no solver number
    # may call the level refuted
    P = cn.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
            nmeas=1, ncon=1, actuator_loss=0.1)
    CL = cn.feedback(P, cn.PeriodicGain([[[-1.5]]]))
    level = 0.3519238534011 - 1e-10
    assert cn.verify.check_certificate(CL, [[1.11978503]], level).verified
    res = cn.passivity_certificate(CL, level, method="lmi")
    assert res.passive or res.reason != "infeasible"
