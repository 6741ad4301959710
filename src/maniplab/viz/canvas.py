"""A canvas: an offscreen OpenGL context and MuJoCo's render context for one model and size."""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from maniplab.viz.gl import GLContext, RenderError, no_gl, open_context

if TYPE_CHECKING:
    from typing_extensions import Self

SHADOW_MAP = 2048
"""Shadow-map size, pixels. MuJoCo's 4096 costs a third more time on a software rasteriser and
looks the same at 1280x720."""


class Canvas:
    """Draws MuJoCo scenes of one model into ``height`` x ``width`` RGB images.

    Use as a context manager (or call :meth:`close`): it owns an OpenGL context.

    Args:
        model: the model whose materials and textures the scenes use. Its offscreen buffer is
            enlarged in place when smaller than the image.
        width: image width, pixels.
        height: image height, pixels.
        samples: multisamples per pixel (antialiasing); 0 for none.

    Raises:
        RenderError: no OpenGL backend can start, or the size is not positive.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, samples: int = 4) -> None:
        if width < 1 or height < 1:
            raise RenderError(f"image size {width}x{height} is empty; width and height must be "
                              ">= 1")
        self.width, self.height = width, height
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        model.vis.quality.shadowsize = SHADOW_MAP
        model.vis.quality.offsamples = samples
        self._gl: GLContext | None = open_context(width, height)
        try:
            self._mjr: mujoco.MjrContext | None = mujoco.MjrContext(
                model, mujoco.mjtFontScale.mjFONTSCALE_150)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        except Exception as exc:  # a backend that "started" without a usable context (glfw, no X)
            self._free_gl()
            raise no_gl(exc) from exc
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.empty((height, width, 3), dtype=np.uint8)

    def draw(self, scene: mujoco.MjvScene) -> np.ndarray:
        """Render ``scene``; returns the image, uint8, shape (height, width, 3), top row first.

        The array is reused by the next call: copy it to keep it.
        """
        if self._gl is None or self._mjr is None:
            raise RenderError("the canvas is closed")
        self._gl.make_current()
        mujoco.mjr_render(self._rect, scene, self._mjr)
        mujoco.mjr_readPixels(self._pixels, None, self._rect, self._mjr)
        return self._pixels[::-1]  # OpenGL's first row is the bottom one

    def close(self) -> None:
        """Free the render and OpenGL contexts (idempotent)."""
        if self._gl is not None and self._mjr is not None:
            with contextlib.suppress(Exception):  # at interpreter exit the display may be gone
                self._gl.make_current()
                self._mjr.free()
        self._mjr = None
        self._free_gl()

    def _free_gl(self) -> None:
        if self._gl is not None:
            with contextlib.suppress(Exception):  # as in close()
                self._gl.free()
        self._gl = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
