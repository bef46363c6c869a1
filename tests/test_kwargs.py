"""Unknown keywords raise TypeError, as in python-control (its kwargs_test).

Every public function or method that takes ``**kwargs`` is listed in
``CALLS`` with a call that would otherwise succeed; a second test makes sure
the list stays complete, so a new ``**kwargs`` function must join it.
"""

import importlib
import inspect

import control as ct
import numpy as np
import pytest

import control_ncs as ncs


def _plant():
    return ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.5, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   actuator_loss=0.1)


def _loop():
    return ncs.feedback(_plant(), [[-1.0]])


def _jss(**kw):
    return ncs.jss([[[0.5]], [[0.1]]], [[1.0]], [[1.0]], [[0.0]], [0.4, 0.6],
                   **kw)


G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], True)


def _switching():
    return ncs.SwitchingSystem([[[0.5]], [[0.2]]], 1.0, 1.0, 1.0)

#: name -> a call that succeeds without the bogus keyword
CALLS = {
    "JumpStateSpace": lambda **kw: ncs.JumpStateSpace(
        [[[0.5]]], [[[1.0]]], [[[1.0]]], [[[0.0]]], [[1.0]], **kw),
    "JumpStateSpace.update_names": lambda **kw: _jss().update_names(**kw),
    "JumpStateSpace.feedback": lambda **kw: _jss().feedback(G, **kw),
    "JumpStateSpace.linearize": lambda **kw: _jss().linearize(0.0, **kw),
    "jss": _jss,
    "NetworkedStateSpace": lambda **kw: ncs.NetworkedStateSpace(
        [[1.1]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.5, 0.0], [0.0, 0.0]],
        nmeas=1, ncon=1, **kw),
    "NetworkedStateSpace.with_network": lambda **kw: _plant().with_network(
        **kw),
    "nss": lambda **kw: ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                                [[0.5, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                                **kw),
    "feedback": lambda **kw: ncs.feedback(_plant(), [[-1.0]], **kw),
    "ms_radius": lambda **kw: ncs.ms_radius(_loop(), **kw),
    "is_mss": lambda **kw: ncs.is_mss(_loop(), **kw),
    "moments": lambda **kw: ncs.moments(_loop(), 3, **kw),
    "ispassive": lambda **kw: ncs.ispassive(_loop(), **kw),
    "JumpStateSpace.ispassive": lambda **kw: _loop().ispassive(**kw),
    "norm": lambda **kw: ncs.norm(_loop(), **kw),
    "l2_gain": lambda **kw: ncs.l2_gain(_loop(), **kw),
    "dissipativity": lambda **kw: ncs.dissipativity(_loop(), 0.0, 1.0, 0.0,
                                                   **kw),
    "hinfsyn": lambda **kw: ncs.hinfsyn(ncs.nss(
        [[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
        [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
        actuator_loss=0.5), **kw),
    "h2syn": lambda **kw: ncs.h2syn(ncs.nss(
        [[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
        [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
        actuator_loss=0.5), **kw),
    "lyapunov_exponent": lambda **kw: ncs.lyapunov_exponent(
        _loop(), steps=20, trials=2, seed=1, **kw),
    "critical_loss": lambda **kw: ncs.critical_loss(ncs.nss(
        [[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]], True,
        nmeas=1, ncon=1), [[-2.0]], tol=1e-2, **kw),
    "dlqr": lambda **kw: ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]],
                                  arrival=0.5, **kw),
    "dlqe": lambda **kw: ncs.dlqe([[1.2]], [[1.0]], [[1.0]], [[1.0]],
                                  [[1.0]], arrival=0.5, **kw),
    "critical_arrival": lambda **kw: ncs.critical_arrival([[1.2]], [[1.0]],
                                                          **kw),
    "isestimable": lambda **kw: ncs.isestimable([[1.2]], [[1.0]], 0.3, **kw),
    "lqg": lambda **kw: ncs.lqg(_plant(), [[1.0]], [[1.0]], [[1.0]],
                                [[1.0]], **kw),
    "JumpStateSpace.step_response": lambda **kw: _loop().step_response(
        5, trials=4, seed=1, **kw),
    "JumpStateSpace.impulse_response": lambda **kw: _loop().impulse_response(
        5, trials=4, seed=1, **kw),
    "JumpStateSpace.initial_response": lambda **kw: _loop().initial_response(
        5, [1.0], trials=4, seed=1, **kw),
    "JumpStateSpace.forced_response": lambda **kw: _loop().forced_response(
        np.arange(5), np.ones((1, 5)), trials=4, seed=1, **kw),
    "get_input_ff_index": lambda **kw: ncs.get_input_ff_index(_loop(), **kw),
    "get_output_fb_index": lambda **kw: ncs.get_output_fb_index(
        ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True), **kw),
    "mean_input_ff_index": lambda **kw: ncs.mean_input_ff_index(_loop(),
                                                                **kw),
    "frequency_ff_index": lambda **kw: ncs.frequency_ff_index(_loop(), **kw),
    "passivity_certificate": lambda **kw: ncs.passivity_certificate(_loop(),
                                                                    **kw),
    "passivesyn": lambda **kw: ncs.passivesyn(_plant(), decay=0.99, **kw),
    "simulate": lambda **kw: ncs.simulate(_loop(), 3, trials=2, seed=0, **kw),
    "SamplePaths.plot": lambda **kw: ncs.simulate(
        _loop(), 3, trials=2, seed=0).plot(**kw),
    "EnsembleResponse.plot": lambda **kw: ncs.step_response(
        _loop(), 3, trials=2, seed=0).plot(**kw),
    "forced_response": lambda **kw: ncs.forced_response(
        _loop(), 3, np.ones(3), trials=2, seed=0, **kw),
    "step_response": lambda **kw: ncs.step_response(_loop(), 3, trials=2,
                                                    seed=0, **kw),
    "impulse_response": lambda **kw: ncs.impulse_response(
        _loop(), 3, trials=2, seed=0, **kw),
    "initial_response": lambda **kw: ncs.initial_response(
        _loop(), 3, [1.0], trials=2, seed=0, **kw),
    "jump_feedback": lambda **kw: ncs.jump_feedback(_loop(), G, **kw),
    "lift_lti": lambda **kw: ncs.lift_lti(G, 2, **kw),
    "interconnect": lambda **kw: ncs.interconnect(
        [_loop()], inplist=["w[0]"], outlist=["z[0]"], **kw),
    "worst_case_dissipativity": lambda **kw: ncs.worst_case_dissipativity(
        _switching(), 0.0, 1.0, 0.0, cycle_length=2, **kw),
    "worst_case_gain": lambda **kw: ncs.worst_case_gain(
        _switching(), cycle_length=2, **kw),
    "worst_case_passivity": lambda **kw: ncs.worst_case_passivity(
        _switching(), cycle_length=2, **kw),
    "worst_case_rate": lambda **kw: ncs.worst_case_rate(
        _switching(), cycle_length=2, tol=1e-3, **kw),
    "worst_case_design": lambda **kw: ncs.worst_case_design(
        ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 1.0,
                                   [(0, 0, 1), (0, 1, 0), (1, 0, 1)]),
        cycle_length=2, **kw),
    "worst_case_route": lambda **kw: ncs.worst_case_route(
        ncs.build(ncs.nss([[1.5]], [[1.0, 1.0]], [[1.0], [1.0]],
                          [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                          actuator_loss=ncs.max_consecutive_losses(1))),
        cycle_length=2, **kw),
}

#: not a keyword funnel: the gain's info travels to the closed loop
EXEMPT = {"JumpPlant.close"}

#: plots hand their keywords to matplotlib, which refuses an unknown one
#: with AttributeError (python-control's kwargs_test accepts either too)
PLOTS = {"SamplePaths.plot", "EnsembleResponse.plot"}


def _public_kwargs_callables():
    names = set()
    for name in [*ncs.__all__, *ncs._IN_SUBMODULE]:
        obj = getattr(importlib.import_module(
            ncs._IN_SUBMODULE.get(name, "control_ncs")), name)
        members = [(name, obj)]
        if inspect.isclass(obj):
            members += [(f"{name}.{m}", v) for m, v in vars(obj).items()
                        if callable(v) and not m.startswith("_")]
        for label, func in members:
            try:
                params = inspect.signature(func).parameters.values()
            except (TypeError, ValueError):
                continue
            if any(p.kind is p.VAR_KEYWORD for p in params):
                names.add(label)
    return names


def test_every_public_kwargs_callable_is_tested():
    missing = _public_kwargs_callables() - set(CALLS) - EXEMPT
    assert not missing, sorted(missing)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_call_succeeds_without_the_unknown_keyword(name):
    import matplotlib.pyplot as plt
    try:
        CALLS[name]()
    finally:
        plt.close("all")


@pytest.mark.parametrize("name", sorted(CALLS))
def test_unknown_keyword_raises_type_error(name):
    import matplotlib.pyplot as plt
    try:
        errors = (TypeError, AttributeError) if name in PLOTS else TypeError
        with pytest.raises(errors, match="unknown_kw"):
            CALLS[name](unknown_kw=1)
    finally:
        plt.close("all")
