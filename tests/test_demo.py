"""The demo command runs end to end and writes real PNG files."""

import subprocess
import sys

import pytest

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow  # a subprocess: seconds, still run in CI
def test_demo_command_exits_0_and_writes_png_files(tmp_path):
    out = tmp_path / "plots"
    proc = subprocess.run(
        [sys.executable, "-m", "control_ncs", "demo", "--out", str(out),
         "--trials", "40"],
        capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    pngs = sorted(out.glob("*.png"))
    assert [p.name for p in pngs] == ["eta_vs_loss.png", "passivity.png",
                                      "schedule.png", "step.png"]
    for p in pngs:
        data = p.read_bytes()
        assert data.startswith(PNG_SIGNATURE) and len(data) > 5000, p.name
    # the printed report carries the verification figures
    assert "λmax(Θ_k)" in proc.stdout
    assert "ms_radius" in proc.stdout


def test_demo_design_is_verified_and_stabilises_an_unstable_plant():
    from control_ncs.demo import levitation_stage
    from control_ncs import feedback, ms_radius, passivesyn
    import numpy as np

    P = levitation_stage()
    assert ms_radius(feedback(P, np.zeros((2, 4)))) > 1.0
    K, CL, eta = passivesyn(P, decay=0.995)
    assert K.result.certificate.verified
    assert ms_radius(CL) < 0.995 ** 2
    assert eta > 0
