"""Each design builds its open loop once and states its result once.

The dispatchers (passivesyn, h2syn, hinfsyn) validate, build the loop of the
plant and its network with the one builder, and hand that JumpPlant to their
routes; no route builds it again or calls a public design. The call count
below is on the builder's one entry that assembles the mode matrices.
"""

import dataclasses
import warnings

import numpy as np
import pytest

import control_ncs as ncs
from control_ncs import strategies


def _scheduled_plant():
    """Two sensors taking turns on a stable two-state plant, z = [x; u]
    (dim w = dim z for passivity), half the commands lost."""
    A = np.array([[0.9, 0.3], [0.0, 0.8]])
    B = np.hstack([np.eye(2), np.array([[1.0], [0.5]])])
    C = np.vstack([np.eye(2), np.eye(2)])
    D = np.zeros((4, 3))
    D[:2, :2] = 0.5 * np.eye(2)
    return ncs.nss(A, B, C, D, True, nmeas=2, ncon=1, actuator_loss=0.5,
                   sensor_schedule=[1, 2])


@pytest.fixture
def builds(monkeypatch):
    calls = []
    real = strategies._run

    def counted(*args, **kwargs):
        calls.append(args[2])           # the controller kind built
        return real(*args, **kwargs)

    monkeypatch.setattr(strategies, "_run", counted)
    return calls


@pytest.mark.parametrize("design", ["passivesyn", "h2syn", "hinfsyn"])
def test_a_structured_design_builds_its_open_loop_once(design, builds):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        K, CL, value = getattr(ncs, design)(_scheduled_plant())
    assert builds == ["static"]
    assert K.result.route in ("program", "riccati", "local")
    assert CL.info["synthesis"] is K.result


@pytest.mark.parametrize("design", ["passivesyn", "h2syn", "hinfsyn"])
def test_a_design_result_is_frozen(design):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        K, CL, value = getattr(ncs, design)(_scheduled_plant())
    result = K.result
    assert isinstance(result, ncs.DesignResult) and result.value == value
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.value = 0.0                          # type: ignore[misc]
    assert result.spec == {"passivesyn": "passivity", "h2syn": "h2",
                           "hinfsyn": "hinf"}[design]
