"""What a verdict says is what was proved.

"infeasible" only with a proof; a failed sufficient condition, a local
search that ran out, or a crashed route say so and prove nothing; a
certified level below zero is certified, and not passive. The plants are
the ones on which these verdicts once read wrong.
"""

import warnings

import control as ct
import numpy as np
import pytest

import control_ncs as ncs
from control_ncs.exceptions import MESSAGES, PROOFS, REASONS


def servo(sensor_loss=0.2, actuator_loss=0.0):
    """A sampled DC-motor servo measured by three sensors in two groups."""
    A = [[1.0, 0.039347, 0.001029], [0.0, 0.606513, 0.037288],
         [0.0, -0.000746, 0.904818]]
    B = [[0.10653, 0.000036], [3.934662, 0.002059], [-0.002059, 0.095162]]
    C = [[0, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    D = [[3.0, 0], [0, 0], [0, 0], [0, 0]]
    return ncs.nss(ct.ss(A, B, C, D, 0.05), nmeas=3, ncon=1,
                   sensor_schedule=[[1, 0, 0], [0, 1, 1]],
                   actuator_schedule=[1, 1], sensor_loss=sensor_loss,
                   actuator_loss=actuator_loss)


def bursty_scalar():
    sys = ct.ss([[-1.218743]], [[-0.576296, 1.508225]], [[0.43995], [1.0]],
                [[1.896095, -0.180401], [0.0, 0.0]], True)
    return ncs.nss(sys, nmeas=1, ncon=1,
                   sensor_loss=ncs.gilbert_elliott(fail=0.18, recover=0.592),
                   actuator_loss=ncs.gilbert_elliott(fail=0.071,
                                                     recover=0.568))


def assert_certified(P, K, CL, eta, **kw):
    """An independent look at the returned loop: it is the loop of K, it is
    mean-square stable, and its certificate passes the exact check."""
    assert ncs.feedback(P, K, **kw).equals(CL)
    assert ncs.ms_radius(CL) < 1.0
    cert = ncs.verify.check_certificate(CL, K.result.certificate.P, eta,
                                        decay=K.result.decay)
    assert cert.verified


# -- the vocabulary -----------------------------------------------------------
def test_every_reason_has_one_sentence_and_only_proofs_say_proven():
    for reason in REASONS:
        assert MESSAGES[reason]
        assert ("proven:" in MESSAGES[reason]) == (reason == "infeasible")
    assert set(PROOFS) <= set(REASONS)
    for open_question in ("sufficient_failed", "not_found", "solver_failed",
                          "time_limit"):
        assert open_question not in PROOFS
        assert "nothing is proven" in MESSAGES[open_question]


# -- "infeasible" only with a proof -------------------------------------------
def test_a_map_cell_is_certified_where_a_design_exists():
    """A negated ct.dlqr gain certifies η ≈ 0.55 at this cell; the LMI for
    the sensor schedule is only sufficient and certified nothing."""
    cell = ncs.design_map(servo(), [0.2], [0.0], decay=0.995, progress=False)
    assert cell.feasible[0, 0] and cell.reason[0, 0] == "certified"
    assert cell.eta[0, 0] > 0.5
    lmi = ncs.design_map(servo(), [0.2], [0.0], decay=0.995, progress=False,
                         method="lmi")
    assert not lmi.feasible[0, 0]
    assert lmi.reason[0, 0] == "sufficient_failed"


def test_the_sufficient_lmi_failing_is_not_called_infeasible():
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.passivesyn(servo(), decay=0.995, method="lmi")
    assert info.value.reason == "sufficient_failed"
    assert "nothing is proven about other gains" in str(info.value)


def test_a_certified_design_exists_where_the_sufficient_condition_fails():
    """The same cell: a certified gain from the default call, and one from
    python-control's LQ design (negated: u = -K x) checked by analysis."""
    P = servo()
    K, CL, eta = ncs.passivesyn(P, decay=0.995)
    assert_certified(P, K, CL, eta)
    assert K.result.method == "refine"
    Q = np.diag([10.0, 1.0, 1.0])
    Kd, _, _ = ct.dlqr(P.A, P.B[:, 1:], Q, [[1.0]])
    loop = ncs.feedback(P, -Kd)
    assert ncs.ms_radius(loop) < 0.995 ** 2


def test_hold_actuators_on_bursty_links_get_a_certified_phase_gain():
    """Once 'infeasible' from the sufficient LMI alone; a gain of index
    1.717 exists (K = 0.8807)."""
    P = bursty_scalar()
    CL = ncs.feedback(P, [[0.8806906734426202]], actuator="hold")
    assert ncs.ms_radius(CL) < 0.985 ** 2
    K, CL, eta = ncs.passivesyn(P, decay=0.985, actuator="hold", gain="phase")
    assert_certified(P, K, CL, eta, actuator="hold")
    assert eta > 1.7


def test_refining_phase_gains_on_bursty_links_does_not_crash(monkeypatch):
    """Explicit refinement of phase gains on Markov links certifies a gain,
    and the default call refines there too, never below it.

    The local search is seeded (``default_rng(0)``), so equal arguments
    give an equal search: the default call, whose LMI start certifies
    nothing here either, is handed the explicit call's search instead of
    running it again (pickled arguments compared; other arguments run).
    Each search runs 40 iterations instead of the default 200 (each costs a
    certificate, an SDP): the claims (a certified gain, the default call
    never below it) hold after any number of iterations."""
    import pickle

    from control_ncs.synthesis import _routes
    search, done = _routes._refine, []

    def search_once(plant, eta, decay, given, rng, deadline, iterations):
        iterations = min(iterations, 40)
        key = pickle.dumps((plant, eta, decay, given, rng, iterations))
        for seen, result in done:
            if seen == key:
                return result
        result = search(plant, eta, decay, given, rng, deadline, iterations)
        done.append((key, result))
        return result

    monkeypatch.setattr(_routes, "_refine", search_once)
    ge = ncs.gilbert_elliott(loss=0.2, burst=5)
    P = servo().with_network(sensor_loss=ge, actuator_loss=ge)
    K, CL, eta = ncs.passivesyn(P, decay=0.995, method="refine",
                                gain="phase")
    assert K.result.method == "refine" and K.gains.ndim == 3
    assert_certified(P, K, CL, eta)
    # the default call refines there too (the LMI is only sufficient)
    K2, CL2, eta2 = ncs.passivesyn(P, decay=0.995)
    assert_certified(P, K2, CL2, eta2)
    assert eta2 >= eta - 1e-9 * max(1.0, abs(eta))


def test_a_proof_is_still_called_infeasible():
    """x⁺ = 2x + u with every actuator message lost half the time and y = x:
    no gain acts on the lost mode, whose rate 0.5·4 = 2 ≥ 1 alone."""
    P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.5)
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.passivesyn(P)
    assert info.value.reason == "infeasible"


def test_a_route_that_crashes_is_a_status(monkeypatch):
    from control_ncs.synthesis import passive as synthesis

    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("a factorisation failed")

    monkeypatch.setattr(synthesis, "_routes", broken)
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.5, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1)
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.passivesyn(P, method="lmi")
    assert info.value.reason == "solver_failed"
    assert "LinAlgError" in info.value.figures["error"]


# -- "certified" is not "passive" ---------------------------------------------
def shortage_plant():
    return ncs.nss(ct.ss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                         [[0.1, 0.0], [0.0, 0.0]], True),
                   nmeas=1, ncon=1, actuator_loss=0.1)


def test_a_negative_certified_level_says_not_passive_and_warns_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        K, CL, eta = ncs.passivesyn(shortage_plant(), decay=0.95)
    assert eta < 0
    shortage = [w for w in caught
                if issubclass(w.category, ncs.NotPassiveWarning)]
    assert len(shortage) == 1
    assert shortage[0].filename == __file__      # points at the user's line
    result = K.result
    assert result.success and not result.passive
    assert result.status == "certified_shortage"
    assert "not passive" in result.message
    assert "not passive" in result.summary()
    assert "D11" in result.message
    assert not ncs.ispassive(CL)


def test_a_negative_level_asked_for_is_not_warned_about():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ncs.NotPassiveWarning)
        K, CL, eta = ncs.passivesyn(shortage_plant(), -1.0, decay=0.95)
    assert eta == -1.0 and K.result.status == "certified_shortage"


def test_a_passive_design_says_certified():
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ncs.NotPassiveWarning)
        K, CL, eta = ncs.passivesyn(P, decay=0.99)
    assert eta > 0 and K.result.passive and K.result.status == "certified"
    assert ncs.ispassive(CL)


# -- a full gain on a scheduled network ----------------------------------------
def two_sensors_in_turn():
    return ncs.nss([[1.1, 0.1], [0.0, 0.9]], [[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
                   [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                   [[0.5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
                   nmeas=2, ncon=1, sensor_schedule=[1, 2], sensor_loss=0.1)


def test_a_full_gain_on_a_scheduled_network_warns_once_naming_the_silence():
    P = two_sensors_in_turn()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        CL = ncs.feedback(P, [[-0.5, -0.2]])
    schedule = [w for w in caught if issubclass(w.category,
                                                ncs.ScheduleWarning)]
    assert len(schedule) == 1
    text = str(schedule[0].message)
    # sensors numbered from 1 as in sensor_schedule=[1, 2]: sensor 2 is
    # silent at phase 0, sensor 1 at phase 1
    assert "phase(s) [0, 1]" in text and "{0: [2], 1: [1]}" in text
    assert "sensor='hold'" in text and "predictor" in text
    assert schedule[0].filename == __file__
    # the loop is the one of the gain without the silent columns
    effective = CL.info["effective_gains"]
    np.testing.assert_array_equal(effective, [[[-0.5, 0.0]], [[0.0, -0.2]]])
    assert ncs.feedback(P, effective).equals(CL)


def test_a_gain_that_respects_the_schedule_does_not_warn():
    P = two_sensors_in_turn()
    with warnings.catch_warnings():
        warnings.simplefilter("error", ncs.ScheduleWarning)
        ncs.feedback(P, [[[-0.5, 0.0]], [[0.0, -0.2]]])
        ncs.feedback(P.with_network(sensor_schedule=None), [[-0.5, -0.2]])


# -- one way to state a verdict ------------------------------------------------
def test_every_result_states_its_verdict_in_the_same_words():
    from control_ncs._results import Result
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1,
                sensor_loss=0.1)
    K, CL, eta = ncs.passivesyn(P, decay=0.99)
    results = [K.result, K.result.certificate, ncs.passivity_certificate(CL),
               ncs.estimator_gain(P),
               ncs.refine_gain(P.with_network(sensor_schedule=[1, 0]),
                               eta=0.0)]
    for res in results:
        assert isinstance(res, Result)
        assert isinstance(res.success, bool) and res.verdict == res.success
        assert res.status in MESSAGES and isinstance(res.message, str)
        head = res.summary().splitlines()[0]
        assert head == f"{type(res).__name__}: {res.status}"
        assert repr(res).startswith(f"<{type(res).__name__}: {res.status}")
        assert len(repr(res)) < 200
