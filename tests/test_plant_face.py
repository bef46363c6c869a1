"""What a user reads of a networked plant: nss documents every keyword it
takes, the plant's repr and str show its delays, and no number is printed
as a raw float."""

import inspect
import re

import control as ct
import pytest

import control_ncs as ncs
from control_ncs.plant import NetworkedStateSpace

#: A float printed with more digits than anybody wrote (0.18999999999999995,
#: 1.11022e-16): seven decimals or more, or a tiny exponent.
RAW_FLOAT = re.compile(r"\d\.\d{7,}|e-1\d")


def scalar(**network):
    return ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, name="P",
                   **network)


def bursty():
    return ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
                            [0.0, 0.5], [1.0])


def test_nss_documents_every_keyword_the_plant_takes():
    taken = [name for name, p in inspect.signature(
        NetworkedStateSpace.__init__).parameters.items()
        if p.kind is p.KEYWORD_ONLY]
    assert "sensor_delay" in taken and "actuator_delay" in taken
    doc = ncs.nss.__doc__
    missing = [name for name in taken
               if not re.search(f"``{name}(``|=)", doc)]
    assert missing == []


def test_repr_shows_a_delayed_link_and_its_total_loss():
    P = scalar(sensor_loss=0.1, sensor_delay=[0.5, 0.3, 0.1])
    assert repr(P) == ("<NetworkedStateSpace P: 1 states, w:1 u:1 z:1 y:1, "
                       "period 1, α1=0.19, α2=0, sensor delays 0..2 steps, "
                       "dt=True>")


def test_repr_shows_a_buffer_longer_than_the_largest_delay():
    P = scalar(actuator_delay=ncs.random_delay([0.6, 0.3], buffer=4))
    assert ", actuator delays 0..1 steps (buffer 4)," in repr(P)


def test_repr_shows_bursty_delays():
    assert ", actuator bursty delays 0..1 steps," in repr(
        scalar(actuator_delay=bursty()))


def test_repr_shows_sub_sample_input_delays():
    G = ct.ss([[-1.0]], [[0.0, 1.0]], [[1.0], [1.0]],
              [[0.0, 0.0], [0.0, 0.0]])
    P = ncs.nss(G, nmeas=1, ncon=1, dt=0.5,
                input_delay=([0.0, 0.25], [0.5, 0.5]))
    assert ", input delays 0..0.25 s (2 values), dt=0.5>" in repr(P)


def test_plant_without_delays_prints_as_before():
    P = scalar(sensor_loss=0.125)
    assert repr(P) == ("<NetworkedStateSpace P: 1 states, w:1 u:1 z:1 y:1, "
                       "period 1, α1=0.125, α2=0, dt=True>")
    assert "delay" not in str(P)


def test_str_shows_the_law_the_buffer_and_how_the_losses_compose():
    P = scalar(sensor_loss=0.1, sensor_delay=ncs.random_delay(
        [0.5, 0.3, 0.1], buffer=3))
    assert ("  sensor delay: P(δ = c), c = 0..2: [0.5, 0.3, 0.1]; buffer 3 "
            "(the link's loss α1 = 0.19 composes the loss 0.1 given and the "
            "law's own 0.1)\n") in str(P)


def test_str_shows_a_bursty_delay_per_channel_state():
    text = str(scalar(actuator_delay=bursty()))
    assert ("  actuator delay: bursty, GilbertElliott(fail=0.1, recover=0.4; "
            "loss=0.2, burst=2.5); P(δ = c) while bad [0, 0.5], while good "
            "[1]; buffer 1 (the link's loss α2 = 0.1 is the laws' own)\n"
            ) in text


@pytest.mark.parametrize("network", [
    dict(sensor_loss=0.1, sensor_delay=[0.5, 0.3, 0.1]),
    dict(sensor_loss=0.3, actuator_loss=0.7, sensor_delay=[0.1, 0.2, 0.3],
         actuator_delay=[0.7, 0.1]),
    dict(actuator_delay=bursty()),
])
def test_no_raw_float_in_what_a_plant_prints(network):
    P = scalar(**network)
    header = str(P).split("Plant (")[0]       # the matrices are numpy's
    assert not RAW_FLOAT.search(repr(P)) and not RAW_FLOAT.search(header)


@pytest.mark.parametrize("make", [
    # 0.7 + 0.4 is 1.0999999999999999 in floating point
    lambda: ncs.gilbert_elliott(loss=0.7, burst=1.1),
    lambda: ncs.random_delay([0.7, 0.4]),
    lambda: ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
                             [0.7, 0.4], [1.0]),
    lambda: ncs.random_delay([0.1, 0.2], buffer=10**3),
    lambda: scalar(sensor_delay=[0.1] * 3 + [0.7 / 97] * 97),
    lambda: scalar(sensor_loss=0.1, sensor_delay=bursty()),
    lambda: scalar(sensor_loss=ncs.gilbert_elliott(fail=0.1, recover=0.3),
                   sensor_delay=[0.5, 0.5]),
])
def test_no_raw_float_in_a_refusal(make):
    with pytest.raises((ValueError, TypeError)) as info:
        make()
    assert not RAW_FLOAT.search(str(info.value)), str(info.value)
