"""Line charts drawn with Pillow (matplotlib is not a dependency of imotion).

:func:`chart` draws one panel (lines, axes, ticks, legend, shaded phases);
:func:`sheet` stacks panels into one image. Used by ``tools/demo_session.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from PIL import Image, ImageDraw

COLORS = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
)
BAND_COLORS = ((236, 240, 248), (248, 242, 232))


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


def nice_ticks(lo: float, hi: float, count: int = 6) -> list[float]:
    """Round tick values covering [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, count - 1)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step) * step
    return [first + i * step for i in range(int((hi - first) / step + 1e-9) + 1)]


def _fmt(v: float) -> str:
    return f"{v:.0f}" if abs(v) >= 10 or v == round(v) else f"{v:.2g}"


def chart(panel: Panel, width: int = 900, height: int = 300) -> Image.Image:
    """One panel as an RGB image."""
    img = Image.new("RGB", (width, height), "white")
    d = ImageDraw.Draw(img)
    left, right, top, bottom = 70, width - 170, 28, height - 40
    xs = [s.t for s in panel.series if s.t.size]
    ys = [s.y[np.isfinite(s.y)] for s in panel.series]
    ys = [y for y in ys if y.size]
    if panel.x_range is not None:
        x0, x1 = panel.x_range
    elif xs:
        x0, x1 = float(min(x.min() for x in xs)), float(max(x.max() for x in xs))
    else:
        x0, x1 = 0.0, 1.0
    y0 = float(min(y.min() for y in ys)) if ys else 0.0
    y1 = float(max(y.max() for y in ys)) if ys else 1.0
    if y1 - y0 < 1e-9:
        y0, y1 = y0 - 1.0, y1 + 1.0
    pad = 0.06 * (y1 - y0)
    y0, y1 = y0 - pad, y1 + pad
    if x1 <= x0:
        x1 = x0 + 1.0

    def px(x: float) -> float:
        return left + (x - x0) / (x1 - x0) * (right - left)

    def py(y: float) -> float:
        return bottom - (y - y0) / (y1 - y0) * (bottom - top)

    for k, (label, a, b) in enumerate(panel.bands):
        a, b = max(a, x0), min(b, x1)
        if b <= a:
            continue
        d.rectangle((px(a), top, px(b), bottom), fill=BAND_COLORS[k % 2])
        d.text((px(a) + 2, top + 2 + 10 * (k % 2)), label, fill=(110, 110, 110))
    for v in nice_ticks(y0, y1):
        d.line((left, py(v), right, py(v)), fill=(225, 225, 225))
        d.text((left - 8, py(v)), _fmt(v), fill=(60, 60, 60), anchor="rm")
    for v in nice_ticks(x0, x1, 10):
        d.line((px(v), bottom, px(v), bottom + 4), fill=(60, 60, 60))
        d.text((px(v), bottom + 6), _fmt(v), fill=(60, 60, 60), anchor="mt")
    d.rectangle((left, top, right, bottom), outline=(60, 60, 60))
    for k, s in enumerate(panel.series):
        color = COLORS[k % len(COLORS)]
        run: list[tuple[float, float]] = []
        for x, y in zip(s.t, s.y, strict=True):
            if math.isfinite(y) and x0 <= x <= x1:
                run.append((px(float(x)), py(float(y))))
                continue
            if len(run) > 1:
                d.line(run, fill=color, width=2)
            run = []
        if len(run) > 1:
            d.line(run, fill=color, width=2)
        ly = top + 4 + 14 * k
        d.line((right + 12, ly + 6, right + 32, ly + 6), fill=color, width=3)
        d.text((right + 38, ly), s.label, fill=(30, 30, 30))
    d.text((left, 8), panel.title, fill=(0, 0, 0))
    d.text((left - 60, top - 24), panel.y_label, fill=(60, 60, 60))
    d.text(((left + right) / 2, height - 14), panel.x_label, fill=(60, 60, 60), anchor="mm")
    return img


def sheet(panels: Sequence[Panel], width: int = 900, height: int = 300) -> Image.Image:
    """Panels stacked vertically."""
    images = [chart(p, width, height) for p in panels]
    out = Image.new("RGB", (width, height * len(images)), "white")
    for k, im in enumerate(images):
        out.paste(im, (0, k * height))
    return out
