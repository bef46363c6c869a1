"""Every public result, system and exception survives pickling.

Sweeps cross process boundaries by pickling (ProcessPoolExecutor, Dask), so
each object a public function returns or raises must come back equal in
what it says. One test per kind of object.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import control_ncs as ncs
from control_ncs.exceptions import CertificationError, SynthesisError


def _plant():
    return ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   actuator_loss=0.1, name="scalar")


@pytest.fixture(scope="module")
def design():
    return ncs.passivesyn(_plant(), decay=0.9)


def _round_trip(obj):
    return pickle.loads(pickle.dumps(obj))


def test_plant_round_trips_with_its_network():
    P = _plant()
    Q = _round_trip(P)
    assert Q.equals(P) and Q.name == P.name


def test_closed_loop_round_trips_with_its_modes(design):
    _, CL, _ = design
    CL2 = _round_trip(CL)
    assert CL2.equals(CL) and ncs.ms_radius(CL2) == ncs.ms_radius(CL)


def test_gain_and_synthesis_result_round_trip(design):
    K, _, eta = design
    K2 = _round_trip(K)
    np.testing.assert_array_equal(K2.gains, K.gains)
    res = _round_trip(K.result)
    assert res.eta == eta and res.certificate.verified
    np.testing.assert_array_equal(res.certificate.P, K.result.certificate.P)


def test_certificate_and_passivity_result_round_trip(design):
    _, CL, _ = design
    cert = _round_trip(ncs.verify.certify_index(CL, CL.info["synthesis"].certificate.P))
    assert cert.verified
    res = ncs.passivity_certificate(CL)
    assert _round_trip(res).eta == res.eta


def test_moments_and_responses_round_trip(design):
    _, CL, _ = design
    mom = ncs.moments(CL, 5)
    np.testing.assert_array_equal(_round_trip(mom).outputs_mean,
                                  mom.outputs_mean)
    paths = ncs.simulate(CL, 5, trials=3, seed=1)
    np.testing.assert_array_equal(_round_trip(paths).outputs, paths.outputs)
    ens = ncs.step_response(CL, 5, trials=3, seed=1)
    np.testing.assert_array_equal(_round_trip(ens).sample_mean,
                                  ens.sample_mean)


def test_schedule_round_trips():
    s = ncs.schedule([2, 1, 0, 2], 2)
    assert _round_trip(s) == s


@pytest.mark.parametrize("cls", [CertificationError, SynthesisError])
def test_exceptions_round_trip_with_reason_and_figures(cls):
    err = cls("no certificate", "infeasible", dict(ms_radius=1.2))
    back = _round_trip(err)
    assert type(back) is cls and back.reason == "infeasible"
    assert back.figures == dict(ms_radius=1.2) and str(back) == str(err)
