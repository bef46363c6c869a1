"""Figures say what they are drawn for: the demo's passivity figure tells
its three levels apart, and a colour bar's ticks read as the numbers they
stand for (no offset)."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import control_ncs as ncs  # noqa: E402
from control_ncs.demo import levitation_stage, passivity_figure  # noqa: E402
from control_ncs.plots import plain_ticks  # noqa: E402


@pytest.fixture(scope="module")
def demo_design():
    K, CL, eta = ncs.passivesyn(levitation_stage(), decay=0.995)
    return CL, eta, ncs.mean_input_ff_index(CL)


def _span(values, ax):
    low, high = ax.get_ylim()
    return (np.max(values) - np.min(values)) / (high - low)


def test_passivity_figure_tells_the_three_levels_apart(demo_design):
    CL, eta, mean_eta = demo_design
    fig = passivity_figure(CL, eta, mean_eta)
    ax, bx = fig.axes
    margin, mean_line, eta_line = bx.get_lines()
    # the margin above η fills its axes instead of a flat line at its top
    assert _span(margin.get_ydata(), bx) > 0.25
    # η (at 0), the mean system's index and the curve are a tenth of the
    # axes apart at least
    gap = (mean_line.get_ydata()[0] - eta_line.get_ydata()[0]) / np.ptp(
        bx.get_ylim())
    assert eta_line.get_ydata()[0] == 0.0 and gap > 0.1
    # the left panel is drawn from zero and shows the loop's dynamics
    assert ax.get_ylim()[0] == 0.0
    lam_max = ax.get_lines()[1].get_ydata()
    assert _span(lam_max, ax) > 0.1
    plt.close(fig)


def test_passivity_figure_draws_the_certified_levels(demo_design):
    # an independent route: the frequency sweep's smallest eigenvalue is the
    # mean system's index (the LMI's, certified from below), and the
    # stochastic certificate is never above it
    CL, eta, mean_eta = demo_design
    fig = passivity_figure(CL, eta, mean_eta)
    margin = fig.axes[1].get_lines()[0].get_ydata() + eta
    assert mean_eta - 1e-9 <= margin.min() <= mean_eta * (1 + 1e-3)
    assert eta <= mean_eta
    plt.close(fig)


def test_passivity_figure_writes_plain_ticks(demo_design):
    fig = passivity_figure(*demo_design)
    fig.canvas.draw()
    for ax in fig.axes:
        assert ax.yaxis.get_offset_text().get_text() == ""
    plt.close(fig)


def _map(values):
    v = np.asarray(values, float)
    grid = np.array([0.0, 0.1, 0.2])
    # what design_map_plot reads of a DesignMap
    return SimpleNamespace(objective="eta", value=v, ms_radius=v,
                           values=(grid, grid),
                           axes=("sensor_loss", "actuator_loss"),
                           shape=v.shape, feasible=np.isfinite(v))


@pytest.mark.parametrize("centre, spread", [(-3e-4, 4e-8), (0.4743018, 7e-8),
                                            (0.47, 3e-3), (1234.5, 10.0)])
def test_design_map_colour_bar_reads_without_offset(centre, spread):
    values = centre + spread * np.linspace(0, 1, 9).reshape(3, 3)
    cplt = ncs.design_map_plot(_map(values))
    cplt.figure.canvas.draw()
    bar = cplt.lines[0, 0][0].colorbar
    axis = bar.ax.yaxis
    assert axis.get_offset_text().get_text() == ""
    ticks = [t for t in axis.get_major_ticks()
             if values.min() <= t.get_loc() <= values.max()]
    labels = [t.label1.get_text().replace("\u2212", "-") for t in ticks]
    locs = np.array([t.get_loc() for t in ticks])
    assert len(ticks) >= 3 and len(set(labels)) == len(labels)
    # each label is the number at its tick, to a tenth of the spacing
    step = np.min(np.diff(locs))
    assert np.allclose([float(s) for s in labels], locs, rtol=0,
                       atol=0.1 * step)
    plt.close(cplt.figure)


@pytest.mark.parametrize("locs, expected", [
    ([0.47335, 0.4734, 0.47345], ["0.47335", "0.47340", "0.47345"]),
    ([-3.0002e-4, -3.0001e-4, -3.0e-4],
     ["-0.00030002", "-0.00030001", "-0.00030000"]),
    ([-1.0, 0.0, 1.0], ["-1", "0", "1"]),
    ([2e6, 3e6, 4e6], ["2e+06", "3e+06", "4e+06"]),
])
def test_plain_ticks_write_the_fewest_decimals_that_tell_ticks_apart(
        locs, expected):
    f = plain_ticks()
    f.set_locs(locs)
    assert [f(x) for x in locs] == expected
