"""Smoke test of the benchmark runner: ``python -m benchmarks --quick``.

Runs every section at tiny sizes into a temporary directory and checks that
the report and the plot are written with the expected sections. No timing
is asserted and the run has no time limit: the machine is shared, and a
loaded machine must not fail it (the real numbers are in
docs/benchmarks.md, from a full run).
"""

import os
import subprocess
import sys
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.mark.slow  # a subprocess: seconds, still run in CI
def test_quick_run_writes_report(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--quick", "--out", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    md = tmp_path / "benchmarks.md"
    png = tmp_path / "benchmarks_scaling.png"
    assert md.exists() and png.exists() and png.stat().st_size > 1000
    text = md.read_text()
    for heading in ("# control_ncs benchmarks", "## Targets",
                    "## 1. passivesyn", "## 1b.", "## 2. The n = 64",
                    "## 2c.", "## 3. ms_radius", "## 3b.", "## 4. simulate",
                    "## 5. Loss-free passivity", "## 6. Scaling",
                    "## 7. Sweeps", "## 8. Bursty (Markov) losses",
                    "## 9. Estimator synthesis"):
        assert heading in text, heading
    assert "(failed)" not in text, text[text.find("(failed)") - 200:][:2000]
    for version in ("python", "numpy", "scipy", "cvxpy", "clarabel",
                    "control"):
        assert version in text
