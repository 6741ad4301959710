"""The exported HTML replay's own WebGL player (maniplab.gui.player) in Debian's headless chromium:
what it draws against MuJoCo's forward kinematics of the run at the time shown, computed here
independently (``ml.build_model``, ``mj_forward``); screenshots go to out/gui-screenshots/."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import browser as web
import mujoco
import numpy as np
import pytest
from PIL import Image
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

import maniplab as ml
from maniplab.gui.player import replay_html
from maniplab.mjcf_gen import names
from maniplab.sim.run import Run
from maniplab.viz import palette
from maniplab.viz.cylinders import BARREL

ARMS = Path(__file__).parent / "arms"


@pytest.fixture(scope="module")
def driver() -> Iterator[Any]:
    with web.chromium(offline=True) as browser:
        yield browser


def _runs(spec: ml.ManipulatorSpec, masses: tuple[float, ...] = (0.0,),
          joint: int = 1) -> list[Run]:
    """Runs of 1 s: a step of the valve of joint ``joint``, one run per extra payload, kg."""
    name = spec.joints[joint].name
    return [ml.simulate(spec, inputs={name: ml.signals.step(0.5, t0=0.1)}, duration=1.0,
                        initial={"dP": "gravity"},
                        overrides={"end_effector.mass": spec.end_effector.mass + m})
            for m in masses]


def _open(driver: Any, page: Path, runs: list[Run]) -> None:
    page.write_text(replay_html(runs))
    driver.get(page.as_uri())
    web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
    error = driver.execute_script("return window.maniplabPlayer.error || null")
    assert error is None, error
    driver.execute_script("maniplabPlayer.pause()")


def _seek(driver: Any, t: float, shot: str) -> np.ndarray:
    """Show time ``t`` (s); the screenshot as an (H, W, 3) int array."""
    driver.execute_script("maniplabPlayer.seek(arguments[0])", t)
    return np.asarray(Image.open(web.shot(driver, shot)).convert("RGB")).astype(int)


def _mujoco(spec: ml.ManipulatorSpec, run: Run, t: float) -> tuple[Any, Any]:
    """MuJoCo's own model and data of ``spec`` at the run's joint positions at time ``t``."""
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    q = np.asarray(run.q, dtype=float)
    data.qpos[:spec.n] = [np.interp(t, run.t, q[:, j]) for j in range(spec.n)]
    mujoco.mj_forward(model, data)
    return model, data


def _project(driver: Any, point: np.ndarray) -> tuple[int, int]:
    x, y = driver.execute_script("return maniplabPlayer.project(arguments[0])",
                                 [float(c) for c in point])
    return round(float(x)), round(float(y))


def _shows(image: np.ndarray, at: tuple[int, int], rgb: tuple[float, ...], reach: int = 3,
           tolerance: float = 0.03) -> bool:
    """Whether a pixel within ``reach`` px of ``at`` has the chromaticity of ``rgb`` (lit or in
    shade: the player scales a colour by its light, so r:g:b is kept) and is not dark."""
    x, y = at
    patch = image[max(y - reach, 0):y + reach + 1, max(x - reach, 0):x + reach + 1].reshape(-1, 3)
    want = np.asarray(rgb[:3]) / sum(rgb[:3])
    bright = patch.sum(axis=1) > 120
    chroma = patch / np.maximum(patch.sum(axis=1, keepdims=True), 1)
    return bool(np.any(bright & (np.abs(chroma - want).max(axis=1) < tolerance)))


def _links(spec: ml.ManipulatorSpec, model: Any) -> list[tuple[int, int]]:
    """(joint index, geom id) of each drawn link."""
    found = []
    for j, joint in enumerate(spec.joints):
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, names.link_geom_name(joint.name))
        if geom >= 0:
            found.append((j, geom))
    return found


def test_the_replay_opens_offline_draws_the_arm_and_names_the_joint_hovered(
        driver: Any, tmp_path: Path) -> None:
    spec = ml.builtin_spec("patu655")
    runs = _runs(spec)
    _open(driver, tmp_path / "replay.html", runs)
    assert "http://" not in (tmp_path / "replay.html").read_text().lower()
    image = _seek(driver, 0.5, "player-patu655")
    model, data = _mujoco(spec, runs[0], 0.5)
    links = _links(spec, model)
    assert len(links) == 3
    for j, geom in links:
        at = _project(driver, data.geom_xpos[geom])
        assert _shows(image, at, palette.link_colour(j)), (spec.joints[j].name, at)
    j, geom = links[1]
    x, y = _project(driver, data.geom_xpos[geom])
    ActionChains(driver).move_to_element_with_offset(
        driver.find_element(By.TAG_NAME, "body"), 0, 0).perform()
    body = driver.find_element(By.TAG_NAME, "body").rect
    ActionChains(driver).move_by_offset(int(x - body["width"] / 2),
                                        int(y - body["height"] / 2)).perform()
    tip = driver.find_element(By.ID, "ml-tip")
    web.wait(lambda: tip.is_displayed() and tip.text == spec.joints[j].name,
             f"the name '{spec.joints[j].name}' on hover")
    key = driver.find_element(By.ID, "ml-key").text
    assert "patu655" in key and "stiction" in key and "limit" in key


def test_seeking_shows_the_pose_of_that_time(driver: Any, tmp_path: Path) -> None:
    """At two times the last link is drawn where MuJoCo puts it, and the page's end-effector
    path point is MuJoCo's end-effector site."""
    spec = ml.builtin_spec("patu655")
    runs = _runs(spec)
    _open(driver, tmp_path / "replay.html", runs)
    places = []
    for t in (0.1, 1.0):
        image = _seek(driver, t, f"player-seek-{t:g}")
        assert driver.execute_script("return maniplabPlayer.time") == pytest.approx(t, abs=1e-9)
        model, data = _mujoco(spec, runs[0], t)
        j, geom = _links(spec, model)[-1]
        at = _project(driver, data.geom_xpos[geom] * 0.7 + data.xpos[model.geom_bodyid[geom]] * 0.3)
        assert _shows(image, at, palette.link_colour(j)), (t, at)
        site = data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE,
                                                names.END_EFFECTOR)]
        drawn = driver.execute_script("return maniplabPlayer.endEffector(0)")
        np.testing.assert_allclose(drawn, site, atol=1e-4)
        places.append(np.array(_project(driver, site)))
    assert np.linalg.norm(places[1] - places[0]) > 20  # the step moved the arm visibly


def test_playing_advances_the_frames_and_space_pauses(driver: Any, tmp_path: Path) -> None:
    spec = ml.builtin_spec("patu655")
    _open(driver, tmp_path / "replay.html", _runs(spec))
    driver.execute_script("maniplabPlayer.seek(0.0)")
    assert driver.execute_script("return maniplabPlayer.frame") == 0
    driver.find_element(By.ID, "ml-play").click()
    assert driver.execute_script("return maniplabPlayer.playing")
    first = web.wait(lambda: driver.execute_script("return maniplabPlayer.frame"), "a frame > 0")
    web.wait(lambda: driver.execute_script("return maniplabPlayer.frame") != first,
             "the next frames")
    slider = driver.find_element(By.ID, "ml-slider")
    assert int(slider.get_attribute("value")) > 0
    driver.find_element(By.TAG_NAME, "body").send_keys(Keys.SPACE)
    web.wait(lambda: not driver.execute_script("return maniplabPlayer.playing"), "the pause")
    assert driver.find_element(By.ID, "ml-play").text == "Play"
    speeds = [o.get_attribute("value") for o in driver.find_elements(By.CSS_SELECTOR,
                                                                       "#ml-speed option")]
    assert speeds == ["0.1", "0.25", "0.5", "1", "2", "4"]


def test_a_pinned_cylinder_is_drawn_along_its_pins(driver: Any, tmp_path: Path) -> None:
    spec = ml.builtin_spec("patu655")
    runs = _runs(spec)
    _open(driver, tmp_path / "replay.html", runs)
    image = _seek(driver, 0.5, "player-cylinders")
    model, data = _mujoco(spec, runs[0], 0.5)
    assert model.ntendon == 2
    seen = []
    for k in range(model.ntendon):  # the barrel: from the parent pin, about half the pin line
        first, count = data.ten_wrapadr[k], data.ten_wrapnum[k]
        pins = data.wrap_xpos.reshape(-1, 3)[first:first + count][[0, count - 1]]
        along = [pins[0] + f * (pins[1] - pins[0]) for f in np.linspace(0.05, 0.45, 9)]
        seen.append([_shows(image, _project(driver, p), BARREL, reach=2) for p in along])
    # the lift cylinder faces the camera; the tilt cylinder is mostly behind the boom
    assert sum(seen[0]) >= 5 and any(seen[1]), seen


def test_a_ghost_is_translucent_over_the_solid_arm(driver: Any, tmp_path: Path) -> None:
    """The same run twice: the ghost lies exactly on the solid arm, which stays visible through
    it: each link's pixel is 65 % its solid colour and 35 % the ghost's, in the same light."""
    spec = ml.builtin_spec("patu655")
    runs = _runs(spec)
    _open(driver, tmp_path / "one.html", runs)
    alone = _seek(driver, 0.5, "player-solid")
    model, data = _mujoco(spec, runs[0], 0.5)
    places = [(j, _project(driver, data.geom_xpos[g])) for j, g in _links(spec, model)]
    _open(driver, tmp_path / "two.html", [runs[0], runs[0]])
    both = _seek(driver, 0.5, "player-ghost")
    ghost = np.asarray(palette.run_colour(1)[:3])
    for j, (x, y) in places:
        solid = alone[y, x]
        light = solid.sum() / (255 * sum(palette.link_colour(j)[:3]))
        want = (1 - palette.GHOST_ALPHA) * solid + palette.GHOST_ALPHA * 255 * light * ghost
        np.testing.assert_allclose(both[y, x], want, atol=14, err_msg=spec.joints[j].name)
        assert both[y, x][0] > 0.5 * solid[0]  # the solid yellow/pink shows through


@pytest.mark.parametrize("arm", ["grapple_crane.yaml", "loader_crane.yaml"])
def test_arms_nobody_tuned_the_player_for(driver: Any, tmp_path: Path, arm: str) -> None:
    """Corpus arms (the grapple crane's passive joints swing): the links MuJoCo places in view are
    drawn there, in their colours, with a ghost of a heavier payload."""
    spec = ml.load_spec(ARMS / arm)
    runs = _runs(spec, (0.0, 200.0))
    _open(driver, tmp_path / "replay.html", runs)
    image = _seek(driver, 0.8, f"player-{arm.removesuffix('.yaml')}")
    model, data = _mujoco(spec, runs[0], 0.8)
    links = _links(spec, model)
    shown = [_shows(image, _project(driver, data.geom_xpos[g]), palette.link_colour(j), reach=4,
                    tolerance=0.05) for j, g in links]
    assert sum(shown) >= max(2, len(links) // 2), shown
    site = data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, names.END_EFFECTOR)]
    np.testing.assert_allclose(driver.execute_script("return maniplabPlayer.endEffector(0)"),
                               site, atol=1e-4)


def test_dragging_orbits_and_the_wheel_zooms(driver: Any, tmp_path: Path) -> None:
    """A drag turns the camera about its target; scrolling towards the page brings it closer (two
    world points drawn farther apart)."""
    spec = ml.builtin_spec("patu655")
    _open(driver, tmp_path / "replay.html", _runs(spec))
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])

    def apart() -> float:
        a, b = (np.array(_project(driver, p)) for p in points)
        return float(np.linalg.norm(a - b))

    canvas = driver.find_element(By.ID, "ml-view")
    before = _project(driver, points[1])
    ActionChains(driver).move_to_element(canvas).click_and_hold().move_by_offset(120, 40) \
        .release().perform()
    moved = _project(driver, points[1])
    assert np.linalg.norm(np.subtract(moved, before)) > 20
    span = apart()
    ActionChains(driver).scroll_from_origin(
        ScrollOrigin.from_element(canvas), 0, -300).perform()
    web.wait(lambda: apart() > 1.2 * span, "the view zoomed in")


def test_a_run_named_with_markup_is_shown_as_text(driver: Any, tmp_path: Path) -> None:
    """A run's name that closes the script and opens another is data in the page: the key
    shows the name as it is, and no script of it runs."""
    spec = ml.load_spec(ARMS / "excavator.yaml")
    name = "<!--<script></script><script>window.pwned=1</script>"
    run = ml.simulate(spec, duration=0.05, label=name)
    page = tmp_path / "named.html"
    page.write_text(replay_html([run], names=[name]))
    assert "window.pwned=1</script>" not in page.read_text()
    driver.get(page.as_uri())
    web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
    assert driver.execute_script("return window.pwned || null") is None
    key = driver.find_element("id", "ml-key").text
    assert name in key


def test_the_player_draws_again_after_the_gpu_takes_its_context_away(
        driver: Any, tmp_path: Path) -> None:
    """A lost WebGL context (a GPU reset) is asked back, and once restored the page starts again
    and draws the arm where MuJoCo puts it."""
    spec = ml.builtin_spec("patu655")
    runs = _runs(spec)
    _open(driver, tmp_path / "replay.html", runs)
    driver.execute_script("""
        const gl = document.getElementById('ml-view').getContext('webgl');
        window.mlLoser = gl.getExtension('WEBGL_lose_context');
        window.mlLoser.loseContext();""")
    web.wait(lambda: driver.execute_script(
        "return document.getElementById('ml-view').getContext('webgl').isContextLost()"),
        "the context lost")
    driver.execute_script("window.mlLoser.restoreContext()")
    web.wait(lambda: driver.execute_script("return window.mlLoser === undefined"),
             "the page started again")
    web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player again")
    driver.execute_script("maniplabPlayer.pause()")
    image = _seek(driver, 0.5, "player-restored")
    model, data = _mujoco(spec, runs[0], 0.5)
    j, geom = _links(spec, model)[0]
    assert _shows(image, _project(driver, data.geom_xpos[geom]), palette.link_colour(j))
