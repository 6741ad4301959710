"""The Watch tab's live replay in the page: ghosts that leave the solid arm seen (issue 37)."""

from __future__ import annotations

import time
from pathlib import Path

import browser as web
import mujoco
import numpy as np
from PIL import Image
from test_gui import _close_toasts, _port, _projector

import maniplab as ml
from maniplab.gui.app import Gui


def _pixels(driver, name: str, points: np.ndarray) -> np.ndarray:
    """The mean colour of a 5x5 patch at each point (x, y) of a fresh screenshot, shape (K, 3)."""
    time.sleep(1.5)  # the page draws the last update (it renders on demand)
    image = np.asarray(Image.open(web.shot(driver, name)).convert("RGB")).astype(float)
    return np.array([image[int(y) - 2:int(y) + 3, int(x) - 2:int(x) + 3].reshape(-1, 3)
                     .mean(axis=0) for x, y in points])


def _watching(driver, app: Gui, runs: dict[str, ml.Run]) -> None:
    """Store ``runs`` (name -> run) in the GUI's workspace, tick them, open the page at the
    Watch tab."""
    for name, run in runs.items():
        app.workspace.save_run(run, name)
    app.runs_changed()
    for box in app.runs.picks.values():
        box.value = True
    driver.get(app.url)
    web.text_shown(driver, "hydraulic")
    web.tab(driver, "Watch")


def test_a_ghost_over_the_solid_arm_leaves_it_seen(tmp_path: Path) -> None:
    """Issue 37, item 4: a ghost run drawn exactly over the solid one (the same run twice) is
    translucent: at the projections of the solid arm's geoms the page shows colours nearer to
    the solid arm drawn alone than to the ghost drawn alone; and the solid's geoms stand where
    MuJoCo puts them (ml.build_model + mj_forward at the run's last state): the replay's end."""
    spec = ml.builtin_spec("erector")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        run = ml.simulate(spec, inputs={"q2": ml.signals.step(0.5, t0=0.05)}, duration=0.5,
                          initial={"dP": "gravity"})
        with web.chromium(1280, 800) as driver:
            _watching(driver, app, {"solid": run, "ghost": run})
            app.watch.show()
            replay = app.watch.replay
            assert replay is not None and len(replay.arms) == 2
            solid, ghost = replay.arms
            assert ghost.tint is not None and solid.tint is None
            app.watch.time.value = app.watch.time.max  # the end of the replay
            web.wait(lambda: np.allclose(solid.view.data.qpos, run.q[-1], atol=1e-9),
                     "the replay at its end")
            web.wait(lambda: np.allclose(next(iter(app.server.get_clients().values()))
                                         .camera.position, app.server.initial_camera.position,
                                         atol=1e-6), "the page's camera at the replay's pose")
            _close_toasts(driver)
            project = _projector(driver, app)
            model = ml.build_model(spec)
            data = mujoco.MjData(model)
            data.qpos[:] = run.q[-1]
            mujoco.mj_forward(model, data)
            centres = []
            for geom, _ in solid._meshes:
                position, _ = solid.drawn_pose(geom)
                reference = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM,
                                              model.geom(geom).name)
                np.testing.assert_allclose(position, data.geom_xpos[reference], atol=1e-9)
                centres.append(position)
            points = project(np.array(centres))
            left, top, w, h, _ = project.rect
            inside = (points[:, 0] > left + 5) & (points[:, 0] < left + w - 5) & \
                (points[:, 1] > top + 5) & (points[:, 1] < top + h - 5)
            points = points[inside]
            assert len(points) >= 5, points
            both = _pixels(driver, "watch-ghost-over-solid", points)
            ghost.set_visible(False)
            alone = _pixels(driver, "watch-solid-alone", points)
            ghost.set_visible(True)
            solid.set_visible(False)
            only_ghost = _pixels(driver, "watch-ghost-alone", points)
            solid.set_visible(True)
            near_solid = np.linalg.norm(both - alone, axis=1)
            near_ghost = np.linalg.norm(both - only_ghost, axis=1)
            seen = int(np.sum(near_solid < near_ghost))
            assert seen >= 0.8 * len(points), (
                f"the solid arm seen at {seen} of {len(points)} of its geoms under the ghost "
                f"(out/gui-screenshots/watch-*.png): {near_solid.round()} {near_ghost.round()}")
    finally:
        app.close()


def test_the_smooth_player_plays_the_ticked_runs_in_the_panel(tmp_path: Path) -> None:
    """Issue 37, item 5: Watch's smooth player is the HTML replays' player framed in the panel;
    it holds the ticked runs, plays (its frame advances), and at the replay's end draws the end
    effector where MuJoCo's site is at the run's last state."""
    from maniplab.mjcf_gen import names

    spec = ml.load_spec(Path(__file__).parent / "arms" / "excavator.yaml")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        run = ml.simulate(spec, inputs={spec.joints[1].name: ml.signals.step(0.4, t0=0.05)},
                          duration=0.6, initial={"dP": "gravity"})
        with web.chromium(1280, 800) as driver:
            _watching(driver, app, {"dig": run})
            app.watch.smooth()
            frame = web.wait(lambda: driver.find_element("id", "ml-player"), "the player's frame")
            driver.switch_to.frame(frame)
            web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
            assert driver.execute_script("return maniplabPlayer.error || null") is None
            first = driver.execute_script("return maniplabPlayer.frame")
            web.wait(lambda: driver.execute_script("return maniplabPlayer.frame") != first,
                     "the player playing")
            driver.execute_script("maniplabPlayer.pause(); maniplabPlayer.seek(arguments[0])",
                                  float(run.t[-1]))
            model = ml.build_model(spec)
            data = mujoco.MjData(model)
            data.qpos[:] = run.q[-1]
            mujoco.mj_forward(model, data)
            site = data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE,
                                                    names.END_EFFECTOR)]
            np.testing.assert_allclose(driver.execute_script(
                "return maniplabPlayer.endEffector(0)"), site, atol=1e-4)
            driver.switch_to.default_content()
            web.shot(driver, "watch-smooth-player")
        assert "the smooth player holds 1 run" in str(app.watch.message.content)
    finally:
        app.close()
