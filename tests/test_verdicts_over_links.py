"""The same verdicts over every link: a delayed link's loop is judged as a
lossy link's is (the designs and analyses read only the one open loop)."""

import warnings

import pytest

import control_ncs as ncs


def _delayed(**extra):
    """x⁺ = 1.2x + w + u, z = x + 0.5w, y = x, the measurement delayed."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.5, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
                   sensor_delay=[0.5, 0.3, 0.1], **extra)


def test_a_negative_certified_level_over_a_delayed_link_is_a_shortage():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        K, CL, eta = ncs.passivesyn(_delayed(), options={"time_limit": 30})
    assert eta < 0 and K.result.status == "certified_shortage"
    assert not K.result.passive
    assert [w.category for w in caught
            if issubclass(w.category, ncs.NotPassiveWarning)] \
        == [ncs.NotPassiveWarning]


def test_the_feedthrough_bound_refuses_at_once_over_a_delayed_link(
        monkeypatch):
    from control_ncs.synthesis import refine

    def never(*args, **kwargs):
        raise AssertionError("a search ran before the refusal")

    monkeypatch.setattr(refine, "_refine", never)
    with pytest.raises(ValueError, match=r"^eta: D11 \+ D11ᵀ"):
        ncs.passivesyn(_delayed(), eta=0.6)


def test_a_stable_loop_over_a_delayed_link_that_is_not_passive_says_so():
    CL = ncs.feedback(_delayed(), [[-0.9, -0.3, 0.1]])
    assert ncs.ms_radius(CL) < 1.0
    assert ncs.ispassive(CL) is False
