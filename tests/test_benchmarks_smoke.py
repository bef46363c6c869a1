"""Smoke test of the benchmark runner: ``python -m benchmarks --quick``.

Runs every section at tiny sizes into a temporary directory, in this
process (the runner's ``main``), and checks that the report and the plot
are written with the expected sections, and that every section states its
targets and the run reports each one. No timing is asserted and the run
has no time limit: the machine is shared, and a loaded machine must not
fail it (the real numbers are in docs/benchmarks.md, from a full run).
"""

import re
import runpy
import sys

import pytest

from benchmarks import __main__ as runner


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick")
    import io
    from contextlib import redirect_stdout
    printed = io.StringIO()
    with redirect_stdout(printed):
        assert runner.main(["--quick", "--out", str(out)]) == 0
    return out, printed.getvalue()


@pytest.mark.slow  # every section at tiny sizes: tens of seconds
def test_quick_run_writes_report(quick_run):
    out, _ = quick_run
    md = out / "benchmarks.md"
    png = out / "benchmarks_scaling.png"
    assert md.exists() and png.exists() and png.stat().st_size > 1000
    text = md.read_text()
    for heading in ("# control_ncs benchmarks", "## Targets",
                    "## 1. passivesyn", "## 1b.", "## 2. The n = 64",
                    "## 2c.", "## 3. ms_radius", "## 3b.", "## 4. simulate",
                    "## 4b. simulate at scale", "## 5. Loss-free passivity",
                    "## 6. Scaling", "## 7. Sweeps",
                    "## 8. Bursty (Markov) losses", "## 9. Estimator synthesis",
                    "## 11. The second-moment kernel", "## 12. The kernels"):
        assert heading in text, heading
    assert "(failed)" not in text, text[text.find("(failed)") - 200:][:2000]
    for version in ("python", "numpy", "scipy", "cvxpy", "clarabel",
                    "control"):
        assert version in text


@pytest.mark.slow
def test_quick_run_reports_every_sections_targets(quick_run):
    out, printed = quick_run
    assert "states no target" not in printed, printed
    lines = [line for line in printed.splitlines()
             if line.startswith("[target] ")]
    words = [line.split()[1] for line in lines]
    assert lines and set(words) <= {"met", "MISSED", "–"}, lines
    summary = re.search(r"targets: (\d+) met, (\d+) missed, (\d+) not "
                        r"measured in this run; 0 section\(s\) failed",
                        printed)
    assert summary, printed[-2000:]
    assert sum(map(int, summary.groups())) == len(lines)
    table = (out / "benchmarks.md").read_text().split("## Targets")[1]
    table = table.split("\n#")[0]                 # up to the next heading
    assert table.count("\n| ") - 1 == len(lines)     # header row excluded


def test_quick_run_never_writes_into_docs_by_default(monkeypatch, tmp_path):
    made = []

    def fake_run(quick, only):
        return []
    monkeypatch.setattr(runner, "_run_sections", fake_run)
    monkeypatch.setattr(runner.tempfile, "mkdtemp",
                        lambda prefix: made.append(prefix) or str(tmp_path))
    assert runner.main(["--quick"]) == 0
    assert made == ["benchmarks-quick-"]
    assert (tmp_path / "benchmarks.md").exists()


def test_help_states_the_quick_runs_time(capsys):
    with pytest.raises(SystemExit):
        runner.main(["--help"])
    assert "< 30 s" in capsys.readouterr().out


def test_runner_runs_as_a_module(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "argv", ["benchmarks", "--only", "nothing",
                                      "--quick", "--out", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:
        runpy.run_module("benchmarks", run_name="__main__")
    assert stop.value.code == 0
    assert (tmp_path / "benchmarks.md").exists()
