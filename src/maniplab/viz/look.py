"""How a video looks: camera, shadows, antialiasing, path, text, plot strip."""

from __future__ import annotations

import dataclasses

from maniplab.viz.camera import AUTO, Framing


@dataclasses.dataclass(frozen=True)
class Look:
    """The keyword arguments of :func:`~maniplab.viz.render.render` that shape the picture.

    Attributes:
        camera: "auto", a model camera's name, or a :class:`~maniplab.viz.camera.Framing`.
        shadows: draw shadows (on a software renderer about half the frame rate).
        antialias: 4x multisampling (smooth edges; on a software renderer about 2.5x the time per
            frame of drawing without it).
        trace: draw the end-effector's path.
        text: draw the time stamp and the colour keys.
        plot: "SIGNAL" or "SIGNAL:COLUMN" for a plot strip under the animation, or None.
    """

    camera: str | Framing = AUTO
    shadows: bool = False
    antialias: bool = True
    trace: bool = True
    text: bool = True
    plot: str | None = None

    @property
    def samples(self) -> int:
        """Multisamples per pixel for MuJoCo's offscreen buffer."""
        return 4 if self.antialias else 0
