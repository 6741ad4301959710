"""A live plot strip: one signal over the whole run, drawn under the animation with a moving cursor.

The strip is drawn twice when the video starts, once with dimmed curves and once with bright ones;
each frame copies the bright part left of the cursor and the dim part right of it, then the cursor
line. That costs a copy of the strip per frame, where drawing it (with matplotlib or Pillow) would
cost milliseconds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from maniplab.sim.run import Run
from maniplab.viz import palette
from maniplab.viz.gl import RenderError
from maniplab.viz.overlay_text import font, font_size
from maniplab.viz.units import display

_DIM = 0.3  # weight of a curve's colour in its dimmed version (the rest is background)
_AXES = {"x": 0, "y": 1, "z": 2}


@dataclasses.dataclass(frozen=True, eq=False)
class Curve:
    """One line of the strip.

    Attributes:
        t: sample times, s, shape (N,).
        y: values, shape (N,) (NaN leaves a gap).
        colour: RGBA.
        label: legend text ("" for none).
    """

    t: np.ndarray
    y: np.ndarray
    colour: palette.RGBA
    label: str = ""


def select(runs: Sequence[Run], selector: str) -> tuple[list[Curve], str]:
    """Curves of ``selector`` ("SIGNAL" or "SIGNAL:COLUMN") for ``runs``, and the strip's title.

    COLUMN is a joint name, a 0-based index, or x, y, z for ``ee_pos``. Without it every column is
    drawn. One run gets a colour per column; several runs get a colour per run
    (:func:`palette.run_colour`). Values are in the unit the figures use
    (:mod:`maniplab.viz.units`: ΔP in MPa, flows in L/min, forces in kN).

    Raises:
        RenderError: a run lacks the signal, or the column is unknown.
    """
    name, _, column = selector.partition(":")
    curves = []
    for k, run in enumerate(runs):
        if name not in run:
            raise RenderError(f"cannot plot '{name}': run '{run.label}' has no such signal; it has "
                              f"{', '.join(run)}")
        values = np.asarray(run[name], dtype=float).reshape(len(run.t), -1)
        labels = _column_labels(run, values.shape[1], name)
        chosen = range(values.shape[1]) if not column else [_column(column, labels, name)]
        _, scale, _ = display(name, None)
        for c in chosen:
            colour = palette.link_colour(c) if len(runs) == 1 else palette.run_colour(k)
            label = labels[c] if len(runs) == 1 and len(chosen) > 1 else ""
            curves.append(Curve(np.asarray(run.t, dtype=float), values[:, c] * scale, colour,
                                label))
    unit = _unit(runs[0], name, column)
    title = f"{name}:{column}" if column else name
    return curves, f"{title} [{unit}]" if unit else title


def _column_labels(run: Run, count: int, name: str) -> list[str]:
    if name == "ee_pos" and count == 3:
        return list(_AXES)
    if count == run.spec.n:
        return list(run.spec.joint_names)
    return [str(i) for i in range(count)]


def _column(column: str, labels: list[str], name: str) -> int:
    if column in labels:
        return labels.index(column)
    if column.isdigit() and int(column) < len(labels):
        return int(column)
    raise RenderError(f"unknown column '{column}' of signal '{name}'; expected one of "
                      f"{', '.join(labels)} or an index below {len(labels)}")


def _unit(run: Run, name: str, column: str) -> str:
    """The shown unit: of the chosen joint, or of all of them."""
    if column in run.spec.joint_names:
        return display(name, run.spec.joint(column).prismatic)[2]
    kinds = {joint.prismatic for joint in run.spec.joints}
    return display(name, kinds.pop() if len(kinds) == 1 else None)[2]


class PlotStrip:
    """The strip for ``curves`` over ``t0``..``t1`` s, ``width`` x ``height`` pixels.

    Args:
        curves: the lines.
        title: shown at the top left (signal and unit).
        width: pixels.
        height: pixels.
        t0: time at the left edge of the plot area, s.
        t1: time at its right edge, s.
    """

    def __init__(self, curves: Sequence[Curve], title: str, width: int, height: int,
                 t0: float, t1: float) -> None:
        self.width, self.height, self.t0, self.t1 = width, height, t0, t1
        size = font_size(3 * height)
        low, high = _limits(curves)
        widest = max(font(_small(size)).getlength(f"{v:.3g}") for v in (low, high))
        self.left = max(round(4.5 * size), round(widest) + 8)  # room for a label's minus sign
        self.right = max(4, width // 100)
        self.top, self.bottom = round(1.6 * size), max(3, height // 12)
        self.dim = self._draw(curves, title, low, high, size, _DIM)
        self.bright = self._draw(curves, title, low, high, size, 1.0)

    def _x(self, t: np.ndarray | float) -> np.ndarray:
        span = max(self.t1 - self.t0, 1e-12)
        plot_width = self.width - self.left - self.right - 1
        return self.left + (np.asarray(t) - self.t0) / span * plot_width

    def _draw(self, curves: Sequence[Curve], title: str, low: float, high: float, size: int,
              weight: float) -> np.ndarray:
        from PIL import Image, ImageDraw

        background = palette.to_uint8(palette.BACKGROUND)
        image = Image.new("RGB", (self.width, self.height), background)
        draw = ImageDraw.Draw(image)
        face, small = font(size), font(_small(size))
        y0, y1 = self.top, self.height - self.bottom
        grid = tuple(min(255, c + 28) for c in background)
        draw.line((self.left, y0, self.left, y1), fill=grid)
        draw.line((self.left, y1, self.width - self.right, y1), fill=grid)
        if low < 0 < high:
            zero = y1 - (0 - low) / (high - low) * (y1 - y0)
            draw.line((self.left, zero, self.width - self.right, zero), fill=grid)
        text = palette.to_uint8(palette.TEXT)
        draw.text((self.left, 0), title, font=face, fill=text)
        for value, y in ((high, y0), (low, y1)):
            label = f"{value:.3g}"
            bottom = small.getbbox(label)[3]  # the label stays inside the strip
            top = min(max(round(y - size / 2), 0), self.height - bottom - 1)
            draw.text((self.left - 4 - small.getlength(label), top), label, font=small, fill=text)
        line = max(1, round(self.height / 70))
        for curve in curves:
            colour = tuple(round(weight * c + (1 - weight) * b)
                           for c, b in zip(palette.to_uint8(curve.colour), background))
            ys = y1 - (curve.y - low) / (high - low) * (y1 - y0)
            for segment in _finite_runs(self._x(curve.t), ys):
                draw.line(segment, fill=colour, width=line, joint="curve")
        labelled = [c for c in curves if c.label]
        x = self.width - self.right - sum(small.getlength(c.label) + size for c in labelled)
        for curve in labelled:  # the legend, in full colour in both versions
            draw.text((x, 0), curve.label, font=small, fill=palette.to_uint8(curve.colour))
            x += small.getlength(curve.label) + size
        return np.asarray(image)

    def draw(self, out: np.ndarray, t: float) -> None:
        """Draw the strip at time ``t`` (s) into ``out`` (uint8, shape (height, width, 3))."""
        x = int(np.clip(round(float(self._x(t))), 0, self.width - 1))
        out[:, :x] = self.bright[:, :x]
        out[:, x:] = self.dim[:, x:]
        out[self.top:self.height - self.bottom, x] = palette.to_uint8(palette.TEXT)


def _small(size: int) -> int:
    """The font size of the axis labels and the legend, for a title of ``size``."""
    return max(8, round(0.85 * size))


def _limits(curves: Sequence[Curve]) -> tuple[float, float]:
    finite = [c.y[np.isfinite(c.y)] for c in curves]
    values = np.concatenate(finite) if finite else np.zeros(0)
    if values.size == 0:
        return -1.0, 1.0
    low, high = float(values.min()), float(values.max())
    pad = 0.06 * (high - low) if high > low else max(abs(high), 1.0) * 0.1
    return low - pad, high + pad


def _finite_runs(x: np.ndarray, y: np.ndarray) -> list[list[tuple[float, float]]]:
    """Polylines of ``(x, y)`` split where y is NaN; single points are dropped."""
    ok = np.isfinite(y)
    segments, current = [], []
    for xi, yi, good in zip(x.tolist(), y.tolist(), ok.tolist()):
        if good:
            current.append((xi, yi))
        elif current:
            segments.append(current)
            current = []
    segments.append(current)
    return [s for s in segments if len(s) > 1]
