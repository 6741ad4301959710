"""What a page may send to the GUI server: checked values, no foreign attributes, no flood.

viser's server trusts its page. For each message a connected client sends it casts a widget's new
value to the widget's type (so NaN, inf, a number outside the widget's min and max, a dropdown
choice outside its options all pass), sets *any* attribute the message names on the widget's
server state (``{"update_cb": []}`` silenced Stop for every tab), takes file uploads for any
widget (the run-name field became an ``UploadedFile``), opens a public share tunnel when asked
(``ShareUrlRequest``, although the share button is hidden), and hands every callback to a thread
pool with an unbounded queue (2,000 edits and 3,000 clicks in a second left Run dead for 45 s).

viser has no hook for any of this, so :func:`guard` wraps two of its internals for one server:

* the server's dispatch of incoming messages (``WebsockServer._handle_incoming_message``): a
  message passes only when it is of a kind the page needs (:data:`PASSED`), a widget update sets
  nothing but ``value`` on an enabled widget and its value is valid for the widget
  (:func:`checked_value`: type, finite, min/max, options, length), and an upload goes to an
  upload button, within :data:`MAX_UPLOAD` bytes. A refused value is dropped and the sender's
  widget is set back to the server's value.
* the executor the GUI and scene APIs hand callbacks to: callbacks run one at a time per client,
  coalesced per widget (while a widget's callback runs, later events of that widget wait as one:
  the callback reads the latest value), at most :data:`QUEUE` widgets waiting per client (more
  are dropped). An exception in a callback is shown on the page (``on_error``) and its traceback
  printed on stderr.

What this guards, for users: docs/guide/safety.md, "The GUI server".
"""

from __future__ import annotations

import math
import threading
import traceback
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

QUEUE = 32
"""Widgets whose callbacks may wait at once, per client; events of further widgets are dropped."""
MAX_TEXT = 10_000
"""Longest text a text field takes, characters."""
MAX_UPLOAD = 16 << 20
"""Largest file an upload button takes, bytes."""

PASSED = frozenset({
    "GuiUpdateMessage", "FileTransferStartUpload", "FileTransferPart", "ViewerCameraMessage",
    "TransformControlsUpdateMessage", "TransformControlsDragStartMessage",
    "TransformControlsDragEndMessage", "ScenePointerMessage", "SceneNodeClickMessage",
})
"""Kinds of message a page may send (the page's own camera, widgets, gizmo and clicks); all others
(share tunnel, forms, commands, server-side kinds) are dropped."""

_REFUSED = object()


def checked_value(handle: Any, value: Any) -> Any:
    """``value`` as the widget ``handle`` holds it, or :data:`_REFUSED` when invalid for it."""
    import viser

    current = handle.value
    if isinstance(handle, viser.GuiButtonHandle):
        return True if value is True else _REFUSED
    if isinstance(handle, viser.GuiCheckboxHandle):
        return value if isinstance(value, bool) else _REFUSED
    if isinstance(handle, viser.GuiTextHandle):
        return value if isinstance(value, str) and len(value) <= MAX_TEXT else _REFUSED
    if isinstance(handle, (viser.GuiDropdownHandle, viser.GuiButtonGroupHandle)):
        return value if isinstance(value, str) and value in handle.options else _REFUSED
    if isinstance(handle, (viser.GuiNumberHandle, viser.GuiSliderHandle)):
        return _number(value, type(current), handle.min, handle.max)
    if isinstance(handle, (viser.GuiVector2Handle, viser.GuiVector3Handle,
                           viser.GuiMultiSliderHandle, viser.GuiRgbHandle, viser.GuiRgbaHandle)):
        if not isinstance(value, (list, tuple)) or len(value) != len(current):
            return _REFUSED
        low, high = getattr(handle, "min", None), getattr(handle, "max", None)
        if isinstance(handle, (viser.GuiRgbHandle, viser.GuiRgbaHandle)):
            low, high = 0, 255
        out = tuple(_number(v, type(c), _at(low, k), _at(high, k))
                    for k, (v, c) in enumerate(zip(value, current)))
        return _REFUSED if _REFUSED in out else out
    return _REFUSED  # progress bars, upload buttons, kinds not known here: not the page's to set


def _number(value: Any, kind: type, low: Any, high: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return _REFUSED
    x = float(value)
    if not math.isfinite(x) or (low is not None and x < low) or (high is not None and x > high):
        return _REFUSED
    if kind is int:
        return int(x) if x.is_integer() else _REFUSED
    return x


def _at(bound: Any, k: int) -> Any:
    return bound[k] if isinstance(bound, (list, tuple)) else bound


class Guard:
    """The checks of one viser server (module docstring); made by :func:`guard`."""

    def __init__(self, server: Any, on_error: Callable[[BaseException], None]) -> None:
        self.server = server
        self.callbacks = Callbacks(server._thread_executor, on_error)
        self._uploads: dict[str, list[int]] = {}  # transfer -> [client, bytes left]
        self._lock = threading.Lock()

    def passes(self, client_id: int, message: Any) -> bool:
        """Whether ``message`` from ``client_id`` may reach viser (a valid value is normalised
        in place; a refused one is set back on the sender's page). Fails closed."""
        try:
            return self._passes(client_id, message)
        except Exception:  # noqa: BLE001 - a message this module cannot judge is dropped
            return False

    def _passes(self, client_id: int, message: Any) -> bool:
        kind = type(message).__name__
        if kind not in PASSED:
            return False
        if kind == "GuiUpdateMessage":
            return self._update(client_id, message)
        if kind == "FileTransferStartUpload":
            return self._upload_start(client_id, message)
        if kind == "FileTransferPart":
            return self._upload_part(client_id, message)
        if kind == "TransformControlsUpdateMessage":
            numbers = (*message.wxyz, *message.position)
            return all(_number(x, float, -1e6, 1e6) is not _REFUSED for x in numbers)
        return True

    def _update(self, client_id: int, message: Any) -> bool:
        handle = self.server.gui._gui_input_handle_from_uuid.get(message.uuid)
        if (handle is None or handle._impl.removed or getattr(handle, "disabled", True)
                or set(message.updates) != {"value"}):
            return False
        value = checked_value(handle, message.updates["value"])
        if value is _REFUSED:
            self._restore(client_id, handle)
            return False
        message.updates["value"] = value
        return True

    def _restore(self, client_id: int, handle: Any) -> None:
        """Show the sender the server's value again (its page shows what it sent)."""
        from viser._messages import GuiUpdateMessage

        state = self.server._websock_server._client_state_from_id.get(client_id)
        if state is not None:
            state.message_buffer.push(GuiUpdateMessage(handle._impl.uuid, {"value": handle.value}))

    def _upload_start(self, client_id: int, message: Any) -> bool:
        import viser

        handle = self.server.gui._gui_input_handle_from_uuid.get(message.source_component_uuid)
        size, parts = message.size_bytes, message.part_count
        if (not isinstance(handle, viser.GuiUploadButtonHandle) or handle.disabled
                or not 0 <= size <= MAX_UPLOAD or not 0 <= parts <= min(size, 4096)):
            return False
        with self._lock:
            if sum(owner == client_id for owner, _ in self._uploads.values()) >= 2:
                return False
            self._uploads[message.transfer_uuid] = [client_id, size]
        return True

    def _upload_part(self, client_id: int, message: Any) -> bool:
        with self._lock:
            entry = self._uploads.get(message.transfer_uuid)
            if entry is None or entry[0] != client_id or len(message.content) > entry[1]:
                self._uploads.pop(message.transfer_uuid, None)
                self.server.gui._current_file_upload_states.pop(message.transfer_uuid, None)
                return False
            entry[1] -= len(message.content)
            if entry[1] == 0:
                del self._uploads[message.transfer_uuid]
        return True

    def forget(self, client_id: int) -> None:
        """Free what a client that left had half uploaded."""
        with self._lock:
            for transfer in [t for t, (owner, _) in self._uploads.items() if owner == client_id]:
                del self._uploads[transfer]
        self.server.gui._drop_uploads_from_client(client_id)


class Callbacks:
    """An executor for viser's event callbacks: one at a time per client, coalesced per widget,
    at most :data:`QUEUE` widgets waiting per client (the rest dropped); errors go to
    ``on_error``. It has the one method viser calls, ``submit(callback, event)``."""

    def __init__(self, pool: Any, on_error: Callable[[BaseException], None]) -> None:
        self.pool = pool
        self.on_error = on_error
        self.dropped = 0
        self._waiting: dict[Any, OrderedDict[Any, tuple[Callable[..., Any], tuple[Any, ...]]]] = {}
        self._lock = threading.Lock()

    def submit(self, callback: Callable[..., Any], *args: Any) -> Future[None]:
        event = args[0] if args else None
        client = getattr(event, "client_id", None)
        key = (id(getattr(event, "target", None)), callback)
        with self._lock:
            queue = self._waiting.get(client)
            start = queue is None
            if queue is None:
                queue = self._waiting[client] = OrderedDict()
            if key in queue or len(queue) < QUEUE:
                queue[key] = (callback, args)  # a waiting event of the widget: now the latest
            else:
                self.dropped += 1
        if start:
            self.pool.submit(self._drain, client)
        done: Future[None] = Future()
        done.set_result(None)
        return done

    def _drain(self, client: Any) -> None:
        while True:
            with self._lock:
                queue = self._waiting[client]
                if not queue:
                    del self._waiting[client]
                    return
                _, (callback, args) = queue.popitem(last=False)
            try:
                callback(*args)
            except Exception as exc:  # noqa: BLE001 - shown on the page, logged in full
                traceback.print_exc()
                self.on_error(exc)


def guard(server: Any, on_error: Callable[[BaseException], None]) -> Guard:
    """Put the checks of this module on ``server`` (a ``viser.ViserServer`` no page has joined)."""
    checks = Guard(server, on_error)
    websock = server._websock_server
    dispatch = websock._handle_incoming_message

    def incoming(client_id: Any, message: Any) -> Any:
        # viser calls this synchronously to make the coroutine it schedules: decided here, in
        # order of arrival, on the event loop's thread
        return dispatch(client_id, message) if checks.passes(client_id, message) else _nothing()

    websock._handle_incoming_message = incoming
    server.gui._thread_executor = checks.callbacks
    server.scene._thread_executor = checks.callbacks
    websock.on_client_disconnect(lambda conn: checks.forget(conn.client_id))
    return checks


async def _nothing() -> None:
    return None
