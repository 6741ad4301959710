"""The GUI server against a hostile page (issue 40): what a page sends is checked on the server,
only the GUI's own page with its token connects, no text becomes markup, and a flood of messages
neither stalls the GUI nor eats the memory. Most tests speak viser's protocol from a raw websocket
client (:class:`Page`), as a hostile page would; the escaping is checked in headless chromium."""

from __future__ import annotations

import math
import resource
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import browser as web
import msgspec
import pytest
import viser
import zstandard
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Subprotocol

import maniplab as ml
from maniplab.gui.app import Gui
from maniplab.gui.configure import _safe
from maniplab.gui.guard import MAX_UPLOAD
from maniplab.gui.workspace import Workspace

XSS = '<iframe srcdoc="<script>parent.xss=1</script>">'


class Page:
    """A raw websocket client of the GUI speaking viser's protocol; it records the kinds and the
    messages the server sends it."""

    def __init__(self, app: Gui, *, token: bool = True, origin: str | None = None,
                 headers: dict[str, str] | None = None) -> None:
        query = f"?token={app.token}" if token else ""
        self.ws = connect(f"ws://127.0.0.1:{app.server.get_port()}/{query}",
                          subprotocols=[Subprotocol(f"viser-v{viser.__version__}")],
                          origin=origin, additional_headers=headers, max_size=None,  # type: ignore[arg-type]
                          open_timeout=10)
        self.received: list[dict[str, Any]] = []
        threading.Thread(target=self._read, daemon=True).start()
        before = set(app.server.get_clients())
        self.send("ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0), position=(3.0, 3.0, 3.0),
                  fov=1.0, near=0.01, far=100.0, image_height=600, image_width=800,
                  look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0))
        _until(lambda: set(app.server.get_clients()) - before, "the client registered")

    def send(self, kind: str, **fields: Any) -> None:
        self.ws.send(msgspec.msgpack.encode({"type": kind, **fields}))

    def set(self, handle: Any, value: Any, **more: Any) -> None:
        """Send a widget's new value (and ``more`` attributes, as a hostile page could)."""
        self.send("GuiUpdateMessage", uuid=handle._impl.uuid, updates={"value": value, **more})

    def kinds(self) -> list[str]:
        return [m.get("type", "") for m in list(self.received)]

    def close(self) -> None:
        self.ws.close()

    def _read(self) -> None:
        unzip = zstandard.ZstdDecompressor()
        try:
            for frame in self.ws:
                assert isinstance(frame, bytes)
                size, packed = (int.from_bytes(frame[k:k + 8], "little") for k in (0, 8))
                batch = msgspec.msgpack.decode(unzip.decompress(frame[16:16 + packed],
                                                                max_output_size=size))
                self.received.extend(batch["messages"])
        except Exception:  # noqa: BLE001 - the connection closed
            return


def _until(condition: Callable[[], Any], what: str, timeout: float = 30.0) -> Any:
    end = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < end, f"timed out after {timeout:g} s waiting for {what}"
        time.sleep(0.02)
    return value


def _port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _button(app: Gui, label: str) -> Any:
    """The button labelled ``label``."""
    found = [h for h in app.server.gui._gui_input_handle_from_uuid.values()
             if isinstance(h, viser.GuiButtonHandle) and h.label == label]
    assert len(found) == 1, f"{len(found)} buttons labelled {label!r}"
    return found[0]


@pytest.fixture
def app(tmp_path: Path) -> Iterator[Gui]:
    gui = Gui(ml.builtin_spec("planar2"), tmp_path / "ws", port=_port())
    try:
        yield gui
    finally:
        gui.close()


def _idle(app: Gui, timeout: float = 120.0) -> str:
    _until(lambda: not app.jobs.busy, "the job's end", timeout)
    return app.said


# --- values ---------------------------------------------------------------------------------------


def test_values_a_widget_cannot_hold_are_refused_and_restored(app: Gui) -> None:
    sim = app.simulate
    page = Page(app)
    bad: list[tuple[Any, list[Any]]] = [
        (sim.dt, [1e-308, math.nan, math.inf, -1e-3, 0.0, 0.5, "0.002", True, None, [0.002]]),
        (sim.duration, [-1.0, 1e300, math.nan]),
        (sim.payload, [-5.0, math.inf]),
        (sim.target_joint, ["q9", 3, None]),
        (sim.mode, ["pid; rm -rf", ["pid"]]),
        (sim.name, [123, "x" * 20_000, {"a": 1}]),
        (sim.target, [[math.nan, 0.0, 0.0], [1.0, 2.0], "abc", [1e9, 0.0, 0.0]]),
        (app.watch.time, [-1.0, 1e9]),
        (app.watch.speed, ["1000"]),
        (app.runs.signals["q"], ["yes", 1]),
        (app.progress, [50.0]),
        (sim.second, [0.7]),  # disabled: the page cannot change it
    ]
    before = {id(h): h.value for h, _ in bad}
    for handle, values in bad:
        for value in values:
            page.set(handle, value)
    page.set(sim.dt, 2e-3)  # a valid value, sent last: once it is applied, all were handled
    _until(lambda: sim.dt.value == 2e-3, "the valid step applied")
    time.sleep(0.3)
    for handle, _ in bad:
        if handle is not sim.dt:
            assert handle.value == before[id(handle)], handle.label
    # the page that sent the refused step was shown the server's value again
    restored = [m for m in page.received if m.get("type") == "GuiUpdateMessage"
                and m.get("uuid") == sim.dt._impl.uuid and m["updates"].get("value") == 1e-3]
    assert restored
    # and the simulation ran at the step the server holds, never at a refused one
    page.set(sim.inputs["q1"], "step:0.5@0.1")
    page.set(sim.duration, 0.2)
    _until(lambda: sim.duration.value == 0.2, "the duration applied")
    page.set(sim.dt, math.nan)
    page.set(_button(app, "Run"), True)
    _until(lambda: app.workspace.runs(), "the run stored")
    run = app.workspace.load_run("run")
    assert float(run.t[1] - run.t[0]) == pytest.approx(2e-3)
    page.close()


def test_foreign_attributes_uploads_and_share_requests_change_nothing(app: Gui) -> None:
    page = Page(app)
    stop, name = app.stop_button, app.simulate.name
    page.set(stop, True, update_cb=[])
    page.send("GuiUpdateMessage", uuid=stop._impl.uuid, updates={"update_cb": []})
    page.send("GuiUpdateMessage", uuid=app.simulate.dt._impl.uuid, updates={"min": 0.0})
    page.send("GuiUpdateMessage", uuid=stop._impl.uuid, updates={"disabled": True})
    page.send("FileTransferStartUpload", source_component_uuid=name._impl.uuid,
              transfer_uuid="t1", filename="x.txt", mime_type="text/plain", part_count=1,
              size_bytes=3)
    page.send("FileTransferPart", source_component_uuid=name._impl.uuid, transfer_uuid="t1",
              part_index=0, content=b"abc")
    page.send("ShareUrlRequest")
    page.set(name, "still-text")  # sent last: once applied, the others were handled
    _until(lambda: name.value == "still-text", "the valid name applied")
    time.sleep(0.3)
    assert len(stop._impl.update_cb) == 1 and not stop.disabled
    assert app.simulate.dt.min == 1e-6
    assert isinstance(name.value, str)
    assert app.server.gui._current_file_upload_states == {}
    assert app.server._share_tunnel is None
    # Stop still answers the page
    app.simulate.duration.value = 600.0
    page.set(_button(app, "Run"), True)
    _until(lambda: app.jobs.busy, "the run started")
    page.set(stop, True)
    assert "stopped, nothing stored" in _idle(app, 30.0)
    page.close()


def test_uploads_are_capped_and_freed_when_their_client_leaves(app: Gui) -> None:
    button = app.server.gui.add_upload_button("file")  # maniplab has none: a stand-in
    states = app.server.gui._current_file_upload_states
    page = Page(app)
    page.send("FileTransferStartUpload", source_component_uuid=button._impl.uuid,
              transfer_uuid="big", filename="big.bin", mime_type="", part_count=40,
              size_bytes=MAX_UPLOAD + 1)
    page.send("FileTransferStartUpload", source_component_uuid=button._impl.uuid,
              transfer_uuid="half", filename="half.bin", mime_type="", part_count=2,
              size_bytes=8)
    page.send("FileTransferPart", source_component_uuid=button._impl.uuid,
              transfer_uuid="half", part_index=0, content=b"x" * 4)
    _until(lambda: "half" in states and states["half"]["parts"], "the first part")
    assert "big" not in states
    page.close()
    _until(lambda: not states, "the half upload freed")


# --- who connects ---------------------------------------------------------------------------------


def test_only_the_own_page_with_the_token_connects(app: Gui) -> None:
    port = app.server.get_port()
    for origin, token in (("http://evil.example", True), ("null", True),
                          (f"http://127.0.0.1:{port}", False), (None, False)):
        with pytest.raises(InvalidStatus) as refused:
            Page(app, token=token, origin=origin)
        assert refused.value.response.status_code == 403
    with pytest.raises(InvalidStatus):  # DNS rebinding: the right token, a foreign name
        Page(app, headers={"Host": f"evil.example:{port}"})
    for origin in (f"http://127.0.0.1:{port}", f"http://localhost:{port}", None):
        Page(app, origin=origin).close()
    Page(app, token=False, headers={"Cookie": f"maniplab-gui-{port}={app.token}"}).close()
    # the page itself: only with the token, or its cookie, and the server's own name
    for url, headers, status in ((app.url, {}, 200), (app.address + "/", {}, 403),
                                 (app.address + "/?token=wrong", {}, 403),
                                 (app.url, {"Host": f"evil.example:{port}"}, 403)):
        try:
            with urllib.request.urlopen(urllib.request.Request(url, headers=headers),
                                        timeout=10) as answer:
                got, cookie = answer.status, answer.headers.get("Set-Cookie", "")
        except urllib.error.HTTPError as error:
            got, cookie = error.code, ""
        assert got == status, url
        if status == 200:
            assert "HttpOnly" in cookie and "SameSite=Strict" in cookie and app.token in cookie


def test_downloads_go_only_to_the_page_that_asked(app: Gui) -> None:
    asking, other = Page(app), Page(app)
    asking.set(_button(app, "Download MJCF"), True)
    _until(lambda: "FileTransferStartDownload" in asking.kinds(), "the download at the asker")
    time.sleep(0.5)
    assert "FileTransferStartDownload" not in other.kinds()
    asking.close()
    other.close()


# --- floods ---------------------------------------------------------------------------------------


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def test_a_flood_of_edits_and_clicks_leaves_run_responsive(app: Gui) -> None:
    mass = next(f.input for f in app.configure.joint_fields if f.path == "body.mass")
    flooder, user = Page(app), Page(app)
    before = _rss_mb()
    for k in range(2000):  # 2,000 edits of a field that redraws the arm, 3,000 clicks
        flooder.set(mass, str(1.0 + k))
    for _ in range(1000):
        for label in ("Add term", "Plot selected runs", "Download MJCF"):
            flooder.set(_button(app, label), True)
    app.simulate.duration.value = 600.0
    began = time.monotonic()
    user.set(_button(app, "Run"), True)
    _until(lambda: app.jobs.busy, "Run to start after the flood", timeout=10.0)
    answered = time.monotonic() - began
    user.set(app.stop_button, True)
    assert "stopped" in _idle(app, 30.0)
    # the flood is worked off: the last edit wins
    _until(lambda: app.spec.joints[0].body.mass == 2000.0, "the last mass", timeout=60.0)
    assert _rss_mb() - before < 400.0, f"memory grew by {_rss_mb() - before:.0f} MB"
    print(f"Run answered {answered:.2f} s after a flood of 5,000 messages; memory "
          f"{_rss_mb() - before:+.0f} MB")
    flooder.close()
    user.close()



def test_an_edit_arriving_while_the_last_is_applied_is_kept(app: Gui) -> None:
    """The flood test's lost update, made deterministic: the page's next edit reaches the server
    while the last one is being applied; applying must not write the older value over it."""
    field = next(f for f in app.configure.joint_fields if f.path == "body.mass")
    arrived: list[str] = []

    def next_edit_arrives() -> None:  # what viser's event loop does when the next edit lands
        if not arrived:
            arrived.append("777.0")
            field.show("777.0")  # the value only: its callback is the coalesced one below

    app._spec_listeners.insert(0, next_edit_arrives)
    field.show("555.0")
    app.configure._apply_joint(field)
    assert app.spec.joints[0].body.mass == 555.0
    assert field.input.value == "777.0", "the newer edit was overwritten by the one applied"
    app.configure._apply_joint(field)  # its own callback, coalesced, runs next
    assert app.spec.joints[0].body.mass == 777.0

# --- text and names -------------------------------------------------------------------------------


def test_a_spec_name_with_markup_is_shown_as_text_and_runs_no_script(tmp_path: Path) -> None:
    spec = ml.builtin_spec("planar2").with_overrides({"name": XSS})
    app = Gui(spec, tmp_path / "ws", port=_port())
    try:
        app.simulate.duration.value = 600.0
        with web.chromium() as driver:
            driver.get(app.url)
            web.tab(driver, "Simulate")
            web.click(driver, "Run")  # the status names the arm: "simulating NAME ..."
            _until(lambda: app.jobs.busy, "the run started")
            web.click(driver, "Stop")
            web.text_shown(driver, f"simulating {XSS}: stopped, nothing stored")
            time.sleep(1.0)
            assert driver.execute_script("return window.xss === undefined")
            assert driver.execute_script("return document.querySelectorAll('iframe').length") == 0
            web.shot(driver, "security-escaped-name")
    finally:
        app.close()


def test_callback_errors_are_shown_on_the_page_in_one_line(app: Gui) -> None:
    def fail(_: Any) -> None:
        raise RuntimeError(f"boom\nsecond line {XSS}")

    app.server.gui.add_button("Fail").on_click(fail)
    page = Page(app)
    page.set(_button(app, "Fail"), True)
    _until(lambda: "boom" in app.said, "the error on the page")
    shown = str(app.status.content)
    assert "RuntimeError: boom second line" in shown and "\n" not in shown
    assert "<iframe" not in shown and "&lt;iframe" in shown
    page.close()


def test_run_names_are_checked_before_the_run(app: Gui) -> None:
    sim = app.simulate
    sim.name.value = "x" * 65
    sim.run_open_loop()
    assert not app.jobs.busy and "not a valid name" in str(sim.input_error.content)
    sim.name.value = "y" * 63
    sim.duration.value = 0.05
    sim.run_open_loop()
    _idle(app)
    assert app.workspace.runs() == ["y" * 63]
    sim.run_open_loop()  # "-2" would make it 65 characters: refused before running
    assert not app.jobs.busy and "too long" in str(sim.input_error.content)
    sim.name.value = "z" * 60
    sim.run_move()  # stored as NAME-cascade: 68 characters
    assert not app.jobs.busy and "not a valid name" in str(sim.verdict.content)


def test_safe_file_names_are_ascii(tmp_path: Path) -> None:
    space = Workspace(tmp_path)
    for name in ("Kran-ä", "臂", "Grúa 3", XSS, ""):
        safe = _safe(name)
        assert safe.isascii() and space.path("specs", safe, ".yaml")
    assert len(_safe("é" * 100, 58) + "_model") <= 64
