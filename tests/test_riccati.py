"""The Riccati route of passivesyn (control_ncs.riccati, theory: passivity, §8).

It must agree with the LMI where both apply, decide feasibility where the
theory knows the answer, and return only gains that an independent exact
check accepts.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from control_ncs import (SynthesisError, ms_radius, passivesyn)
from control_ncs.verify import check_certificate
from control_ncs.synthesis import _routes as _synthesis_routes
from control_ncs.riccati import riccati_synthesis
from control_ncs.strategies import build

from helpers import random_plant, scalar_plant

#: The bisection's default tolerance on η (relative to max(1, |η|)).
RTOL = 1e-4


def recheck(K, CL, eta, decay=1.0):
    """Every returned gain: its own certificate re-checked exactly, and the
    LMI variables it reports consistent with it."""
    res = K.result
    cert = check_certificate(CL, res.certificate.P, eta, decay=decay)
    assert cert.verified, cert.failures
    assert cert.ms_radius < min(1.0, decay ** 2)
    P = np.array([np.linalg.inv(X) for X in res.X])
    np.testing.assert_allclose(P, res.certificate.P, rtol=1e-6, atol=1e-9)
    F = np.einsum("kuj,kjx->kux", K.gains, res.plant.E)
    np.testing.assert_allclose(res.Y, F @ res.X, rtol=1e-9, atol=1e-9)


def grid_plant(n, N, seed):
    """Seeded full-information plant: two inputs, two w's; for N = 2 an
    actuator schedule [1, 2] (exact LMI, theory: synthesis); losses 0.1 and 0.2."""
    rng = np.random.default_rng([seed, n, N, 11])
    return random_plant(rng, n, m1=2, m2=2, radius=1.1,
                        actuator_schedule=None if N == 1 else [1, 2],
                        sensor_loss=0.1, actuator_loss=0.2)


# -- agreement with the LMI ------------------------------------------------------
#: Seeded grid (a subset of n = 2..5, N = 1, 2, seeds 0, 1 whose Riccati
#: runs take under a second each; the others take 1-4 s, agree as well).
GRID = [(2, 1, 0), (3, 1, 0), (3, 1, 1), (3, 2, 0), (4, 1, 0), (4, 1, 1),
        (5, 1, 0), (5, 1, 1), (2, 2, 0), (5, 2, 0)]


@pytest.mark.parametrize("n, N, seed", GRID)
def test_maximised_eta_agrees_with_lmi_to_the_bisection_tolerance(n, N, seed):
    P = grid_plant(n, N, seed)
    Kl, _, eta_lmi = passivesyn(P, options={"solver": "CLARABEL"})
    Kr, CLr, eta_ric = passivesyn(P, options={"solver": "riccati"})
    recheck(Kr, CLr, eta_ric)
    tol = 2 * RTOL * max(1.0, abs(eta_lmi))
    # never above what the LMI's optimum allows (both are certified)
    assert eta_ric <= Kl.result.eta_solver + tol
    if len(Kl.result.attempts) == 1:     # no back-off below the LMI optimum
        assert eta_ric == pytest.approx(eta_lmi, abs=tol)
    else:
        assert eta_ric >= eta_lmi - tol


def test_fixed_eta_returns_that_eta_verified():
    P = grid_plant(3, 2, 0)
    _, _, best = passivesyn(P, options={"solver": "riccati"})
    eta = best - 0.1
    K, CL, got = passivesyn(P, eta, options={"solver": "RICCATI"})
    assert got == eta and K.result.eta == eta
    recheck(K, CL, eta)


# -- the scalar loop of theory: synthesis: critical actuator loss 1/a² = 0.25 ----------------
def test_scalar_loop_feasible_below_critical_loss():
    P = scalar_plant(2.0, actuator_loss=0.24)
    K, CL, eta = passivesyn(P, options={"solver": "riccati"})
    recheck(K, CL, eta)
    assert ms_radius(CL) < 1


@pytest.mark.parametrize("eta", [None, -1.0])
def test_scalar_loop_infeasible_above_critical_loss(eta):
    P = scalar_plant(2.0, actuator_loss=0.26)
    with pytest.raises(SynthesisError) as info:
        passivesyn(P, eta, options={"solver": "riccati"})
    assert info.value.reason == "infeasible"


@settings(max_examples=15, deadline=None, derandomize=True)
@given(a=st.floats(0.5, 3.0), loss=st.floats(0.0, 0.6))
def test_scalar_loops_feasible_exactly_below_critical_loss(a, loss):
    """Static gain, actuator loss α: a gain exists iff α a² < 1 (theory: synthesis);
    within 2 % of the boundary either answer is allowed."""
    P = scalar_plant(a, actuator_loss=loss)
    critical = loss * a * a
    try:
        K, CL, eta = passivesyn(P, options={"solver": "riccati"})
    except SynthesisError as err:
        assert critical > 0.98, (critical, err.reason)
        assert err.reason in ("infeasible", "solver_failed")
        return
    assert critical < 1
    recheck(K, CL, eta)


# -- decay bound -----------------------------------------------------------------
def test_decay_bound_is_honoured():
    P = grid_plant(3, 2, 1)
    r = 0.9       # free loop: ms_radius 0.656; best achievable about 0.64
    K, CL, best = passivesyn(P, decay=r, options={"solver": "riccati"})
    recheck(K, CL, best, decay=r)
    assert ms_radius(CL) < r ** 2 and K.result.decay == r
    K, CL, eta = passivesyn(P, best - 1.0, decay=r,
                            options={"solver": "riccati"})
    recheck(K, CL, eta, decay=r)
    assert ms_radius(CL) < r ** 2


# -- the result object -----------------------------------------------------------
def test_result_is_filled_like_the_lmi_route():
    P = grid_plant(3, 2, 0)
    K, CL, eta = passivesyn(P, options={"solver": "riccati"})
    res = K.result
    assert CL.info["synthesis"] is res
    assert res.report.solver == "RICCATI" and res.report.status == "optimal"
    assert res.report.compile_time == 0.0
    assert res.report.iterations >= 1
    assert res.attempts == [res.report]
    assert (res.structure, res.form, res.width) == ("full", "merged", 3 + 2)
    assert res.X.shape == (2, 3, 3) and res.Y.shape == (2, 2, 3)
    assert res.eta == eta < res.certificate.eta_sup
    assert res.eta_solver >= eta - RTOL
    # the actuator not addressed at a phase gets an exactly zero gain row
    assert np.all(K.gains[0][1] == 0) and np.all(K.gains[1][0] == 0)


# -- automatic choice of the route ---------------------------------------------------
def test_auto_selects_riccati_above_threshold_and_clarabel_below():
    n = _synthesis_routes.RICCATI_THRESHOLD
    rng = np.random.default_rng(5)
    small = random_plant(rng, n, m1=2, m2=2, radius=1.05)
    big = random_plant(rng, n + 1, m1=2, m2=2, radius=1.05)
    Ks, _, _ = passivesyn(small, -5.0)
    Kb, _, _ = passivesyn(big, -5.0)
    assert Ks.result.report.solver == "CLARABEL"
    assert Kb.result.report.solver == "RICCATI"


def test_auto_keeps_the_lmi_when_solver_options_are_given():
    rng = np.random.default_rng(6)
    big = random_plant(rng, _synthesis_routes.RICCATI_THRESHOLD + 1, m1=2, m2=2,
                       radius=1.05)
    K, _, _ = passivesyn(big, -5.0,
                         options={"solver_options": {"max_iter": 200}})
    assert K.result.report.solver == "CLARABEL"


# -- bad input -------------------------------------------------------------------
@pytest.fixture
def plant():
    return grid_plant(2, 1, 0)


@pytest.mark.parametrize("kwargs, options", [
    (dict(controller="predictor"), {}), (dict(actuator="hold"), {}),
    ({}, dict(structure="extended"))])
def test_riccati_for_a_structured_loop_raises_naming_solver(plant, kwargs,
                                                            options):
    with pytest.raises(ValueError, match="^solver: .*structure"):
        passivesyn(plant, **kwargs, options={"solver": "riccati", **options})


def test_riccati_with_sensor_schedule_raises_naming_solver():
    rng = np.random.default_rng(1)
    P = random_plant(rng, 2, m1=1, m2=1, sensor_schedule=[1, 2])
    with pytest.raises(ValueError, match="^solver: .*structure"):
        passivesyn(P, options={"solver": "riccati"})


def test_unknown_riccati_option_raises_type_error(plant):
    with pytest.raises(TypeError, match="bogus_option"):
        passivesyn(plant, options={"solver": "riccati",
                                   "solver_options": {"bogus_option": 1}})


@pytest.mark.parametrize("option, value", [("rtol", -1.0),
                                           ("max_sweeps", 0),
                                           ("probe_sweeps", 2.5)])
def test_bad_riccati_option_value_raises_value_error_naming_it(plant, option,
                                                              value):
    with pytest.raises(ValueError, match=f"^{option}: "):
        passivesyn(plant, options={"solver": "riccati",
                                   "solver_options": {option: value}})


def test_out_of_sweeps_is_inconclusive_not_infeasible():
    P = scalar_plant(2.0, actuator_loss=0.249)
    with pytest.raises(SynthesisError, match="inconclusive") as info:
        passivesyn(P, -1.0, options={"solver": "riccati",
                                     "solver_options": {"max_sweeps": 2}})
    assert info.value.reason == "solver_failed"


def test_riccati_synthesis_refuses_a_structured_plant():
    rng = np.random.default_rng(2)
    P = random_plant(rng, 2, m1=1, m2=1)
    with pytest.raises(ValueError, match="^plant: "):
        riccati_synthesis(build(P, "predictor"))


# -- automatic choice: an inconclusive iteration falls back to the LMI ------------
@pytest.mark.parametrize("reason, falls_back", [("solver_failed", True),
                                                ("infeasible", False)])
def test_auto_riccati_falls_back_to_lmi_only_when_inconclusive(
        monkeypatch, reason, falls_back):
    rng = np.random.default_rng(11)
    P = random_plant(rng, _synthesis_routes.RICCATI_THRESHOLD + 1, m1=2, m2=2,
                     radius=1.05)

    def refuse(*args, **kwargs):
        raise SynthesisError("riccati: stub verdict", reason, {})

    monkeypatch.setattr(_synthesis_routes, "riccati_synthesis", refuse)
    if falls_back:
        K, CL, eta = passivesyn(P, -5.0)
        assert K.result.report.solver == "CLARABEL"
        recheck(K, CL, eta)
    else:
        with pytest.raises(SynthesisError) as info:
            passivesyn(P, -5.0)
        assert info.value.reason == "infeasible"
