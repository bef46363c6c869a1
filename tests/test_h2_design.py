"""H2 design of structured gains: a local search on the exact norm.

The objective and its adjoint gradient are checked against an independent
route (the loop built by ``feedback`` and its exact ``norm``, central
differences); the search against the exact program where that applies, a
scan where the gain is one number, and the full-information optimum as a
bound it cannot beat.
"""

import math

import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension

import control_ncs as ncs
from control_ncs.synthesis._h2 import H2Objective
from control_ncs.synthesis.norms import _local_h2syn


def _lq_plant(loss=0.5, **network):
    """x⁺ = 1.2 x + θ u + w, z = [x; θu], y = x."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
                   [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
                   ncon=1, actuator_loss=loss, **network)


def _two_state(**network):
    """A stable two-state plant, z = [x1 + 0.2 w; 0.5 u], y = x."""
    A = np.array([[0.9, 0.3], [0.0, 0.8]])
    return ncs.nss(A, np.array([[1.0, 1.0], [0.0, 0.5]]),
                   np.array([[1.0, 0.0], [0.0, 0.0], [1.0, 0.0],
                             [0.0, 1.0]]),
                   np.array([[0.2, 0.0], [0.0, 0.5], [0.0, 0.0],
                             [0.0, 0.0]]), True, nmeas=2, ncon=1, **network)


def _plant_objective(P, controller, actuator="zero"):
    """The local search's objective on the one open loop, and the exact
    norm of the loop feedback builds for the same gains."""
    from control_ncs.synthesis._local import Loop
    plant = ncs.build(P, controller, actuator)
    loop = Loop(plant, plant.probabilities, plant.transition)
    objective = H2Objective(loop, plant.Cz, plant.Du, plant.Bw, plant.Dw,
                            plant.probabilities, plant.readings()[1])

    def exact(x):
        return ncs.norm(ncs.feedback(P, loop.gains(x), controller=controller,
                                     actuator=actuator)) ** 2
    return objective, exact


@pytest.mark.parametrize("case", [
    ("delayed", "static", "zero"), ("delayed", "static", "hold"),
    ("delayed", "predictor", "zero"), ("delayed", "predictor", "hold"),
    ("plant", "static", None), ("plant", "predictor", None)])
def test_objective_and_gradient_are_the_exact_norms(case):
    """Delayed links (Markov ages, actuator buffer) and a scheduled plant
    over a bursty sensor link: J equals norm(feedback(P, K))², and the
    adjoint gradient of log J matches central differences of it."""
    kind, controller, actuator = case
    if kind == "delayed":
        P = _two_state(sensor_delay=[0.5, 0.3, 0.1],
                       actuator_delay=[0.6, 0.3])
        objective, exact = _plant_objective(P, controller, actuator)
        scale = 0.3
    else:
        P = _two_state(sensor_schedule=[1, 2], actuator_loss=0.2,
                       sensor_loss=ncs.gilbert_elliott(0.2, 0.5))
        objective, exact = _plant_objective(P, controller)
        scale = 0.05
    x = scale * np.random.default_rng(7).standard_normal(
        objective.loop.free.size)
    f, grad = objective.value(x)
    assert math.exp(f) == pytest.approx(exact(x), rel=1e-10)
    assert np.max(np.abs(grad)) > 1e-3
    h = 1e-6
    central = np.array([(math.log(exact(x + h * e))
                         - math.log(exact(x - h * e))) / (2 * h)
                        for e in np.eye(x.size)])
    assert np.max(np.abs(central - grad)) < 1e-6 * np.max(np.abs(grad))


def test_the_local_search_finds_the_exact_programs_optimum():
    """Where the program is exact (y = x, zero actuator) the local search,
    run on purpose, reaches the modified Riccati cost S = 5.762615414813."""
    K, CL, h2 = _local_h2syn(_lq_plant(), "static", "zero", None, None, 60.0)
    assert K.result.route == "local"
    assert h2 ** 2 == pytest.approx(5.762615414813, rel=1e-8)
    exact = ncs.h2syn(_lq_plant())[2]
    assert h2 >= exact * (1 - 1e-9)


def test_a_held_command_is_designed_to_the_scans_minimum():
    """One gain: the local optimum is the minimum of a fine scan of the
    exact norm (the held command makes the problem nonconvex)."""
    P = _lq_plant()
    K, CL, h2 = ncs.h2syn(P, actuator="hold")
    scan = [ncs.norm(ncs.feedback(P, [[k]], actuator="hold"),
                     print_warning=False) ** 2
            for k in np.linspace(-1.2, 0.0, 241)]
    assert h2 ** 2 <= min(scan) * (1 + 1e-12)
    assert h2 ** 2 >= min(scan) * (1 - 1e-3)


def test_a_sensor_schedule_costs_between_full_information_and_its_start():
    P = _two_state(sensor_schedule=[1, 2], actuator_loss=0.2)
    K, CL, h2 = ncs.h2syn(P)
    assert K.result.route == "local" and K.result.status == "certified"
    assert h2 == ncs.norm(ncs.feedback(P, K)) == ncs.norm(CL)
    full = ncs.h2syn(P.with_network(sensor_schedule=[1, 1]))
    assert h2 >= full[2] * (1 - 1e-9)              # less information
    restricted = np.array([full[0].gains[0] * np.array([[1.0, 0.0]]),
                           full[0].gains[0] * np.array([[0.0, 1.0]])])
    assert h2 <= ncs.norm(ncs.feedback(P, restricted)) * (1 + 1e-9)


def test_over_delayed_links_per_age_gains_beat_the_design_without_delays():
    P = _lq_plant(loss=0.0, sensor_delay=[0.5, 0.3, 0.1])
    K, CL, h2 = ncs.h2syn(P)
    assert K.gains.shape == (1, 1, 3) and K.result.route == "local"
    assert h2 == ncs.norm(ncs.feedback(P, K))
    K0 = ncs.h2syn(_lq_plant(loss=0.0))[0].gains
    assert h2 <= ncs.norm(ncs.feedback(P, K0)) * (1 + 1e-9)
    Kp, _, h2p = ncs.h2syn(P, controller="predictor")
    assert Kp.gains.shape == (1, 1, 1)
    assert h2p == ncs.norm(ncs.feedback(P, Kp, controller="predictor"))


def test_the_estimator_controller_is_designed_on_its_loop():
    """y = x1 only: the estimator's loop, its gain searched locally."""
    P = ncs.nss([[1.1, 0.3], [0.0, 0.8]], [[1.0, 1.0], [0.0, 0.5]],
                [[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]],
                [[0.2, 0.0], [0.0, 0.5], [0.0, 0.0]], True, nmeas=1,
                ncon=1, actuator_loss=0.2, sensor_loss=0.1)
    K, CL, h2 = ncs.h2syn(P, controller="estimator")
    assert K.result.route == "local" and math.isfinite(h2)
    again = ncs.feedback(P, K, controller="estimator",
                         estimator_gain=K.estimator_gain)
    assert ncs.norm(again) == pytest.approx(h2, rel=1e-12)


def test_the_local_route_refuses_what_does_not_apply():
    P = _lq_plant()
    with pytest.raises(ControlDimension, match="^initial_gain:"):
        ncs.h2syn(P, actuator="hold", initial_gain=np.zeros((2, 1, 1)))
    with pytest.raises(ControlArgument, match="^estimator_gain:"):
        ncs.h2syn(P, actuator="hold", estimator_gain=[[1.0]])
    with pytest.raises(ControlArgument, match="^initial_gain:"):
        ncs.h2syn(P, initial_gain=[[[-1.0]]])
    with pytest.raises(ControlArgument, match="^controller:"):
        ncs.h2syn(P, controller="lti")


# -- H∞ of structured gains ------------------------------------------------------
@pytest.mark.parametrize("kind", ["delayed", "plant"])
def test_the_l2_gain_objectives_gradient_is_its_difference_quotient(kind):
    """The envelope-theorem gradient of the bounded real lemma's optimum
    (from the LMI's duals) against central differences of that optimum;
    the solver's accuracy bounds the agreement."""
    from control_ncs.synthesis._hinf import GainObjective
    from control_ncs.synthesis.norms import _plant_problem
    if kind == "delayed":
        P = _two_state(sensor_delay=[0.5, 0.3, 0.1])
        mats, loop, *_ = _plant_problem(P, "static", "zero", None)
        scale = 0.3
    else:
        P = _two_state(sensor_schedule=[1, 2], actuator_loss=0.2)
        mats, loop, *_ = _plant_problem(P, "static", "zero", None)
        scale = 0.1
    objective = GainObjective(loop, *mats)
    x = scale * np.random.default_rng(2).standard_normal(loop.free.size)
    f, grad = objective.value(x)
    assert math.isfinite(f) and np.max(np.abs(grad)) > 1e-2
    h = 1e-4
    central = np.array([(objective.value(x + h * e)[0]
                         - objective.value(x - h * e)[0]) / (2 * h)
                        for e in np.eye(x.size)])
    assert np.max(np.abs(central - grad)) < 1e-3 * np.max(np.abs(grad))


def test_hinfsyn_of_a_held_command_reaches_the_scans_minimum():
    P = _lq_plant()
    K, CL, gamma = ncs.hinfsyn(P, actuator="hold")
    assert K.result.route == "local" and K.result.status == "certified"
    assert gamma == ncs.l2_gain(ncs.feedback(P, K, actuator="hold")).gamma
    def certified(k):
        try:
            return ncs.l2_gain(ncs.feedback(P, [[k]], actuator="hold")).gamma
        except ncs.CertificationError:       # near the edge of stability
            return math.inf

    scan = min(certified(k) for k in np.linspace(-0.5, -0.2, 31))
    assert gamma <= scan * (1 + 1e-4)
    h2_gain = ncs.h2syn(P, actuator="hold")[0]
    assert gamma <= ncs.l2_gain(ncs.feedback(P, h2_gain,
                                             actuator="hold")).gamma


def test_hinfsyn_over_a_delayed_link_certifies_a_gain_per_age(monkeypatch):
    from control_ncs.synthesis import norms
    P = _lq_plant(loss=0.0, sensor_delay=[0.5, 0.3, 0.1])
    # a short search stopped by an iteration cap, not by a time limit, so
    # that what is returned (the better of the H2 stage's gain and the l2
    # stage's, certified either way) does not depend on the machine's speed
    monkeypatch.setattr(norms, "HINF_ITERATIONS", 3)
    K, CL, gamma = ncs.hinfsyn(P, options={"time_limit": None})
    assert K.gains.shape == (1, 1, 3) and K.result.route == "local"
    assert gamma == ncs.l2_gain(ncs.feedback(P, K)).gamma
    h2_gain = ncs.h2syn(P)[0]
    assert gamma <= ncs.l2_gain(ncs.feedback(P, h2_gain)).gamma


@pytest.mark.parametrize("which", ["h2", "hinf"])
def test_gradients_through_a_noisy_measurement(which):
    """y = x + D21 w on a scheduled plant: the noise enters through the
    gain too (Bcl = Bw + Bu K Ew); both gradients against central
    differences, the values against the loop's exact norm / l2 gain."""
    from control_ncs.synthesis._hinf import GainObjective
    from control_ncs.synthesis.norms import _plant_problem
    A = np.array([[0.9, 0.3], [0.0, 0.8]])
    P = ncs.nss(A, np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]]),
                np.array([[1.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
                np.array([[0.2, 0, 0], [0, 0, 0.5], [0, 0.3, 0],
                          [0.1, 0, 0]]), True, nmeas=2, ncon=1,
                sensor_schedule=[1, 2], actuator_loss=0.2)
    mats, loop, shape, close, *_ = _plant_problem(P, "static", "zero", None)
    objective = (H2Objective if which == "h2" else GainObjective)(loop,
                                                                 *mats)
    x = 0.1 * np.random.default_rng(2).standard_normal(loop.free.size)
    f, grad = objective.value(x)
    CL = close(loop.gains(x))
    exact = ncs.norm(CL) ** 2 if which == "h2" else \
        ncs.l2_gain(CL).gamma ** 2
    assert math.exp(f) == pytest.approx(exact, rel=1e-10 if which == "h2"
                                        else 1e-4)
    h = 1e-5 if which == "h2" else 1e-4
    central = np.array([(objective.value(x + h * e)[0]
                         - objective.value(x - h * e)[0]) / (2 * h)
                        for e in np.eye(x.size)])
    tol = 1e-6 if which == "h2" else 1e-3
    assert np.max(np.abs(central - grad)) < tol * np.max(np.abs(grad))


def test_the_local_search_uses_a_given_start_and_the_other_routes_options(
        monkeypatch):
    """Stage 2 starts from the stable start of least norm, not from the one
    of least rate (held command: the rate is least near k = -0.3, the norm
    near -0.365; with no iterations the search returns its stage-2 start);
    the held predictor over a delayed link reads the estimate and the held
    command; margin belongs to the exact program."""
    import control_ncs.synthesis._h2 as h2d
    from control_ncs.synthesis.norms import _plant_problem
    P = _lq_plant()
    mats, loop, *_ = _plant_problem(P, "static", "hold", None)
    objective = H2Objective(loop, *mats)
    good, fast = np.array([-0.365]), np.array([-0.3])
    assert loop.rate(fast)[0] < loop.rate(good)[0]
    assert objective.value(good)[0] < objective.value(fast)[0]
    monkeypatch.setattr(h2d, "ITERATIONS", 0)
    assert np.array_equal(h2d.local_h2(objective, [fast, good], None, "t"),
                          good)
    monkeypatch.undo()
    delayed = _lq_plant(loss=0.0, sensor_delay=[0.5, 0.3, 0.1])
    K, CL, h2 = ncs.h2syn(delayed, controller="predictor", actuator="hold")
    assert K.gains.shape == (1, 1, 2) and math.isfinite(h2)
    with pytest.raises(ControlArgument, match="^margin: .*locally"):
        ncs.h2syn(P, actuator="hold", options={"margin": 1e-3})
