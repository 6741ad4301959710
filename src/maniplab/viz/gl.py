"""OpenGL contexts for offscreen rendering, and the error raised when none can start.

MuJoCo picks its OpenGL backend from ``MUJOCO_GL`` when ``mujoco`` is imported. maniplab reads the
variable again when a context is opened, so a script (or a notebook) that sets it after importing
maniplab still gets the backend it asked for. Nothing here sets the variable: the CLI's ``main()``
chooses ``egl`` when the user has not (library modules have no side effects at import).
"""

from __future__ import annotations

import os
import platform
import warnings
from importlib import import_module
from typing import Any, Protocol

from maniplab.errors import ManiplabError

BACKENDS = ("egl", "osmesa", "glfw")
"""Values of ``MUJOCO_GL`` that maniplab can render with (plus ``cgl`` on macOS)."""

_DEFAULT_ALIASES = ("", "enable", "enabled", "on", "true", "1")

_ADVICE = (
    "on a machine without a display set MUJOCO_GL=egl (Debian/Ubuntu: apt install libegl1 "
    "libgl1-mesa-dri) or MUJOCO_GL=osmesa (apt install libosmesa6), or run where a display is "
    "available (DISPLAY set) with MUJOCO_GL=glfw"
)


class RenderError(ManiplabError):
    """A video cannot be rendered or written (no OpenGL, a bad camera or size, ffmpeg failed)."""


class GLContext(Protocol):
    """What maniplab uses of MuJoCo's ``GLContext`` classes."""

    def make_current(self) -> None: ...

    def free(self) -> None: ...


def backend() -> str:
    """The OpenGL backend ``MUJOCO_GL`` names now (MuJoCo's platform default when unset).

    Raises:
        RenderError: the variable names no backend.
    """
    value = os.environ.get("MUJOCO_GL", "").strip().lower()
    if value in _DEFAULT_ALIASES:
        return "cgl" if platform.system() == "Darwin" else "glfw"
    valid = BACKENDS + (("cgl",) if platform.system() == "Darwin" else ())
    if value not in valid:
        raise RenderError(f"MUJOCO_GL={value!r} is not an OpenGL backend; expected one of "
                          f"{', '.join(valid)}")
    return value


def open_context(width: int, height: int) -> GLContext:
    """An offscreen OpenGL context of at least ``width`` x ``height`` pixels, made current.

    Raises:
        RenderError: no context can be created; the message says what to install or set.
    """
    name = backend()
    try:
        with warnings.catch_warnings():  # glfw warns before it fails; the error says it all
            warnings.simplefilter("ignore")
            module = import_module(f"mujoco.{name}")
            context: Any = module.GLContext(width, height)
            context.make_current()
    except Exception as exc:  # ImportError, OSError, GLError, RuntimeError... all mean "no GL"
        raise no_gl(exc) from exc
    return context


def no_gl(exc: BaseException) -> RenderError:
    """The error for an OpenGL backend that failed with ``exc``: what failed and what to do."""
    name = os.environ.get("MUJOCO_GL", "")
    reason = _one_line(exc)
    if backend() in ("glfw", "cgl") and not (os.environ.get("DISPLAY")
                                             or os.environ.get("WAYLAND_DISPLAY")):
        reason = "no display (DISPLAY is not set)"
    return RenderError(f"cannot start OpenGL for offscreen rendering (MUJOCO_GL={name or 'unset'}: "
                       f"{reason}); {_ADVICE}")


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."
