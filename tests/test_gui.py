"""The GUI (maniplab gui): its parts against independent references, and the page driven in
Debian's headless chromium. Screenshots of each stage go to out/gui-screenshots/."""

from __future__ import annotations

import html
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import browser as web
import mujoco
import numpy as np
import pytest
from PIL import Image
from selenium.webdriver.common.keys import Keys

import maniplab as ml
from maniplab.gui.app import IDLE_STOP, Gui
from maniplab.gui.arm3d import Arm3D
from maniplab.gui.player import replay_html
from maniplab.gui.replay import recording_server
from maniplab.gui.simulate import headline_overrides, inputs_of, term
from maniplab.gui.workspace import Workspace, WorkspaceError

ARMS = Path(__file__).parent / "arms"
CORPUS = sorted(ARMS.glob("*.yaml"))


def _specs() -> list[ml.ManipulatorSpec]:
    return [ml.builtin_spec(n) for n in ml.builtin_specs()] + [ml.load_spec(p) for p in CORPUS]


def _saturated(png: Path, box: tuple[float, float, float, float] = (0.0, 0.2, 0.7, 0.95)) -> int:
    """Pixels of strong colour (the links' yellow, green, pink...) in the fraction ``box``
    (left, top, right, bottom) of a screenshot: the page's grey grid and white sky have none."""
    image = np.asarray(Image.open(png).convert("RGB")).astype(int)
    h, w, _ = image.shape
    part = image[int(box[1] * h):int(box[3] * h), int(box[0] * w):int(box[2] * w)]
    return int(np.count_nonzero(part.max(axis=2) - part.min(axis=2) > 80))


def _wait_idle(app: Gui, timeout: float = 120.0) -> str:
    end = time.monotonic() + timeout
    while app.jobs.busy:
        assert time.monotonic() < end, "the GUI's job did not finish"
        time.sleep(0.05)
    return str(app.status.content)


# --- parts ----------------------------------------------------------------------------------------


def test_workspace_takes_names_never_paths(tmp_path: Path) -> None:
    space = Workspace(tmp_path / "ws")
    for bad in ("../escape", "a/b", ".hidden", "", "x" * 65, "/etc/passwd", "..", "a\\b", "é"):
        with pytest.raises(WorkspaceError, match="not a valid name"):
            space.path("runs", bad, ".npz")
    run = ml.simulate("planar2", inputs={"q1": 1.0}, duration=0.05)
    assert space.save_run(run, "a") == "a"
    assert space.save_run(run, "a") == "a-2"  # never overwrites
    space.rename_run("a-2", "b")
    with pytest.raises(WorkspaceError, match="exists already"):
        space.rename_run("a", "b")
    space.delete_run("a")
    assert space.runs() == ["b"]
    assert Workspace(tmp_path / "ws").runs() == ["b"]  # a restart finds the runs again
    np.testing.assert_array_equal(space.load_run("b").q, run.q)
    assert sorted(p.name for p in (tmp_path / "ws").rglob("*") if p.is_file()) == ["b.npz"]


def test_signal_terms_are_the_closed_form_signals() -> None:
    t = np.linspace(0.0, 3.0, 301)
    cases = {
        term("step", 0.5, 0.0, 0.2): np.where(t >= 0.2, 0.5, 0.0),
        term("sine", 0.1, 2.0, 0.5): np.where(t >= 0.5, 0.1 * np.sin(2 * np.pi * 2.0 * (t - 0.5)), 0),
        term("ramp", 2.0, 1.5, 1.0): np.clip(2.0 * (t - 1.0), 0.0, 1.0),
    }
    for text, expected in cases.items():
        signal = inputs_of({"q1": text})["q1"]
        np.testing.assert_allclose([signal(x) for x in t], expected, atol=1e-12, err_msg=text)
    impulse = inputs_of({"q1": term("impulse", 0.02, 0.01, 1.0)})["q1"]
    fine = np.linspace(0.0, 2.0, 200001)
    assert np.trapezoid([impulse(x) for x in fine], fine) == pytest.approx(0.02, rel=1e-3)
    with pytest.raises(ml.ManiplabError, match="q1"):
        inputs_of({"q1": "stepp:1"})


def test_headline_parameters_become_overrides_of_the_changed_values() -> None:
    spec = ml.builtin_spec("erector")
    assert headline_overrides(spec, "all joints", spec.end_effector.mass, None, None) == {}
    got = headline_overrides(spec, "q2", 2500.0, 3e-12, 1234.0)
    assert got == {"end_effector.mass": 2500.0, "joints.q2.actuator.leakage": 3e-12,
                   "joints.q2.friction.viscous": 1234.0}
    every = headline_overrides(spec, "all joints", spec.end_effector.mass, 3e-12, None)
    assert set(every) == {f"joints.{j.name}.actuator.leakage" for j in spec.joints}


def test_a_warnings_verdict_opens_in_the_runs_list(tmp_path: Path) -> None:
    """Issue 37: a run with warnings lists its findings (each once) under its summary."""
    from maniplab.gui.runs import run_summary

    space = Workspace(tmp_path / "ws")
    run = ml.simulate("crane3", inputs={"luff": 50.0}, duration=1.0, initial={"dP": "gravity"})
    assert run.health.verdict == "warnings"
    space.save_run(run, "hard")
    shown = run_summary(space, "hard")
    assert "health warnings" in shown and "<details class='ml-health'>" in shown
    for line in run.health.lines():
        assert shown.count(html.escape(line)) == 1


@pytest.mark.parametrize("spec", _specs(), ids=lambda s: s.name)
def test_the_3d_arm_stands_where_mujoco_puts_it(spec: ml.ManipulatorSpec) -> None:
    """Each mesh sits at the geom pose that MuJoCo's full forward pass gives for the model
    ml.build_model makes, at a random pose within the limits."""
    rng = np.random.default_rng(7)
    lo = np.array([j.limits[0] if j.limits else -1.0 for j in spec.joints])
    hi = np.array([j.limits[1] if j.limits else 1.0 for j in spec.joints])
    q = rng.uniform(lo, hi)
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    with recording_server() as server:
        arm = Arm3D(server.scene, "/arm", spec)
        arm.pose(q)
        assert arm._meshes, f"{spec.name}: no geometry drawn"
        for geom, _ in arm._meshes:
            name = model.geom(geom).name
            reference = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
            position, rotation = arm.drawn_pose(geom)  # its body's frame and its place in it
            np.testing.assert_allclose(position, data.geom_xpos[reference], atol=1e-9,
                                       err_msg=f"{spec.name} {name}")
            np.testing.assert_allclose(rotation.ravel(), data.geom_xmat[reference], atol=1e-9)


def test_a_stopped_run_stores_nothing(tmp_path: Path) -> None:
    app = Gui(ml.builtin_spec("crane3"), tmp_path / "ws", port=_port())
    try:
        app.simulate.duration.value = 600.0
        app.simulate.run_open_loop()
        time.sleep(1.0)
        assert app.jobs.busy
        app.jobs.stop()
        assert "stopped, nothing stored" in _wait_idle(app)
        assert list((tmp_path / "ws" / "runs").iterdir()) == []
    finally:
        app.close()


def test_the_closed_loop_move_reports_its_verdict(tmp_path: Path) -> None:
    spec = ml.builtin_spec("crane3")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        view = app.configure.arm3d
        assert view is not None
        view.view.pose(np.array([0.3, 0.2, 0.5]))
        app.simulate.target.value = tuple(float(x) for x in view.end_effector)
        app.simulate.move_duration.value = 2.0
        app.simulate.run_move()
        assert "stored run 'run-cascade'" in _wait_idle(app)
        verdict = str(app.simulate.verdict.content)
        assert "health ok  \ntolerances met" in verdict
        # the planner stretched this move, and the verdict says so: asked and actual duration
        move = app.workspace.load_run("run-cascade").meta["move"]
        assert f"asked 2 s, ran {move['duration']:.3g} s" in verdict and move["duration"] > 2.0
        run = app.workspace.load_run("run-cascade")
        # the run ends at the target: the arm's own forward kinematics at its last q
        view.view.pose(run.q[-1])
        np.testing.assert_allclose(view.end_effector, app.simulate.target.value, atol=2e-3)
        app.simulate.target.value = (50.0, 0.0, 0.0)  # far out of reach
        app.simulate.run_move()
        assert "out of reach" in _wait_idle(app)
    finally:
        app.close()


def test_your_own_controller_is_offered_for_closed_loop_moves(tmp_path: Path) -> None:
    """Issue 41: `maniplab gui --controller MODULE:NAME` offers your controller beside the
    cascade and the PID baseline; its move is the one run_move gives with that factory."""
    from maniplab.control.cascade import CascadeController
    from maniplab.control.move import run_move

    def baseline(spec, move):
        return CascadeController(spec, move, mode="pid")

    spec = ml.builtin_spec("crane3")
    app = Gui(spec, tmp_path / "ws", port=_port(), controllers={"baseline": baseline})
    try:
        assert app.simulate.mode.options == ("cascade", "pid", "baseline")
        app.simulate.target.value = (5.46, 0.6, 1.4)
        app.simulate.move_duration.value = 3.0
        app.simulate.mode.value = "baseline"
        app.simulate.run_move()
        assert "stored run 'run-baseline'" in _wait_idle(app)
        run = app.workspace.load_run("run-baseline")
        alone = run_move(spec, [5.46, 0.6, 1.4], start=None, duration=3.0, controller=baseline)
        np.testing.assert_array_equal(run.q, alone.run.q)
    finally:
        app.close()


def test_runs_start_from_the_pose_typed(tmp_path: Path) -> None:
    """Issue 33: the GUI starts open-loop runs and moves from a pose, as simulate --start does;
    a pose of the wrong length is refused under the field, nothing run. Issue 37: the pose and
    the move's target are typed in the units chosen in Configure (deg or rad, m or mm), and a
    change of units re-expresses what is typed."""
    spec = ml.builtin_spec("patu655")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        tab, choice = app.simulate, app.configure.unit_choice
        assert tab.start.label == "Start pose q [deg]" and tab.target.label == "Target x, y, z [m]"
        tab.start.value = "20, -30, 60"
        tab.duration.value = 0.05
        tab.run_open_loop()
        assert "stored run 'run'" in _wait_idle(app)
        run = app.workspace.load_run("run")
        expected = np.radians([20.0, -30.0, 60.0])
        np.testing.assert_allclose(run.q[0], expected)
        np.testing.assert_allclose(run.q[-1], expected, atol=1e-3)  # held there
        choice["angle"].value = "rad"
        assert tab.start.label == "Start pose q [rad]"
        np.testing.assert_allclose([float(x) for x in tab.start.value.split(",")], expected,
                                   rtol=1e-5)
        target = np.array(tab.target.value) * 1000.0
        choice["length"].value = "mm"
        assert tab.target.label == "Target x, y, z [mm]"
        np.testing.assert_allclose(tab.target.value, target, atol=0.5)
        np.testing.assert_allclose(tab.gizmo.position, target / 1000.0, atol=1e-3)
        tab.start.value = "0.2, -0.4"
        tab.run_open_loop()
        assert "expected 3 finite numbers" in str(tab.input_error.content)
        assert app.workspace.runs() == ["run"]
    finally:
        app.close()


def test_gui_listens_on_localhost_and_warns_loudly_otherwise(tmp_path: Path) -> None:
    app = Gui(ml.builtin_spec("planar2"), tmp_path / "ws", port=_port())
    try:
        assert app.server.get_host() == "127.0.0.1"
    finally:
        app.close()
    command = [sys.executable, "-m", "maniplab", "gui", "planar2", "--no-browser", "--host",
               "0.0.0.0", "--port", str(_port()), "--workspace", str(tmp_path / "ws2")]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "MUJOCO_GL": "egl"})
    try:
        assert process.stderr is not None
        line = process.stderr.readline()
        assert "WARNING: listening on 0.0.0.0" in line
    finally:
        process.kill()
        process.wait()


# --- in the browser -------------------------------------------------------------------------------


def test_exported_replay_opens_offline_and_draws_the_arm(tmp_path: Path) -> None:
    spec = ml.load_spec(ARMS / "excavator.yaml")
    runs = [ml.simulate(spec, inputs={spec.joints[1].name: ml.signals.step(0.4, t0=0.1)},
                        duration=1.0, initial={"dP": "gravity"}, overrides=o)
            for o in ({}, {"end_effector.mass": spec.end_effector.mass * 2 + 100})]
    page = tmp_path / "replay.html"
    page.write_text(replay_html(runs))
    text = page.read_text().lower()
    assert "http://" not in text and "https://" not in text  # nothing fetched from elsewhere
    with web.chromium(offline=True) as driver:
        driver.get(page.as_uri())
        web.wait(lambda: driver.execute_script("return window.maniplabPlayer"), "the player")
        assert driver.execute_script("return window.maniplabPlayer.error || null") is None
        # an empty scene (grid, sky) has no strongly coloured pixel; the thin excavator about 1400
        web.wait(lambda: _saturated(web.shot(driver, "replay-offline"), (0.0, 0.2, 1.0, 0.95))
                 > 600, "the arm drawn (see out/gui-screenshots/replay-offline.png)")


def test_the_page_configures_simulates_compares_and_replays(tmp_path: Path) -> None:
    app = Gui(ml.builtin_spec("erector"), tmp_path / "ws", port=_port())
    try:
        with web.chromium() as driver:
            driver.get(app.url)
            web.text_shown(driver, "hydraulic")
            web.wait(lambda: _saturated(web.shot(driver, "1-configure")) > 600,
                     "the arm in the scene (see out/gui-screenshots/1-configure.png)")

            # edit a joint: the table and the model follow
            web.type_into(driver, "Body mass [kg]", "1800")
            web.wait(lambda: app.spec.joint("q1").body.mass == 1800.0, "the new mass")
            web.text_shown(driver, "1800")
            # a bad value: the spec's one-line error under the field, the arm unchanged
            web.type_into(driver, "Body mass [kg]", "-5")
            web.text_shown(driver, "joint q1, field 'body.mass'")
            web.shot(driver, "2-bad-value")
            assert app.spec.joint("q1").body.mass == 1800.0

            # two step responses, the second with another payload
            web.tab(driver, "Simulate")
            web.type_into(driver, "q2 [A]", "step:0.5@0.1")
            web.type_into(driver, "Duration [s]", "1")
            web.click(driver, "Run")
            web.text_shown(driver, "stored run 'run'")
            web.type_into(driver, "Payload mass [kg]", "2000")
            web.click(driver, "Run")
            web.text_shown(driver, "stored run 'run-2'")
            web.shot(driver, "3-simulate")
            assert app.workspace.runs() == ["run", "run-2"]
            assert app.workspace.load_run("run-2").spec.end_effector.mass == 2000.0

            # both in the list, overlaid
            web.tab(driver, "Runs")
            web.wait(lambda: web.visible(driver, "//label[normalize-space()='run-2']"),
                     "run-2 in the list")
            web.tick(driver, "run")
            web.tick(driver, "run-2")
            web.click(driver, "Plot selected runs")
            web.text_shown(driver, "2 run(s): q, dP")
            plot = web.wait(lambda: driver.execute_script(_PLOT), "the plot")
            web.wait(lambda: "payload=2000" in plot.text, "the legend naming the payloads")
            assert plot.size["width"] > 600
            web.shot(driver, "4-compare")

            # a second tab sees the same runs
            driver.switch_to.new_window("tab")
            driver.get(app.url)
            web.tab(driver, "Runs")
            web.wait(lambda: web.visible(driver, "//label[normalize-space()='run-2']"),
                     "run-2 in the second tab")
            driver.close()
            driver.switch_to.window(driver.window_handles[0])

            # replay, then scrub the timeline to its end
            web.tab(driver, "Watch")
            web.click(driver, "Show the ticked runs")
            web.text_shown(driver, "2 run(s)")
            assert app.watch.replay is not None
            start = [arm.end_effector for arm in app.watch.replay.arms]
            thumb = web.wait(lambda: web.visible(driver, "//*[@role='slider']"), "the timeline")
            driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", thumb)
            thumb.click()
            thumb.send_keys(Keys.END)  # the slider's keyboard scrub: to the last frame
            web.wait(lambda: app.watch.time.value >= app.watch.time.max - 0.05, "the scrub")
            end = [arm.end_effector for arm in app.watch.replay.arms]
            last = [app.workspace.load_run(n) for n in ("run", "run-2")]
            for arm, run, before, after in zip(app.watch.replay.arms, last, start, end):
                arm.view.pose(run.q[-1])  # the scrubbed pose is the run's last state
                np.testing.assert_allclose(after, arm.end_effector, atol=1e-6)
                assert np.linalg.norm(after - before) > 0.01
            time.sleep(1.0)
            web.shot(driver, "5-watch")
    finally:
        app.close()


def _port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_joints_added_moved_removed_saved_and_exported(tmp_path: Path) -> None:
    app = Gui(ml.load_spec(ARMS / "gantry.yaml"), tmp_path / "ws", port=_port())
    try:
        tab = app.configure
        names = [j.name for j in app.spec.joints]
        tab.joint.value = names[0]
        tab.add_joint()
        assert [j.name for j in app.spec.joints] == [names[0], f"{names[0]}_2", *names[1:]]
        assert app.spec.joints[1] == ml.ManipulatorSpec.from_dict(app.spec.to_dict()).joints[1]
        tab.move_joint(1)  # the copy moves one place down the chain
        assert [j.name for j in app.spec.joints][1:3] == [names[1], f"{names[0]}_2"]
        tab.remove_joint()
        assert [j.name for j in app.spec.joints] == names
        assert "<th>" + names[0] + "</th>" in str(tab.table.content)
        tab.file_name.value = "my_gantry"
        tab.save()
        saved = ml.load_spec(tmp_path / "ws" / "specs" / "my_gantry.yaml")
        assert saved.to_dict() == app.spec.to_dict()
        tab.download_mjcf()
        xml = next((tmp_path / "ws" / "exports").glob("*.xml")).read_text()
        model = mujoco.MjModel.from_xml_string(xml)
        assert model.njnt == app.spec.n
        tab.file_name.value = "../outside"
        tab.save()
        assert "not a valid name" in tab.save_note.text
        assert not (tmp_path / "outside.yaml").exists()
    finally:
        app.close()


def _button(driver: Any, text: str) -> Any:
    return web.wait(lambda: web.visible(driver, f"//button[normalize-space()='{text}']"),
                    f"the button '{text}'")


def _red(element: Any) -> bool:
    """Whether ``element``'s background is strongly red."""
    colour = element.value_of_css_property("background-color")
    r, g, b = (int(float(x)) for x in colour[colour.index("(") + 1:].split(",")[:3])
    return r > 150 and r > g + 60 and r > b + 60


def test_the_page_says_its_state_next_to_the_control(tmp_path: Path) -> None:
    """Issue 37, clear state: Stop disabled (not red) while idle and Run disabled during a job; a
    job's outcome (and a refusal) said next to its control; a move the planner stretched said
    (asked and actual duration, each sentence once) and stored in the run's metadata, expandable
    in the Runs tab, which lists each run once; switching tabs clears the messages, and leaving
    Watch takes the replay away and shows the configured arm again."""
    spec = ml.builtin_spec("erector")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        with web.chromium() as driver:
            driver.get(app.url)
            web.text_shown(driver, "hydraulic")
            idle = _button(driver, IDLE_STOP)  # in the place of Stop, disabled and grey
            assert not idle.is_enabled() and not _red(idle)
            assert not web.visible(driver, "//button[normalize-space()='Stop']")

            # a long run: Stop enabled and red, Run disabled, another job refused next to it
            web.tab(driver, "Simulate")
            app.simulate.duration.value = 600.0
            web.click(driver, "Run")
            web.wait(lambda: app.jobs.busy, "the run started")
            assert _button(driver, "Stop").is_enabled() and _red(_button(driver, "Stop"))
            assert not web.visible(driver, f"//button[normalize-space()='{IDLE_STOP}']")
            web.wait(lambda: not _button(driver, "Run").is_enabled(), "Run disabled")
            app.simulate.run_move()  # as a second page would ask
            web.text_shown(driver, "busy: another job runs")
            web.click(driver, "Stop")
            web.text_shown(driver, "stopped, nothing stored")  # next to Run
            _button(driver, IDLE_STOP)  # idle again: Stop disabled and grey
            assert not web.visible(driver, "//button[normalize-space()='Stop']")
            assert _button(driver, "Run").is_enabled() and app.workspace.runs() == []

            # a move asked faster than the valves allow: stretched, said, stored
            from maniplab.gui.configure import home
            from maniplab.viz.arm import ArmView

            view = ArmView(spec)
            lo, hi = (np.array([j.limits[k] for j in spec.joints]) for k in (0, 1))
            view.pose(home(spec) + 0.01 * (hi - lo))
            target = tuple(round(float(x), 3) for x in view.end_effector_position)
            app.simulate.target.value = target
            app.simulate.move_duration.value = 0.2
            web.click(driver, "Run move")
            web.text_shown(driver, "move stretched: asked 0.2 s, ran")
            _wait_idle(app)
            web.shot(driver, "state-1-stretched")
            verdict = str(app.simulate.verdict.content)
            sentences = [x.strip() for x in verdict.replace("  \n", ";").split(";") if x.strip()]
            assert len(sentences) == len(set(sentences)), verdict
            assert "--fit" not in verdict and "--" not in verdict.replace("\\-", "")
            run = app.workspace.load_run("run-cascade")
            move = run.meta["move"]
            assert move["asked_duration"] == 0.2 and move["stretched"]
            assert move["target"] == list(target) and move["controller"] == "cascade"
            # the stretch is real: the stored run lasts the move it reports, not the 0.2 s asked
            assert float(run.t[-1]) >= 0.5 + move["duration"] > 0.5 + 0.2 + 0.5
            assert f"{move['duration']:.3g} s" in verdict

            # Runs: each run once, its move expandable; the Simulate messages gone
            web.tab(driver, "Runs")
            web.wait(lambda: app.simulate.verdict.content == "", "Simulate's messages cleared")
            web.wait(lambda: web.visible(driver, "//label[normalize-space()='run-cascade']"),
                     "the run listed")
            named = [e for e in driver.find_elements(
                "xpath", "//*[normalize-space(.)='run-cascade' and "
                "not(*[normalize-space(.)='run-cascade'])]") if e.is_displayed()]
            assert len(named) == 1, [e.tag_name for e in named]
            summary = _wait_shown(driver, "//details[@class='ml-move']/summary")
            summary.click()
            web.text_shown(driver, "duration asked [s]")
            web.shot(driver, "state-2-runs")

            # Watch, then back to Configure: the replay gone, the configured arm shown
            web.tick(driver, "run-cascade")
            web.tab(driver, "Watch")
            web.click(driver, "Show the ticked runs")
            web.wait(lambda: app.watch.replay is not None, "the replay")
            arm = app.configure.arm3d
            assert arm is not None
            # hidden: every node of the arm that is no child of another (a body's frame, its geoms)
            web.wait(lambda: not any(n.visible for n in arm._nodes()), "the arm hidden")
            web.tab(driver, "Configure")
            web.wait(lambda: app.watch.replay is None and all(n.visible for n in arm._nodes()),
                     "the replay taken away, the arm shown")
            assert app.simulate.gizmo is not None and not app.simulate.gizmo.visible
            assert "/target/name" in app.server.scene._handle_from_node_name  # its label
            web.wait(lambda: _saturated(web.shot(driver, "state-3-back")) > 600, "the arm")
    finally:
        app.close()


def _wait_shown(driver: Any, xpath: str) -> Any:
    return web.wait(lambda: web.visible(driver, xpath), xpath)


_ROWS = """return Array.from(document.querySelectorAll('label')).filter(
    function(l) { return l.offsetParent !== null; }).map(function(l) {
    var row = l.closest('.mantine-Flex-root'); var i = row && row.querySelector('input');
    return [l.textContent.trim(), i ? i.value : null, i ? i.type : null]; });"""


def _fields_of(driver: Any, joint: str) -> list[Any] | None:
    """The page's labelled rows once they show the fields of ``joint``."""
    rows = driver.execute_script(_ROWS)
    return rows if ["Joint name", joint] in [r[:2] for r in rows] else None


def _numeric(text: str) -> bool:
    """Whether a field's text is a number or a list of numbers."""
    import yaml

    try:
        value = yaml.safe_load(text) if text.strip() else None
    except yaml.YAMLError:
        return False
    flat = value if isinstance(value, list) else [value]
    return bool(flat) and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                              for x in flat)


def test_every_number_on_the_page_carries_its_unit(tmp_path: Path) -> None:
    """Issue 37, engineering labelling: every numeric field of Configure (each joint of a lumped
    and of a pinned-cylinder arm) and of Simulate is labelled with its unit in brackets; type
    and axis are choices; the pressure shown in the unit chosen (bar) and typed back in it; an
    error names no path inside maniplab."""
    app = Gui(ml.builtin_spec("erector"), tmp_path / "ws", port=_port())
    try:
        with web.chromium() as driver:
            driver.get(app.url)
            web.text_shown(driver, "hydraulic")
            checked = 0
            for arm in ("erector", "patu655"):
                if app.spec.name != arm:
                    app.set_spec(ml.builtin_spec(arm))
                for joint in [j.name for j in app.spec.joints]:
                    app.configure.joint.value = joint  # its callback shows the joint's fields
                    rows = web.wait(lambda j=joint: _fields_of(driver, j), f"the fields of {joint}")
                    for label, value, kind in rows:
                        if kind in ("text", "number", None) and value and _numeric(value):
                            assert "[" in label and label.endswith("]"), (arm, joint, label, value)
                            checked += 1
            web.shot(driver, "units-1-configure")
            assert checked > 80
            labels = {label for label, _, _ in driver.execute_script(_ROWS)}
            assert "Valve nominal pressure drop [MPa]" in labels  # patu655's valve
            # type and axis are choices, not free text
            assert isinstance(app.configure.joint_fields[1].input, type(app.configure.joint))
            assert app.configure.joint_fields[2].options[:3] == ("x", "y", "z")
            web.tab(driver, "Simulate")
            web.text_shown(driver, "Input syntax")
            for label, value, kind in driver.execute_script(_ROWS):
                if value and _numeric(value) and kind != "checkbox":
                    assert "[" in label, label
                    checked += 1
            web.shot(driver, "units-2-simulate")

            # bar: shown and typed in bar, stored in Pa
            app.set_spec(ml.builtin_spec("erector"))
            table = str(app.configure.table.content)  # limits in deg (revolute) or m (q4)
            assert "[-200.5, 200.5] deg" in table and "[-0.25, 0.25] m" in table
            web.tab(driver, "Configure")
            app.configure.unit_choice["pressure"].value = "bar"  # its callback rebuilds
            web.wait(lambda: _fields_of(driver, "q1"), "the fields of q1")
            pa = app.spec.joint("q1").actuator.supply_pressure
            supply = web.field(driver, "Supply pressure [bar]")
            assert float(supply.get_attribute("value")) == pytest.approx(pa / 1e5)
            web.type_into(driver, "Supply pressure [bar]", "150")
            web.wait(lambda: app.spec.joint("q1").actuator.supply_pressure == pytest.approx(1.5e7),
                     "150 bar stored as 1.5e7 Pa")
            # an error names the arm's file, not where maniplab is installed
            web.type_into(driver, "Body mass [kg]", "-5")
            web.text_shown(driver, "joint q1, field 'body.mass'")
            shown_errors = " ".join(str(f.error.content) for f in app.configure.joint_fields)
            assert "erector.yaml" in shown_errors and "maniplab/assets" not in shown_errors
            web.shot(driver, "units-3-bar")
    finally:
        app.close()


_PLOT = "return document.querySelector('.js-plotly-plot')"


def _close_toasts(driver: Any) -> None:
    """Close the page's notices (headless chromium's 'software WebGL' one) before a screenshot."""
    for button in driver.find_elements(
            "xpath", "//div[contains(@class,'mantine-Notification-root')]//button"):
        driver.execute_script("arguments[0].click();", button)
    web.wait(lambda: not web.visible(driver, "//div[contains(@class,'mantine-Notification-root')]"),
             "the notices closed")


def test_the_plot_pane_is_large_interactive_and_exports(tmp_path: Path) -> None:
    """Issue 37, the plot pane: every joint of the chosen signals in its own subplot with its
    unit, legends naming the runs and the parameter that differs (never meta.steps), a drag
    zooms (the axis range changes), and the same panels export to CSV (every sample) and SVG."""
    spec = ml.builtin_spec("erector")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        made = {}
        for name, mass in (("light", 500.0), ("heavy", 3000.0)):
            made[name] = ml.simulate(spec, inputs={"q2": ml.signals.step(0.3, t0=0.05)},
                                     duration=0.3, initial={"dP": "gravity"},
                                     overrides={"end_effector.mass": mass})
            app.workspace.save_run(made[name], name)
        app.runs_changed()
        with web.chromium(1600, 1000) as driver:
            driver.get(app.url)
            web.tab(driver, "Runs")
            web.tick(driver, "light")
            web.tick(driver, "heavy")
            web.click(driver, "Plot selected runs")
            plot = web.wait(lambda: driver.execute_script(
                _PLOT + " && document.querySelector('.js-plotly-plot')._fullLayout ? "
                "document.querySelector('.js-plotly-plot') : null"), "the plot")
            web.wait(lambda: "heavy (payload=3000)" in plot.text, "the legend")
            text = plot.text
            assert "light (payload=500)" in text and "meta." not in text
            titles = [f"{j.name}: position" for j in spec.joints]
            titles += [f"{j.name}: load pressure ΔP" for j in spec.joints]
            assert all(t in text for t in titles), text  # all six joints, both signals
            assert "[deg]" in text and "[MPa]" in text and "[m]" in text  # q4 is prismatic
            assert plot.size["width"] > 700 and 400 < plot.size["height"] < 800
            _close_toasts(driver)
            web.shot(driver, "plot-1-pane")

            # a drag across the first subplot zooms its time axis
            before = driver.execute_script(_PLOT + "._fullLayout.xaxis.range.slice()")
            drag = plot.find_element("css selector", ".nsewdrag")
            from selenium.webdriver.common.action_chains import ActionChains

            w = drag.size["width"]
            ActionChains(driver).move_to_element_with_offset(drag, -w // 4, 0).click_and_hold() \
                .move_by_offset(w // 3, 5).move_by_offset(5, 0).release().perform()
            web.wait(lambda: driver.execute_script(_PLOT + "._fullLayout.xaxis.range.slice()")
                     != before, "the zoom")
            after = driver.execute_script(_PLOT + "._fullLayout.xaxis.range.slice()")
            assert before[0] <= after[0] < after[1] <= before[1]
            assert after[1] - after[0] < 0.6 * (before[1] - before[0])
            web.shot(driver, "plot-2-zoomed")

            # exports: every sample as CSV, the same panels as SVG
            web.click(driver, "CSV")
            web.text_shown(driver, "CSV written to exports/")
            csv_file = next((tmp_path / "ws" / "exports").glob("*.csv"))
            lines = csv_file.read_text().splitlines()
            assert lines[0].startswith("run,t [s],q1: position [deg]")
            assert len(lines) == 1 + len(made["light"].t) + len(made["heavy"].t)
            row = lines[1 + len(made["light"].t) + 10].split(",")  # heavy, its 11th sample
            assert row[0] == "heavy"
            np.testing.assert_allclose(float(row[3]), np.degrees(made["heavy"].q[10, 1]),
                                       rtol=1e-8, atol=1e-12)
            web.click(driver, "SVG")
            web.text_shown(driver, "SVG written to exports/")
            svg = next((tmp_path / "ws" / "exports").glob("*.svg")).read_text()
            assert "<svg" in svg and "heavy (payload=3000)" in svg
    finally:
        app.close()


def _projector(driver: Any, app: Gui) -> Any:
    """World points (m, shape (K, 3)) -> screenshot pixels (x, y), through the camera the page
    reports (its pose, OpenCV frame: x right, y down, z forward; vertical fov; aspect) and the
    canvas's place on the page."""
    camera = next(iter(app.server.get_clients().values())).camera
    rect = driver.execute_script("var r = document.querySelector('canvas')"
                                 ".getBoundingClientRect(); return [r.left, r.top, r.width, "
                                 "r.height, window.innerWidth];")
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, np.asarray(camera.wxyz, dtype=float))
    frame, eye = rotation.reshape(3, 3), np.asarray(camera.position, dtype=float)
    half = np.tan(float(camera.fov) / 2.0)

    def project(points: np.ndarray) -> np.ndarray:
        local = (np.atleast_2d(points) - eye) @ frame  # camera coordinates
        assert np.all(local[:, 2] > 0), "a point behind the camera"
        x = local[:, 0] / (local[:, 2] * half * rect[2] / rect[3])
        y = local[:, 1] / (local[:, 2] * half)
        return np.stack([rect[0] + (x + 1) / 2 * rect[2], rect[1] + (y + 1) / 2 * rect[3]], 1)

    project.rect = rect  # type: ignore[attr-defined]
    return project


def test_the_camera_frames_the_arm_and_pinned_cylinders_are_drawn(tmp_path: Path) -> None:
    """Issue 37, 3D that frames: at 1280x800 and 1920x1080 the arm's box projects inside the 3D
    view, beside the control panel (docked, not over it), and fills a good part of it; the lift
    cylinder of patu655 is drawn as a teal barrel along its pin line (its pixels there)."""
    spec = ml.builtin_spec("patu655")
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        arm = app.configure.arm3d
        assert arm is not None
        lo, hi = arm.bounds()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        # joints named at their axes: MuJoCo's joint anchors of ml.build_model at the pose shown
        from maniplab.gui.configure import home

        model = ml.build_model(spec)
        data = mujoco.MjData(model)
        data.qpos[:] = home(spec)
        mujoco.mj_forward(model, data)
        assert [label.text for label in arm.labels] == list(spec.joint_names)
        for name, label in zip(spec.joint_names, arm.labels):
            joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            np.testing.assert_allclose(label.position, data.xanchor[joint], atol=1e-9)
        key = str(app.configure.key.content)
        assert all(n in key for n in spec.joint_names) and "cylinder barrel" in key
        assert "grid cells" in key
        # the lift cylinder's pin line, from MuJoCo's tendon through its pins at the pose shown
        view = arm.view
        first = view.data.ten_wrapadr[0]
        pins = view.data.wrap_xpos.reshape(-1, 3)[first:first + view.data.ten_wrapnum[0]]
        parent, child = pins[0], pins[-1]
        direction = (child - parent) / np.linalg.norm(child - parent)
        barrel = 0.9 * spec.joint("lift").actuator.cylinder.min_length  # as drawn from the pin
        along = parent + np.outer(np.linspace(0.15, 0.75, 9) * barrel, direction)
        for width, height in ((1280, 800), (1920, 1080)):
            with web.chromium(width, height) as driver:
                driver.get(app.url)
                web.text_shown(driver, "hydraulic")
                web.wait(lambda: app.server.get_clients(), "the page connected")
                _close_toasts(driver)
                web.wait(lambda: np.allclose(next(iter(app.server.get_clients().values()))
                                             .camera.position, app.server.initial_camera.position,
                                             atol=1e-6), "the page's camera at its first pose")
                project = _projector(driver, app)
                left, top, w, h, window = project.rect
                assert left + w < window - 200  # the panel beside the view, not over it
                box = project(corners)
                assert np.all(box[:, 0] >= left) and np.all(box[:, 0] <= left + w), box
                assert np.all(box[:, 1] >= top) and np.all(box[:, 1] <= top + h), box
                span = box.max(axis=0) - box.min(axis=0)
                assert span[0] > 0.35 * w or span[1] > 0.35 * h, span
                png = web.shot(driver, f"frame-{width}x{height}")
                image = np.asarray(Image.open(png).convert("RGB")).astype(int)
                hits = 0
                for x, y in project(along):
                    patch = image[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4].reshape(-1, 3)
                    r, g, b = patch[:, 0], patch[:, 1], patch[:, 2]
                    hits += bool(np.any((g > r + 40) & (b > r + 40) & (np.abs(g - b) < 40)))
                assert hits >= 7, f"{hits} of 9 points of the lift's barrel are teal ({png})"
    finally:
        app.close()



def test_runs_are_recorded_at_the_interval_asked(tmp_path: Path) -> None:
    """Issue 37, storage: 'Record every [s]' stores the run at that interval (a tenth of the
    samples and about a tenth of the file at 0.01 s against every 1 ms step); an interval that is
    not a positive number is refused under the inputs, nothing run."""
    app = Gui(ml.builtin_spec("planar2"), tmp_path / "ws", port=_port())
    try:
        sim = app.simulate
        sim.inputs["q1"].value = "step:0.5@0.1"
        sim.duration.value = 2.0
        sim.run_open_loop()
        assert "stored run 'run'" in _wait_idle(app)
        sim.record.value = "0.01"
        sim.run_open_loop()
        assert "stored run 'run-2'" in _wait_idle(app)
        every, sparse = (app.workspace.load_run(n) for n in ("run", "run-2"))
        np.testing.assert_allclose(np.diff(sparse.t), 0.01, rtol=1e-9)
        assert len(every.t) == 2001 and len(sparse.t) == 201
        # the same motion at the shared instants, a tenth of the samples
        np.testing.assert_allclose(sparse.q, every.q[::10], atol=1e-12)
        size = {n: app.workspace.run_path(n).stat().st_size for n in ("run", "run-2")}
        assert size["run-2"] < 0.2 * size["run"], size
        sim.record.value = "-1"
        sim.run_open_loop()
        assert "not a positive interval" in str(sim.input_error.content)
        assert app.workspace.runs() == ["run", "run-2"]
    finally:
        app.close()


def test_a_replay_sends_only_what_moved() -> None:
    """Issue 37, speed: posing the arm again at the same pose sends the page nothing, and moving
    only the last joint sends only the poses downstream of it (a replay's frames are what the
    page's player spends its time on)."""
    from maniplab.gui.configure import home
    from maniplab.gui.replay import recording_server

    spec = ml.builtin_spec("patu655")
    with recording_server() as server:
        arm = Arm3D(server.scene, "/arm", spec)
        q = home(spec)
        arm.pose(q)
        recorder = server.get_scene_serializer()  # the scene as it is, then what is sent
        scene = len(recorder._messages)
        arm.pose(q)
        assert len(recorder._messages) == scene
        moved = q.copy()
        moved[-1] += 0.1  # the tilt: the tip's link and the tilt cylinder move
        arm.pose(moved)
        sent = len(recorder._messages) - scene
        arm.pose(q + 0.1)  # every joint: everything moves
        every = len(recorder._messages) - scene - sent
        assert 0 < sent < 0.7 * every, (sent, every)
        # and what was sent is where MuJoCo puts it
        model = ml.build_model(spec)
        data = mujoco.MjData(model)
        data.qpos[:] = q + 0.1
        mujoco.mj_forward(model, data)
        for geom, _ in arm._meshes:
            reference = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, model.geom(geom).name)
            np.testing.assert_allclose(arm.drawn_pose(geom)[0], data.geom_xpos[reference],
                                       atol=1e-9)


def test_an_edit_that_changes_nothing_drawn_keeps_the_3d_arm(tmp_path: Path) -> None:
    """Issue 37, speed: editing a mass or a valve poses the arm drawn again (no mesh rebuilt for
    the page); editing a length draws it anew, where MuJoCo puts the longer body."""
    app = Gui(ml.builtin_spec("patu655"), tmp_path / "ws", port=_port())
    try:
        tab = app.configure
        first = tab.arm3d
        assert first is not None
        app.set_spec(app.spec.with_overrides({"joints.lift.body.mass": 300.0,
                                              "joints.tilt.actuator.leakage": 2e-13}))
        assert tab.arm3d is first and first.view.spec.joint("lift").body.mass == 300.0
        app.set_spec(app.spec.with_overrides({"joints.lift.body.length": 3.5}))
        assert tab.arm3d is not first and tab.arm3d is not None
        model = ml.build_model(app.spec)
        data = mujoco.MjData(model)
        from maniplab.gui.configure import home

        data.qpos[:] = home(app.spec)
        mujoco.mj_forward(model, data)
        for geom, _ in tab.arm3d._meshes:
            reference = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, model.geom(geom).name)
            np.testing.assert_allclose(tab.arm3d.drawn_pose(geom)[0], data.geom_xpos[reference],
                                       atol=1e-9)
    finally:
        app.close()
