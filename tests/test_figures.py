"""Figures read as they are drawn: nothing clipped by a plain savefig."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import control_ncs as ncs  # noqa: E402
from control_ncs.demo import levitation_stage  # noqa: E402


def test_schedule_plot_keeps_its_labels_inside_the_figure():
    cplt = ncs.schedule_plot(levitation_stage(), 8)
    fig, ax = cplt.figure, cplt.axes[0, 0]
    fig.canvas.draw()
    box = fig.bbox
    renderer = fig.canvas.get_renderer()
    for label in ax.get_yticklabels() + [ax.title, ax.xaxis.label]:
        ext = label.get_window_extent(renderer)
        assert ext.x0 >= box.x0 - 0.5 and ext.x1 <= box.x1 + 0.5, \
            label.get_text()
        assert ext.y0 >= box.y0 - 0.5 and ext.y1 <= box.y1 + 0.5, \
            label.get_text()
    plt.close(fig)
