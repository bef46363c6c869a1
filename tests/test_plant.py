"""The networked generalized plant (theory: plant, §3)."""

import copy
import pickle

import numpy as np
import control as ct
import pytest
from control.exception import ControlDimension

from control_ncs import NetworkedStateSpace, nss

from helpers import random_plant


def example_matrices():
    """n = 2, w ∈ R¹, u ∈ R¹, z ∈ R¹, y = x ∈ R²."""
    A = [[1.1, 0.2], [0.0, 0.7]]
    B = [[1.0, 0.5], [0.3, 2.0]]          # [B1 B2]
    C = [[1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]   # [C1; C2]
    D = [[0.4, 0.1], [0.0, 0.0], [0.0, 0.0]]    # [D11 D12; 0 0]
    return A, B, C, D


def test_partition_follows_the_hinfsyn_layout():
    A, B, C, D = example_matrices()
    P = nss(A, B, C, D, nmeas=2, ncon=1)
    B, C, D = map(np.array, (B, C, D))
    assert np.array_equal(P.B1, B[:, :1]) and np.array_equal(P.B2, B[:, 1:])
    assert np.array_equal(P.C1, C[:1]) and np.array_equal(P.C2, C[1:])
    assert np.array_equal(P.D11, D[:1, :1]) and np.array_equal(P.D12, D[:1, 1:])


def test_statespace_face_is_the_plant_itself():
    A, B, C, D = example_matrices()
    P = nss(A, B, C, D, 0.1, nmeas=2, ncon=1)
    assert isinstance(P, ct.StateSpace)
    ref = ct.ss(A, B, C, D, 0.1)
    for X, Y in zip((P.A, P.B, P.C, P.D), (ref.A, ref.B, ref.C, ref.D)):
        assert np.array_equal(X, Y)
    assert P.dt == 0.1


def test_default_signal_names_split_w_u_and_z_y():
    P = nss(*example_matrices(), nmeas=2, ncon=1)
    assert P.input_labels == ["w[0]", "u[0]"]
    assert P.output_labels == ["z[0]", "y[0]", "y[1]"]
    assert P.disturbance_labels == ["w[0]"]
    assert P.performance_labels == ["z[0]"]


def test_from_statespace_keeps_names_and_sampling_time():
    sys = ct.ss(*example_matrices(), 0.5, inputs=["d", "f"],
                outputs=["e", "p", "v"], states=["pos", "vel"], name="cart")
    P = nss(sys, nmeas=2, ncon=1, sensor_loss=0.2)
    assert isinstance(P, NetworkedStateSpace)
    assert P.input_labels == ["d", "f"] and P.output_labels == ["e", "p", "v"]
    assert P.state_labels == ["pos", "vel"] and P.name == "cart"
    assert P.dt == 0.5 and P.sensor_loss == 0.2


def test_transfer_function_is_converted_then_checked():
    # u → y = 1/(z - 0.5) converts (ct.ss) but leaves no w and no z
    G = ct.tf([1], [1, -0.5], True)
    with pytest.raises(ControlDimension, match="dim w = 0 and dim z = 0"):
        nss(G, nmeas=1, ncon=1)


def test_from_state_space_of_a_transfer_function():
    G = ct.ss(ct.tf([1], [1, -0.5], True))
    P = nss(ct.append(ct.ss([], [], [], [[1.0]], True), G), nmeas=1, ncon=1)
    assert isinstance(P, NetworkedStateSpace)
    assert P.B1.shape == (1, 1) and P.C1.shape == (1, 1)
    assert np.allclose(ct.evalfr(P, 0.3)[1, 1], ct.evalfr(G, 0.3))


@pytest.mark.parametrize("nmeas, ncon, arg", [(1, 2, "ncon"), (2, 1, "nmeas")])
def test_counts_leaving_no_w_or_no_z_are_refused_naming_the_dimensions(
        nmeas, ncon, arg):
    A, B, C, D = [[0.5]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0]] * 2
    with pytest.raises(ControlDimension, match=rf"{arg}: .*dim w = "
                       rf"{2 - ncon} and dim z = {2 - nmeas}"):
        nss(A, B, C, D, nmeas=nmeas, ncon=ncon)


def test_feedthrough_into_y_names_the_dimensions_of_w_and_z():
    # a feedthrough from the last input into the last output: y would see u
    # (D22), the message says how the inputs and outputs were split
    with pytest.raises(ValueError, match="dim w = 2 and dim z = 1"):
        nss([[0.5]], [[1.0, 1.0, 1.0]], [[1.0], [1.0]],
            [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], nmeas=1, ncon=1)


def test_network_attributes_are_stored():
    P = nss(*example_matrices(), nmeas=2, ncon=1, sensor_schedule=[1, 2, 0],
            actuator_schedule=[0, 0, 1], sensor_loss=0.1, actuator_loss=0.2,
            shared_channel=True)
    assert (P.nmeas, P.ncon, P.period) == (2, 1, 3)
    assert (P.sensor_loss, P.actuator_loss, P.shared_channel) == (0.1, 0.2, True)


def test_with_network_changes_only_the_network():
    P = random_plant(np.random.default_rng(3), n=2, sensor_loss=0.1)
    Q = P.with_network(sensor_loss=0.4, actuator_schedule=[1, 0])
    assert Q.sensor_loss == 0.4 and Q.period == 2 and P.sensor_loss == 0.1
    for X, Y in zip((P.A, P.B, P.C, P.D), (Q.A, Q.B, Q.C, Q.D)):
        assert np.array_equal(X, Y)


def test_with_network_rejects_unknown_settings():
    P = random_plant(np.random.default_rng(3))
    with pytest.raises(TypeError, match="bogus"):
        P.with_network(bogus=1)


def test_pickle_round_trip_is_equal_and_keeps_the_type():
    P = nss(*example_matrices(), 0.25, nmeas=2, ncon=1,
            sensor_schedule=[2, 1, 0, 2], actuator_schedule=[[1], [0]],
            sensor_loss=0.1, actuator_loss=0.3, name="plant")
    Q = pickle.loads(pickle.dumps(P))
    assert type(Q) is NetworkedStateSpace and Q.equals(P)
    assert Q.name == "plant" and Q.dt == 0.25
    assert Q.sensor_schedule == P.sensor_schedule


@pytest.mark.parametrize("duplicate", [copy.copy, copy.deepcopy])
def test_copies_are_equal_and_keep_the_type(duplicate):
    P = random_plant(np.random.default_rng(4), n=3, m2=2,
                     sensor_schedule=[1, 2, 3], actuator_loss=0.2)
    Q = duplicate(P)
    assert type(Q) is NetworkedStateSpace and Q.equals(P) and Q is not P


def test_equality_sees_a_different_network():
    P = random_plant(np.random.default_rng(5), sensor_loss=0.1)
    assert P != P.with_network(sensor_loss=0.2)
    assert P != P.with_network(sensor_schedule=[1, 2])


def test_repr_and_str_say_what_it_is():
    P = nss(*example_matrices(), nmeas=2, ncon=1, sensor_schedule=[2, 1, 0, 2],
            sensor_loss=0.125, name="plant")
    r, s = repr(P), str(P)
    assert r.startswith("<NetworkedStateSpace plant")
    assert "period 4" in r and "α1=0.125" in r
    assert s.startswith("NetworkedStateSpace: plant")
    assert "sensor schedule" in s and "0.125" in s and "nmeas = 2" in s
