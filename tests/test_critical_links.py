"""critical_loss on every link kind: the loss of the link it is asked about.

A loss on a delayed link composes with the delay law (the loop at the
critical loss is the loop of the thinned law, given directly); a bursty
link keeps its mean burst length while its stationary loss varies (the
closed form of a deadbeat gain: stable for every loss bursts of that length
allow); a bursty delay has no one loss probability and is refused by name.
"""

import numpy as np
import pytest
from control.exception import ControlArgument

import control_ncs as ncs


def _scalar(a=1.1, **network):
    return ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
                   **network)


def test_a_loss_on_a_delayed_sensor_link_is_the_thinned_law():
    pmf = np.array([0.5, 0.4])
    alpha = ncs.critical_loss(_scalar(sensor_delay=pmf), [[-0.9]],
                              link="sensor", tol=1e-9)
    assert 0.0 < alpha < 1.0
    for step, stable in ((-1e-6, True), (1e-6, False)):
        thinned = _scalar(sensor_delay=(1.0 - alpha - step) * pmf)
        rate = ncs.ms_radius(ncs.feedback(thinned, [[-0.9]]))
        assert (rate < 1.0) == stable


def test_a_bursty_link_keeps_its_bursts_while_its_loss_varies():
    link = ncs.gilbert_elliott(loss=0.2, burst=3.0)
    # deadbeat: (1 - r) a² = (2/3) 1.21 < 1 at every loss bursts of 3 steps
    # allow, the largest of which is 3/4
    top = ncs.critical_loss(_scalar(actuator_loss=link), [[-1.1]])
    assert top == pytest.approx(0.75, rel=1e-9)
    # a weaker gain stops at a loss where bursts of 3 steps tip it over
    alpha = ncs.critical_loss(_scalar(actuator_loss=link), [[-0.3]],
                              tol=1e-9)
    assert 0.0 < alpha < 0.75
    for step, stable in ((-1e-6, True), (1e-6, False)):
        at = ncs.gilbert_elliott(loss=alpha + step, burst=3.0)
        rate = ncs.ms_radius(ncs.feedback(_scalar(actuator_loss=at),
                                          [[-0.3]]))
        assert (rate < 1.0) == stable


def test_a_bursty_delay_has_no_one_loss_to_vary():
    link = ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.5),
                            [0.0], [0.6, 0.4])
    with pytest.raises(ControlArgument, match="^link: .*bursty delay"):
        ncs.critical_loss(_scalar(sensor_delay=link), [[-0.9]],
                          link="sensor")
