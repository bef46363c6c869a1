"""No test depends on the machine's speed: no timeout on a subprocess, a
worker or a notebook, and no assertion on elapsed time. A shared or loaded
machine runs the suite slower, never differently."""

import ast
import pathlib

import pytest

TESTS = pathlib.Path(__file__).resolve().parent
CLOCKS = {"perf_counter", "time", "monotonic", "process_time",
          "perf_counter_ns", "monotonic_ns", "time_ns"}


def _reads_a_clock(node):
    return any(isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
               and n.func.attr in CLOCKS
               and isinstance(n.func.value, ast.Name)
               and n.func.value.id == "time"
               for n in ast.walk(node))


def offences(source):
    """Lines of ``source`` with a timeout or an elapsed-time comparison."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.keyword) and node.arg == "timeout" and not (
                isinstance(node.value, ast.Constant)
                and node.value.value is None):
            found.append(node.value.lineno)
        if isinstance(node, ast.Compare) and _reads_a_clock(node):
            found.append(node.lineno)
    return found


@pytest.mark.parametrize("path", sorted(TESTS.glob("*.py")),
                         ids=lambda p: p.name)
def test_no_timeout_and_no_elapsed_time_assertion(path):
    assert offences(path.read_text(encoding="utf-8")) == []


@pytest.mark.parametrize("source", [
    "subprocess.run(cmd, timeout=300)",
    "future.result(timeout=120)",
    "assert time.perf_counter() - start < 5.0",
    "assert time.time() - t0 <= 10",
])
def test_the_check_finds_each_kind_of_speed_dependence(source):
    assert offences(source) == [1]


@pytest.mark.parametrize("source", [
    "NotebookClient(nb, timeout=None)",
    "deadline = time.perf_counter() - 1.0",
    "assert res.iterations <= 2",
])
def test_the_check_lets_clock_free_code_pass(source):
    assert offences(source) == []


def test_notebook_cells_run_without_a_time_limit():
    # nbmake stops a cell after 300 s unless told otherwise (-1: never);
    # read as text (tomllib is Python 3.11+)
    pyproject = (TESTS.parent / "pyproject.toml").read_text(encoding="utf-8")
    addopts = [line for line in pyproject.splitlines()
               if line.startswith("addopts")]
    assert len(addopts) == 1
    assert "--nbmake " in addopts[0] and "--nbmake-timeout=-1" in addopts[0]
