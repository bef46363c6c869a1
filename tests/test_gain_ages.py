"""A gain per age of a buffered measurement says so: one gain per phase
whose columns are blocks per age, labelled, validated, kept by pickling
and equality, and read by the loop exactly as the unlabelled gain."""

import pickle

import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension

import control_ncs as ncs

PER_AGE = [[-0.9, -0.5, -0.2]]        # buffer 2, one sensor: three ages


def delayed_plant():
    return ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   sensor_delay=[0.5, 0.3, 0.1])


def test_per_age_gain_prints_its_ages_not_a_period_of_three():
    text = repr(ncs.PeriodicGain(PER_AGE, ages=3))
    assert "per sensor age (3)" in text
    assert "period=1" in text and "period=3" not in text


def test_gain_without_ages_prints_as_before():
    K = ncs.PeriodicGain(PER_AGE)
    assert K.ages is None
    assert repr(K) == ("PeriodicGain(controller='static', actuator='zero', "
                       "period=1,\n[[-0.9 -0.5 -0.2]])")


def test_large_per_age_gain_prints_its_shape_and_ages():
    K = ncs.PeriodicGain(np.ones((2, 3, 40)), ages=4)
    assert repr(K) == ("PeriodicGain(controller='static', actuator='zero', "
                       "period=2, per sensor age (4), shape=(2, 3, 40))")


@pytest.mark.parametrize("ages", [0, -1, 1.5, True, "3", np.float64(3.0)])
def test_ages_must_be_a_positive_int(ages):
    with pytest.raises(ValueError, match="^ages: expected an int >= 1"):
        ncs.PeriodicGain(PER_AGE, ages=ages)


def test_ages_must_split_the_columns_evenly():
    with pytest.raises(ControlDimension, match="^ages: 3 columns do not "
                       "split into 2 blocks"):
        ncs.PeriodicGain(PER_AGE, ages=2)


def test_only_a_static_gain_reads_the_measurement_per_age():
    with pytest.raises(ControlArgument, match="^ages: only "
                       "controller='static'"):
        ncs.PeriodicGain(PER_AGE, controller="predictor", ages=3)


def test_ages_survive_pickling_and_take_part_in_equality():
    K = ncs.PeriodicGain(PER_AGE, ages=3)
    again = pickle.loads(pickle.dumps(K))
    assert again == K and again.ages == 3
    assert K != ncs.PeriodicGain(PER_AGE)
    assert K != ncs.PeriodicGain(PER_AGE, ages=1)


def test_ages_are_a_label_the_loop_reads_the_same_columns():
    P = delayed_plant()
    labelled = ncs.feedback(P, ncs.PeriodicGain(PER_AGE, ages=3))
    plain = ncs.feedback(P, ncs.PeriodicGain(PER_AGE))
    assert np.array_equal(labelled.modes.A, plain.modes.A)
    assert ncs.ms_radius(labelled) == ncs.ms_radius(plain)


def test_a_periodic_gain_keeps_its_period_over_a_delayed_link():
    """A stack of gains is one per phase even where its length equals the
    number of ages: over a period-1 plant with a two-age sensor buffer, a
    period-2 gain gives a period-2 loop applying each phase's gain at both
    ages, the same loop as the gain written per age explicitly."""
    P = ncs.nss([[1.0, 0.1], [0.0, 1.0]], [[0.0, 0.005], [0.0, 0.1]],
                np.vstack([[1.0, 0.0], np.eye(2)]), np.zeros((3, 2)), 0.1,
                nmeas=2, ncon=1,
                actuator_loss=0.2, sensor_delay=[0.7, 0.3])
    K = np.array([[[-1.0, 0.0]], [[0.0, -2.2]]])
    CL = ncs.feedback(P, K)
    assert CL.period == 2
    explicit = ncs.feedback(P, ncs.PeriodicGain(
        np.concatenate([K, K], axis=2), ages=2))
    np.testing.assert_array_equal(CL.info["effective_gains"],
                                  explicit.info["effective_gains"])
    assert ncs.ms_radius(CL) == pytest.approx(ncs.ms_radius(explicit),
                                              rel=1e-12)
