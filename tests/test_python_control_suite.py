"""python-control's own test suite, run on jump systems.

python-control's installed test files (:data:`FILES`) run in a pytest
session of their own, with the plugin ``tests/jump_substitution.py``:
every discrete-time ``StateSpace`` the tests build is a one-mode
:class:`control_ncs.JumpStateSpace` with the same matrices, ``dt`` and
names, and python-control's own functions then operate on it. The
plugin counts the substitutions (so that they cannot silently stop) and
records every test's outcome. Every test passes except the
:data:`DIFFERENCES`, where a jump system must differ from python-control's
class, each with its reason; a documented difference that starts passing
fails here too, so the list stays exact.

The session is a subprocess (python-control's ``conftest.py`` and
configuration are its own) and has no time limit: the machine's speed
cannot fail it. It takes about 60 s of CPU on one core.
"""

from __future__ import annotations

import collections
import json
import os
import pathlib
import subprocess
import sys

import control as ct
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PC_TESTS = pathlib.Path(ct.__file__).parent / "tests"

#: python-control's test files that run on jump systems: the core of its
#: linear systems (state space, I/O systems, discrete time, block
#: diagrams, interconnection, time and frequency responses, LTI, state
#: feedback, stochastic systems, norms) and every other file that builds a
#: discrete-time StateSpace, except the slow optimal-control one.
FILES = ("statesp", "iosys", "discrete", "bdalg", "interconnect",
         "timeresp", "freqresp", "lti", "statefbk", "stochsys", "sysnorm",
         "config", "kwargs", "matlab", "modelsimp", "namedio", "timebase",
         "trdata", "xferfcn", "nyquist", "rlocus")

_NONE = "builds no discrete-time StateSpace (none would be substituted)"

#: python-control's test files left out, and why.
LEFT_OUT = {
    "optimal": "optimal control and MPC (21 systems substituted) takes "
               "about 5 minutes; its one difference: ct.feedback(J, K) with "
               "a nonlinear controller K is refused (ControlArgument), since "
               "the result cannot be a jump system",
    "passivity": "runs in tests/test_python_control_passivity.py, with the "
                 "package's passivity functions substituted",
    "docstrings": "inspects python-control's docstrings and signatures, "
                  "which the substitution wraps; " + _NONE,
    "robust": "needs slycot (h2syn, hinfsyn, mixsyn), not installed",
    "slycot_convert": "needs slycot, not installed",
    "ctrlplot": "plots (about 4 minutes); " + _NONE,
    "freqplot": "plots (about 3 minutes); " + _NONE,
    "timeplot": "plots (over a minute); " + _NONE,
    "phaseplot": "phase portraits (over a minute); " + _NONE,
    **{name: _NONE for name in (
        "bspline", "canonical", "convert", "ctrlutil", "delay", "descfcn",
        "flatsys", "frd", "input_element_int", "margin", "mateqn", "matlab2",
        "minreal", "nichols", "nlsys", "pzmap", "response", "sisotool",
        "type_conversion", "xferfcn_input")},
}

#: Tests of python-control's where a jump system must differ, by node id
#: prefix, with the reason.
DIFFERENCES = {
    "statesp_test.py::test_html_repr[":
        "the HTML header names the class, as python-control's own "
        "subclasses do (self.__class__.__name__): 'JumpStateSpace', where "
        "the reference text says 'StateSpace'; the LaTeX of the matrices "
        "is python-control's, unchanged (36 parametrisations)",
    "statesp_test.py::TestStateSpace::test_str":
        "str names the class ('<JumpStateSpace>: sys') and adds the mode "
        "law (period, modes, probabilities) before python-control's "
        "A, B, C, D",
    "statesp_test.py::TestStateSpace::test_repr":
        "the loadable repr rebuilds a JumpStateSpace ('JumpStateSpace(...)', "
        "with its mode law), so it needs that name, not StateSpace, where "
        "it is evaluated",
    "config_test.py::TestConfig::test_repr_format[":
        "the same: eval(repr(sys)) with only StateSpace and array in scope "
        "(one parametrisation, the discrete-time one)",
    "statefbk_test.py::TestStatefbk::test_lqr_integral_discrete":
        "assigns sys.C = np.eye(4): a JumpStateSpace is immutable (its "
        "matrices are the exact mean of its modes), the assignment raises "
        "AttributeError",
    "stochsys_test.py::test_estimator_errors":
        "the same: assigns sys_fs.C",
}

#: At least this many systems must have been substituted.
MIN_SUBSTITUTED = 2000


def _documented(nodeid: str) -> str | None:
    short = nodeid.split("::")[0].rsplit("/", 1)[-1] + nodeid[
        len(nodeid.split("::")[0]):]
    return next((p for p in DIFFERENCES if short.startswith(p)), None)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("python_control_suite")
    ini = tmp / "pytest.ini"
    ini.write_text("[pytest]\n", encoding="utf-8")
    out = tmp / "report.json"
    env = dict(os.environ, MPLBACKEND="Agg",
               JUMP_SUBSTITUTION_REPORT=str(out))
    env["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT / "tests"), str(ROOT)] + [p for p in env.get(
            "PYTHONPATH", "").split(os.pathsep) if p])
    env.pop("JUMP_SUBSTITUTION", None)
    files = [str(PC_TESTS / f"{name}_test.py") for name in FILES]
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "jump_substitution",
         "-p", "no:cacheprovider", "-q", "-c", str(ini),
         "--rootdir", str(PC_TESTS.parent), *files],
        cwd=tmp, env=env, capture_output=True, text=True)
    assert out.exists(), proc.stdout[-3000:] + proc.stderr[-3000:]
    data = json.loads(out.read_text(encoding="utf-8"))
    data["log"] = proc.stdout[-20000:] + proc.stderr[-5000:]
    return data


def test_the_lists_cover_every_test_file_of_python_control():
    present = {p.name[:-len("_test.py")] for p in PC_TESTS.glob("*_test.py")}
    assert set(FILES) | set(LEFT_OUT) == present
    assert not set(FILES) & set(LEFT_OUT)


def test_python_controls_tests_ran_on_jump_systems(report):
    counts = report["counts"]
    assert report["enabled"]
    assert counts["substituted"] >= MIN_SUBSTITUTED, counts
    outcomes = collections.Counter(report["outcomes"].values())
    assert outcomes["passed"] >= 2400, outcomes
    for name in FILES:
        assert any(f"/{name}_test.py::" in node
                   for node in report["outcomes"]), name


def test_only_the_documented_differences_fail(report):
    failed = sorted(n for n, o in report["outcomes"].items()
                    if o == "failed")
    unexpected = [n for n in failed if _documented(n) is None]
    assert not unexpected, "\n".join(unexpected) + "\n" + report["log"]


def test_every_documented_difference_still_differs(report):
    failed = [n for n, o in report["outcomes"].items() if o == "failed"]
    for prefix in DIFFERENCES:
        assert any(_documented(n) == prefix for n in failed), prefix
