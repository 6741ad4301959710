"""Who may open the GUI: the page's own address and a secret token, as Jupyter does it.

viser's server answers any HTTP request whatever its ``Host`` header (DNS rebinding: a page of
``evil.example`` whose name now resolves to 127.0.0.1 reads it) and accepts any websocket whatever
its ``Origin`` (cross-site websocket hijacking: any page the user visits drives the GUI). So every
request, page or websocket, must:

* name the server in ``Host``: ``127.0.0.1``, ``localhost`` or ``[::1]``, the ``--host`` given, or
  the address the connection came in on, each with the server's port;
* come from the server's own page when it says where it comes from (``Origin``);
* carry the token: ``?token=...`` in the address ``maniplab gui`` prints and opens, or the cookie
  the page received with it (viser's page opens its websocket at the page's address without the
  query, so the cookie is what carries the token there; it is ``HttpOnly`` and ``SameSite=Strict``).

Anything else is answered 403 before viser sees it. viser has no hook for this: :func:`hooked`
swaps the ``serve`` function viser's server thread calls, while one server is being built, for one
that adds the check (and a 1 MiB message limit instead of viser's 50 MiB).
"""

from __future__ import annotations

import contextlib
import hmac
import http
import ipaddress
import secrets
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any
from urllib.parse import parse_qs, urlsplit

LOOPBACK = ("127.0.0.1", "localhost", "::1")
MAX_MESSAGE = 1 << 20
"""Largest websocket message a page may send, bytes (viser's upload parts are 512 KiB)."""

_building = threading.Lock()


def new_token() -> str:
    """A fresh random token (32 URL-safe characters)."""
    return secrets.token_urlsafe(24)


def _bracketed(host: str) -> str:
    """``host`` as it stands in a URL or a Host header (IPv6 in brackets), lower case."""
    host = host.strip().lower()
    with contextlib.suppress(ValueError):
        if ipaddress.ip_address(host.strip("[]")).version == 6:
            return f"[{host.strip('[]')}]"
    return host


class Access:
    """The check of one server's requests (module docstring).

    Args:
        token: the secret the page's address carries.
        hosts: names the server is reached by, besides the loopback ones (the ``--host`` given).
    """

    def __init__(self, token: str, hosts: Iterable[str] = ()) -> None:
        self.token = token
        self.names = {_bracketed(h) for h in (*LOOPBACK, *hosts)} - {"0.0.0.0", "[::]"}

    def cookie(self, port: int) -> str:
        """The cookie's name for the server on ``port`` (cookies do not tell ports apart)."""
        return f"maniplab-gui-{port}"

    def refusal(self, connection: Any, request: Any) -> str | None:
        """Why ``request`` (a websockets Request) is refused, or None when it may pass."""
        local = connection.local_address
        port = int(local[1])
        allowed = {f"{name}:{port}" for name in {*self.names, _bracketed(str(local[0]))}}
        host = (request.headers.get("Host") or "").lower()
        if host not in allowed:
            return f"unknown host {host!r}"
        origin = request.headers.get("Origin")
        if origin is not None and origin.lower() not in {f"http://{a}" for a in allowed}:
            return f"foreign origin {origin!r}"
        given = _query_token(request.path) or _cookies(request.headers).get(self.cookie(port))
        if given is None or not hmac.compare_digest(given.encode(), self.token.encode()):
            return "no valid token: open the address 'maniplab gui' printed"
        return None

    def wrap(self, process_request: Callable[..., Any] | None) -> Callable[..., Any]:
        """``process_request`` (viser's file server) behind the check; the page served to an
        address with the token gets the token's cookie."""
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        def checked(connection: Any, request: Any) -> Any:
            why = self.refusal(connection, request)
            if why is not None:
                body = f"maniplab gui: refused: {why}\n".encode()
                return Response(http.HTTPStatus.FORBIDDEN.value, "Forbidden",
                                Headers({"Content-Type": "text/plain; charset=utf-8",
                                         "Content-Length": str(len(body))}), body)
            response = process_request(connection, request) if process_request else None
            if response is not None and _query_token(request.path):
                response.headers["Set-Cookie"] = (
                    f"{self.cookie(int(connection.local_address[1]))}={self.token}; "
                    "Path=/; HttpOnly; SameSite=Strict")
            return response

        return checked


@contextlib.contextmanager
def hooked(access: Access) -> Iterator[None]:
    """While viser builds a server inside this block, that server checks ``access``.

    viser's server thread calls ``websockets.asyncio.server.serve(handler, host, port,
    process_request=..., max_size=...)``; here that call gets ``access`` wrapped around its
    ``process_request`` and :data:`MAX_MESSAGE` as ``max_size``. One server is built at a time.
    """
    import websockets.asyncio.server as ws_server

    original = ws_server.serve
    calls: list[int] = []

    def serve(*args: Any, **kwargs: Any) -> Any:
        kwargs["process_request"] = access.wrap(kwargs.get("process_request"))
        kwargs["max_size"] = MAX_MESSAGE
        calls.append(1)
        return original(*args, **kwargs)

    with _building:
        ws_server.serve = serve  # type: ignore[assignment]
        try:
            yield
        finally:
            ws_server.serve = original
        if not calls:  # fail closed should viser stop calling serve this way
            raise RuntimeError("maniplab gui: viser's server was not guarded (viser changed?)")


def _query_token(path: str) -> str | None:
    values = parse_qs(urlsplit(path).query).get("token")
    return values[0] if values else None


def _cookies(headers: Any) -> dict[str, str]:
    found: dict[str, str] = {}
    for line in headers.get_all("Cookie"):
        for part in line.split(";"):
            name, _, value = part.strip().partition("=")
            found.setdefault(name, value)
    return found
