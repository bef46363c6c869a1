"""Synthesis under stress: solver failures, options, scaling, the edge of
mean-square stability, proofs of infeasibility, time budget, the driver."""

import time

import numpy as np
import pytest
import control as ct
import cvxpy as cp

import control_ncs as ncs
from control_ncs import driver, lmi
from control_ncs.synthesis import _routes as _synthesis_routes
from control_ncs.exceptions import SynthesisError
from control_ncs.verify import check_certificate

REASONS = ("infeasible", "solver_failed", "inaccurate", "not_verified",
           "time_limit")


@pytest.fixture
def plant():
    # x⁺ = 2x + w + u, z = x + w, actuator loss 10 %
    return ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   actuator_loss=0.1)


def verified(P, K, CL, eta, decay=1.0, scaling=None):
    """Independent check: the certificate on the loop rebuilt from K (in
    coordinates x = diag(scaling) x̃ when given: P̃ = S P S, a congruence)."""
    loop = ncs.feedback(P, K)
    cert_P = K.result.certificate.P
    if scaling is not None:
        s = np.asarray(scaling, float)
        m = loop.modes
        loop = ncs.jss(m.A / s[:, None] * s[None, :], m.B / s[:, None],
                       m.C * s[None, :], m.D, m.probabilities, loop.dt)
        cert_P = cert_P * s[:, None] * s[None, :]
    cert = check_certificate(loop, cert_P, eta, decay=decay)
    assert cert.verified, cert.failures
    assert ncs.ms_radius(loop) < min(1.0, decay ** 2)
    return ncs.ms_radius(loop)


# -- 1. any solver exception is a status; global options restored -------------
def test_solver_arithmetic_error_becomes_a_status(monkeypatch, plant):
    def boom(self, *args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(cp.Problem, "solve", boom)
    report = lmi.solve(cp.Problem(cp.Minimize(0)), "CVXOPT")
    assert report.status == "solver_error"
    assert "ZeroDivisionError" in report.message
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(plant, options={"solver": "CLARABEL"})
    assert info.value.reason == "solver_failed"


def test_cvxopt_global_options_are_restored_after_a_solve():
    cvxopt = pytest.importorskip("cvxopt")
    before = dict(cvxopt.solvers.options)
    x = cp.Variable()
    lmi.solve(cp.Problem(cp.Minimize(x), [x >= 1]), "CVXOPT", maxiters=7,
              abstol=1e-5)
    assert dict(cvxopt.solvers.options) == before


# -- 2. solver options checked at the boundary ------------------------------------
def test_unknown_clarabel_option_raises_type_error_naming_it(plant):
    with pytest.raises(TypeError, match="'tol'.*tol_gap_abs"):
        ncs.passivesyn(plant, options={"solver_options": {"tol": 1e-9}})


def test_unknown_scs_option_raises_type_error_naming_it(plant):
    if "SCS" not in cp.installed_solvers():
        pytest.skip("SCS not installed")
    with pytest.raises(TypeError, match="'tol'"):
        ncs.passivesyn(plant,
                       options={"solver": "SCS", "solver_options": {"tol": 1e-9}})


def test_known_clarabel_setting_is_accepted(plant):
    K, CL, eta = ncs.passivesyn(plant, decay=0.9,
                                options={"solver_options": {"tol_gap_abs": 1e-8}})
    verified(plant, K, CL, eta, 0.9)


# -- 3. the batch reactor towards its critical loss --------------------------------
BATCH_A = [[1.38, -0.2077, 6.715, -5.676], [-0.5814, -4.29, 0, 0.675],
           [1.067, 4.273, -6.654, 5.893], [0.048, 4.273, 1.343, -2.104]]
BATCH_B = [[0, 0], [5.679, 0], [1.136, -3.146], [1.136, 0]]
BATCH_C = [[1, 0, 1, -1], [0, 1, 0, 0]]


def batch_reactor(dt, fraction):
    """Full state, w entering like u, z = C x + 0.5 w, i.i.d. actuator loss
    ``fraction`` of the critical loss 1/ρ(A)² (B reaches the unstable
    subspace)."""
    d = ct.sample_system(ct.ss(BATCH_A, BATCH_B, BATCH_C, 0), dt, "zoh")
    critical = 1 / np.max(np.abs(np.linalg.eigvals(d.A))) ** 2
    D = np.zeros((6, 4))
    D[:2, :2] = 0.5 * np.eye(2)
    return ncs.nss(d.A, np.hstack([d.B, d.B]), np.vstack([d.C, np.eye(4)]),
                   D, dt, nmeas=4, ncon=2, actuator_loss=fraction * critical)


@pytest.mark.parametrize("dt, fraction", [(0.05, 0.97), (0.05, 0.995),
                                          (0.1, 0.99)])
def test_batch_reactor_default_call_certifies_near_critical_loss(dt,
                                                                fraction):
    P = batch_reactor(dt, fraction)
    K, CL, eta = ncs.passivesyn(P)
    verified(P, K, CL, eta)


@pytest.mark.slow
@pytest.mark.parametrize("fraction", [0.9, 0.98, 0.9999])
def test_batch_reactor_sweep_never_fails_below_critical_loss(fraction):
    P = batch_reactor(0.05, fraction)
    K, CL, eta = ncs.passivesyn(P)
    verified(P, K, CL, eta)


# -- 4. proofs of infeasibility ------------------------------------------------
def test_batch_reactor_above_critical_loss_is_proved_infeasible():
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(batch_reactor(0.05, 1.001))
    assert info.value.reason == "infeasible"
    assert info.value.figures["ms_radius_without_control"] >= 1.0


def test_unreachable_unstable_state_is_proved_infeasible():
    # x1⁺ = 2 x1 + w is not reached by u: no gain stabilises it, though
    # the delivered mode has u acting (no open-loop bound applies); the
    # Riccati iteration's divergence (R_k losing definiteness) proves it
    P = ncs.nss([[2.0, 0.0], [0.0, 0.5]], [[1.0, 0.0], [1.0, 1.0]],
                [[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
                [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]], nmeas=2, ncon=1,
                actuator_loss=0.1)
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(P)
    assert info.value.reason == "infeasible"
    assert "ms_radius_without_control" not in info.value.figures


def test_loss_one_on_unstable_plant_is_infeasible_with_open_loop_figure():
    P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=1.0)
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(P)
    assert info.value.reason == "infeasible"
    assert info.value.figures["ms_radius_without_control"] == pytest.approx(4.0)


def test_loss_one_on_stable_plant_is_not_called_infeasible():
    P = ncs.nss([[0.5]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=1.0)
    K, CL, eta = ncs.passivesyn(P)
    verified(P, K, CL, eta)


def test_decay_below_the_uncontrolled_rate_is_infeasible(plant):
    # the lost mode alone has rate 0.1 · 2² = 0.4 per step
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(plant, decay=np.sqrt(0.39))
    assert info.value.reason == "infeasible"
    assert info.value.figures["ms_radius_without_control"] == pytest.approx(
        0.4)


# -- 5. badly scaled states --------------------------------------------------------
def scaled_plant(t1, t2):
    """A well-posed plant (A = [[0.9, 0.5], [0.2, 1.2]], B = [1; 1],
    z = x1 + x2 + w) written in coordinates x = diag(t1, t2) x̃."""
    T = np.diag([t1, t2])
    Ti = np.diag([1 / t1, 1 / t2])
    A = T @ np.array([[0.9, 0.5], [0.2, 1.2]]) @ Ti
    B = T @ np.ones((2, 1))
    C = np.array([[1.0, 1.0]]) @ Ti
    return ncs.nss(A, np.hstack([B, B]), np.vstack([C, np.eye(2)]),
                   [[1, 0], [0, 0], [0, 0]], nmeas=2, ncon=1,
                   sensor_loss=0.05, actuator_loss=0.1)


@pytest.mark.parametrize("t1, t2", [(1e3, 1e-3), (1e-4, 1e2), (1.0, 1e5),
                                    (3e4, 7e-3)])
def test_badly_scaled_state_gets_a_verified_lmi_gain(t1, t2):
    P = scaled_plant(t1, t2)
    K, CL, eta = ncs.passivesyn(P, decay=0.99)
    assert K.result.report.solver != "RICCATI"
    verified(P, K, CL, eta, 0.99, scaling=(t1, t2))
    # the same η as the well-scaled plant: scaling is a change of coordinates
    K1, CL1, eta1 = ncs.passivesyn(scaled_plant(1.0, 1.0), decay=0.99)
    assert eta == pytest.approx(eta1, rel=1e-3, abs=1e-4)


def test_issue_plant_under_diagonal_scaling_is_not_called_infeasible():
    P = ncs.nss([[0.9, 5e5], [2e-7, 1.2]], [[1e3, 1e3], [1e-3, 1e-3]],
                [[1e-3, 1e3], [1, 0], [0, 1]], [[1, 0], [0, 0], [0, 0]],
                nmeas=2, ncon=1, sensor_loss=0.05, actuator_loss=0.1)
    K, CL, eta = ncs.passivesyn(P, decay=0.99)
    assert K.result.report.solver != "RICCATI"
    verified(P, K, CL, eta, 0.99, scaling=(1e3, 1e-3))


def test_inaccurate_infeasible_status_is_not_a_proof(monkeypatch, plant):
    real = lmi.solve

    def fake(problem, solver=None, **options):
        report = real(problem, solver, **options)
        if report.solver == "CLARABEL":
            report.status = "infeasible_inaccurate"
        return report

    monkeypatch.setattr(_synthesis_routes, "solve", fake)
    try:
        K, CL, eta = ncs.passivesyn(plant, decay=0.9)
    except SynthesisError as err:
        assert err.reason != "infeasible"
    else:
        verified(plant, K, CL, eta, 0.9)


# -- 7. time budget ------------------------------------------------------------
def test_time_limit_ends_with_reason_time_limit(plant, monkeypatch):
    solves = []
    real = lmi.solve
    monkeypatch.setattr(_synthesis_routes, "solve",
                        lambda *a, **k: solves.append(1) or real(*a, **k))
    with pytest.raises(SynthesisError) as info:
        ncs.passivesyn(plant, options={"time_limit": 1e-9})
    assert info.value.reason == "time_limit"
    # the budget is read before the first solve: no LMI was solved
    assert solves == []


@pytest.mark.parametrize("bad", [0.0, -1.0, "soon"])
def test_time_limit_must_be_positive(plant, bad):
    with pytest.raises(ValueError, match="time_limit"):
        ncs.passivesyn(plant, options={"time_limit": bad})


# -- 10. the driver's rules --------------------------------------------------------
class _Cert:
    def __init__(self, ok, eta=0.0):
        self.verified, self.eta, self.failures = ok, eta, ["refused"]

    def figures(self):
        return dict(eta=self.eta)


def _report(status, value=None):
    return lmi.SolveReport(status, "FAKE", 0.0, 0.0, 0.0, value=value)


def _scripted(statuses, verdicts=()):
    """An ``attempt`` answering ``statuses`` in turn (a candidate for each
    optimal one), and a ``verify`` answering ``verdicts`` in turn."""
    calls, checks = [], list(verdicts)

    def attempt(scale, target, name, left):
        status = statuses[min(len(calls), len(statuses) - 1)]
        calls.append((scale, target, name))
        candidate = object() if status.startswith("optimal") else None
        return _report(status, 1.0 if candidate else None), candidate

    def verify(candidate):
        return _Cert(checks.pop(0) if checks else False)

    return calls, attempt, verify


def test_driver_only_the_problem_as_posed_decides_infeasibility():
    calls, attempt, verify = _scripted(["optimal_inaccurate", "infeasible",
                                        "infeasible"])
    out = driver.drive(attempt, verify, eta=None, solver="X")
    assert len(calls) == 3 and out.reason != "infeasible"


def test_driver_inaccurate_infeasible_of_problem_as_posed_is_no_proof():
    calls, attempt, verify = _scripted(["infeasible_inaccurate"])
    out = driver.drive(attempt, verify, eta=0.0, solver="X")
    assert out.reason == "solver_failed"


def test_driver_exact_infeasible_of_problem_as_posed_stops():
    calls, attempt, verify = _scripted(["infeasible"])
    out = driver.drive(attempt, verify, eta=0.0, solver="X")
    assert out.reason == "infeasible" and len(calls) == 1


def test_driver_prefers_an_accurate_verified_answer():
    calls, attempt, verify = _scripted(["optimal_inaccurate", "optimal"],
                                       [True, True])
    out = driver.drive(attempt, verify, eta=None, solver="X")
    assert out.ok and out.report.status == "optimal" and len(calls) == 2


def test_driver_keeps_a_verified_gain_from_an_inaccurate_solve():
    calls, attempt, verify = _scripted(["optimal_inaccurate"], [True])
    out = driver.drive(attempt, verify, eta=None, solver="X")
    assert out.ok and out.report.status == "optimal_inaccurate"


def test_driver_classifies_refused_answers():
    _, attempt, verify = _scripted(["optimal"])
    assert driver.drive(attempt, verify, eta=0.0,
                        solver="X").reason == "not_verified"
    _, attempt, verify = _scripted(["optimal_inaccurate"])
    assert driver.drive(attempt, verify, eta=0.0,
                        solver="X").reason == "inaccurate"


def test_driver_stops_at_its_deadline():
    calls, attempt, verify = _scripted(["optimal"])
    out = driver.drive(attempt, verify, eta=None, solver="X",
                       deadline=time.perf_counter() - 1.0)
    assert out.reason == "time_limit" and not calls


# -- 6. structure='auto': 'block' when 'extended' certifies nothing ----------------
def scheduled_plant():
    """Two sensors sending in turn (n = 2, N = 2): structure 'extended'."""
    return ncs.nss([[0.9, 0.3], [0.0, 0.8]], [[1.0, 0.0], [0.5, 1.0]],
                   [[1.0, 0.5], [1.0, 0.0], [0.0, 1.0]],
                   [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]], nmeas=2, ncon=1, sensor_schedule=[[1, 0], [0, 1]],
                   actuator_schedule=[[1], [1]], sensor_loss=0.1,
                   actuator_loss=0.1)


def test_auto_structure_falls_back_to_block_and_says_so(monkeypatch):
    P = scheduled_plant()
    real = _synthesis_routes.synthesis_model

    def broken_extended(plant, eta, decay, margin, structure, form, *gain):
        if structure == "extended":
            # an 'extended' LMI that never verifies: η fixed above the
            # feedthrough bound makes it infeasible
            return real(plant, 10.0, decay, margin, structure, form, *gain)
        return real(plant, eta, decay, margin, structure, form, *gain)

    monkeypatch.setattr(_synthesis_routes, "synthesis_model",
                        broken_extended)
    with pytest.raises(SynthesisError):
        ncs.passivesyn(P, options={"structure": "extended"})
    K, CL, eta = ncs.passivesyn(P)
    assert K.result.structure == "block"
    verified(P, K, CL, eta)


LEVELS = ((1.0, 0.0), (1e2, 0.0), (None, 0.0))


def test_driver_refuted_fixed_level_skips_larger_margins_only():
    calls, attempt, verify = _scripted(["infeasible", "optimal"], [True])
    out = driver.drive(attempt, verify, eta=0.5, solver="X", retries=LEVELS,
                       refute_margins=True, spare=False)
    # the 100x margin is skipped; the margin-maximising LMI still runs
    assert [c[0] for c in calls] == [1.0, None] and out.ok


def test_driver_refuted_fixed_level_is_infeasible_when_nothing_verifies():
    calls, attempt, verify = _scripted(["infeasible", "optimal"], [False])
    out = driver.drive(attempt, verify, eta=0.5, solver="X", retries=LEVELS,
                       refute_margins=True, spare=False)
    assert out.reason == "infeasible" and len(calls) == 2


def test_driver_nonpositive_maximised_margin_refutes_nothing():
    # a maximised margin <= 0 is the solver's number, within its tolerance
    # of 0 near the index: only an exact check or status may refute
    def attempt(scale, target, name, left):
        value = -1.0 if scale is None else None
        return _report("optimal" if scale is None else "solver_error",
                       value), (object() if scale is None else None)

    out = driver.drive(attempt, lambda c: _Cert(False), eta=0.5,
                       solver="X", retries=LEVELS, refute_margins=True)
    assert out.reason != "infeasible"


def test_driver_without_spare_returns_a_verified_level_of_inaccurate_solve():
    calls, attempt, verify = _scripted(["optimal_inaccurate"], [True])
    out = driver.drive(attempt, verify, eta=0.5, solver="X", spare=False)
    assert out.ok and len(calls) == 1


def test_driver_without_spare_refuses_an_inaccurate_index():
    calls, attempt, verify = _scripted(["optimal_inaccurate"], [True] * 9)
    out = driver.drive(attempt, verify, eta=None, solver="X", spare=False)
    assert out.reason == "inaccurate"
