"""python-control's own passivity tests, run against control_ncs.

The file ``control/tests/passivity_test.py`` of the installed
python-control is loaded and run twice with our ``ispassive``,
``get_input_ff_index`` and ``get_output_fb_index`` in place of its own
(``sys.ispassive()`` included): once as written, and once with every
continuous-time system sampled first (bilinear, which keeps passivity).
Our functions need no cvxopt, so python-control's "cvxopt only" marker is
dropped.
"""

from __future__ import annotations

import importlib.util
import inspect
import pathlib
import types

import control as ct
import pytest

import control_ncs as ncs

SOURCE = pathlib.Path(ct.__file__).parent / "tests" / "passivity_test.py"


def _solve_passivity_lmi(sys, rho=None, nu=None):
    """python-control's ``solve_passivity_LMI`` contract on our certificate
    (the only part its tests use: both indices None is refused)."""
    return ncs.passivity_certificate(sys, nu, ofp_index=rho)


OURS = types.SimpleNamespace(
    ispassive=ncs.ispassive, get_input_ff_index=ncs.get_input_ff_index,
    get_output_fb_index=ncs.get_output_fb_index,
    solve_passivity_LMI=_solve_passivity_lmi)


def _load() -> types.ModuleType:
    spec = importlib.util.spec_from_file_location("pc_passivity_test", SOURCE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _sampled(make):
    """``make`` (ss or tf) whose continuous-time results are sampled."""
    def wrapper(*args, **kwargs):
        sys = make(*args, **kwargs)
        return (ct.sample_system(sys, 0.1, method="bilinear")
                if sys.isctime(strict=True) else sys)
    return wrapper


def _sample_once(sys, Ts, method="zoh", **kwargs):
    """python-control's ``sample_system``; an already sampled system
    (the second form's) is kept."""
    if sys.isdtime(strict=True):
        return sys
    return ct.sample_system(sys, Ts, method=method, **kwargs)


MODULE = _load()
CASES = []
for _name, _func in inspect.getmembers(MODULE, inspect.isfunction):
    if not _name.startswith("test_"):
        continue
    marks = getattr(_func, "pytestmark", [])
    params = [m for m in marks if m.name == "parametrize"]
    if params:
        argnames, values = params[0].args[:2]
        for i, value in enumerate(values):
            CASES.append(pytest.param(_name, value, id=f"{_name}[{i}]"))
    else:
        CASES.append(pytest.param(_name, None, id=_name))


@pytest.fixture
def substituted(monkeypatch):
    monkeypatch.setattr(MODULE, "passivity", OURS)
    # LTI.ispassive imports control.passivity.ispassive when called
    monkeypatch.setattr(ct.passivity, "ispassive", ncs.ispassive)
    return MODULE


def _run(module, name, value):
    func = getattr(module, name)
    if value is None:
        func()
    else:
        func(*value)


def test_the_file_is_python_controls_thirteen_tests():
    assert len(CASES) == 13


@pytest.mark.parametrize("name, value", CASES)
def test_as_written(substituted, name, value):
    _run(substituted, name, value)


@pytest.mark.parametrize("name, value", CASES)
def test_with_continuous_systems_sampled(substituted, monkeypatch, name,
                                         value):
    monkeypatch.setattr(substituted, "ss", _sampled(ct.ss))
    monkeypatch.setattr(substituted, "tf", _sampled(ct.tf))
    monkeypatch.setattr(substituted, "sample_system", _sample_once)
    _run(substituted, name, value)
