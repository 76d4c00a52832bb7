"""Line charts for ``tools/demo_session.py``, drawn with matplotlib (extra ``plot``).

:class:`Panel` is one chart (lines, shaded phases); :func:`save_sheet` stacks panels into
one PNG.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
from matplotlib import pyplot as plt

BAND_COLORS = ("#eceff8", "#f8f2e8")


@dataclass
class Series:
    label: str
    t: np.ndarray  #: x values
    y: np.ndarray  #: y values (NaN breaks the line)


@dataclass
class Panel:
    title: str
    y_label: str
    series: list[Series]
    x_label: str = "time [s]"
    #: Shaded x ranges with a label: (label, start, end).
    bands: list[tuple[str, float, float]] = field(default_factory=list)
    x_range: tuple[float, float] | None = None


def save_sheet(panels: Sequence[Panel], path: Path, width: float = 11.0) -> None:
    """Panels stacked vertically, written as a PNG to ``path``."""
    fig, axes = plt.subplots(len(panels), 1, figsize=(width, 3.2 * len(panels)), squeeze=False)
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        for k, (label, a, b) in enumerate(panel.bands):
            ax.axvspan(a, b, color=BAND_COLORS[k % 2], zorder=0)
            ax.text(a, 1.0, f" {label}", transform=ax.get_xaxis_transform(), va="top",
                    fontsize=7, color="#666666")  # fmt: skip
        for s in panel.series:
            ax.plot(s.t, s.y, label=s.label, lw=1.4)
        if panel.x_range is not None:
            ax.set_xlim(*panel.x_range)
        ax.set_title(panel.title, fontsize=10, loc="left")
        ax.set_ylabel(panel.y_label)
        ax.set_xlabel(panel.x_label)
        ax.grid(True, color="#e0e0e0", lw=0.6)
        if panel.series:
            ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
