"""Text on frames (time stamp, captions, legends), drawn with Pillow in the bundled DejaVu Sans.

Text is drawn once into small RGBA patches that are alpha-blended onto each frame: blending a patch
costs microseconds, drawing the whole frame through Pillow would cost milliseconds.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from maniplab.viz import palette

if TYPE_CHECKING:
    from PIL.ImageFont import FreeTypeFont

# matplotlib and Pillow are imported when text is first drawn: they would add 150 ms to every
# ``import maniplab`` (and every CLI command).

_PAD = 0.35  # padding around text, in font sizes


def font_size(height: int) -> int:
    """Font size in pixels for annotations on an image (or tile) ``height`` pixels high."""
    return max(9, round(height / 34))


@functools.lru_cache(maxsize=16)
def font(size: int) -> FreeTypeFont:
    """DejaVu Sans (shipped with matplotlib, so text looks the same everywhere) at ``size`` px."""
    from matplotlib import font_manager
    from PIL import ImageFont

    path = font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans"))
    return ImageFont.truetype(path, size)


def text_patch(text: str, size: int, colour: palette.RGBA = palette.TEXT,
               background: palette.RGBA = palette.PANEL, swatch: palette.RGBA | None = None,
               width: int | None = None) -> np.ndarray:
    """``text`` on a padded panel, optionally after a colour swatch; RGBA uint8, shape (h, w, 4).

    Args:
        text: one line.
        size: font size, pixels.
        colour: text colour.
        background: panel colour (its alpha makes the panel translucent).
        swatch: a square of this colour before the text (legends).
        width: cut the text with an ellipsis so the patch is at most this wide, pixels.
    """
    from PIL import Image, ImageDraw

    face, pad = font(size), max(2, round(_PAD * size))
    lead = size + pad if swatch is not None else 0
    if width is not None:
        text = _fit(text, face, width - 2 * pad - lead)
    right = int(face.getbbox(text or " ")[2])  # whole pixels (Pillow types the box as floats)
    ascent, descent = face.getmetrics()
    patch = Image.new("RGBA", (lead + right + 2 * pad, ascent + descent + 2 * pad),
                      _rgba8(background))
    draw = ImageDraw.Draw(patch)
    if swatch is not None:
        y0 = pad + (ascent + descent - size) // 2
        draw.rectangle((pad, y0, pad + size - 1, y0 + size - 1), fill=_rgba8(swatch))
    draw.text((pad + lead, pad), text, font=face, fill=_rgba8(colour))
    return np.asarray(patch)


def _fit(text: str, face: FreeTypeFont, width: int) -> str:
    if face.getlength(text) <= width:
        return text
    while text and face.getlength(text + "…") > width:
        text = text[:-1]
    return text + "…"


def _rgba8(colour: palette.RGBA) -> tuple[int, int, int, int]:
    r, g, b, a = (round(255 * c) for c in colour)
    return r, g, b, a


def blend(frame: np.ndarray, patch: np.ndarray, x: int, y: int) -> None:
    """Alpha-blend ``patch`` (RGBA, shape (h, w, 4)) onto ``frame`` (RGB, shape (H, W, 3)) in place,
    with its top-left corner at column ``x``, row ``y`` (negative: from the right or bottom edge);
    the part outside the frame is dropped."""
    height, width = frame.shape[:2]
    h, w = patch.shape[:2]
    x = width + x - w if x < 0 else x
    y = height + y - h if y < 0 else y
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, width), min(y + h, height)
    if x0 >= x1 or y0 >= y1:
        return
    part = patch[y0 - y:y1 - y, x0 - x:x1 - x]
    alpha = part[..., 3:4].astype(np.uint32)
    region = frame[y0:y1, x0:x1]
    region[:] = ((part[..., :3] * alpha + region * (255 - alpha) + 127) // 255).astype(np.uint8)


def stamp(t: float, size: int) -> np.ndarray:
    """The time stamp patch, "t = 1.23 s"."""
    return text_patch(f"t = {t:.2f} s", size)
