"""The demonstration page's web server: the standard library's ``http.server``, nothing else.

Routes (JSON in and out):

* ``GET /`` (and ``/demo.js``, ``/demo.css``): the page, plain HTML and JavaScript;
* ``GET /api/state``: what the page draws (:meth:`DemoSession.snapshot`);
* ``GET /api/events``: the same as server-sent events, one per change;
* ``POST /api/episode``: reset the world into a new episode (task, blocks, objects, ...);
* ``POST /api/action``: a click (object and goal, an orientation, or a tray toggle).

The page moves a robot, so the server listens on loopback by default and, against another web
site in the same browser, answers only requests whose ``Host`` is this server's own (DNS
rebinding) and POSTs only with a JSON content type from no other origin (a cross-site form
cannot send one). Bodies are limited to :data:`MAX_BODY` bytes and every field is checked,
naming it when it is wrong.
"""

from __future__ import annotations

import json
import logging
import re
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib.resources import files
from typing import Any, Protocol

from manigraph_shared.messages import Action
from manigraph_tools.click_page.clicks import Click, ClickRefused
from manigraph_tools.click_page.session import DemoSession

log = logging.getLogger("manigraph.demo-ui.http")

MAX_BODY = 4096
#: Seconds between keep-alive comments on the event stream (and checks for shutdown).
EVENT_WAIT = 1.0
#: How long a click waits for the world to settle (the robot finishing, a fresh scene).
READY_WAIT = 3.0
STATIC = {
    "/": ("index.html", "text/html; charset=utf-8"),
    "/index.html": ("index.html", "text/html; charset=utf-8"),
    "/demo.js": ("demo.js", "text/javascript; charset=utf-8"),
    "/demo.css": ("demo.css", "text/css; charset=utf-8"),
}


class BadRequest(ValueError):
    """A request the server refuses before it reaches the session; names the field."""


class DemoApp(Protocol):
    """What the server needs from the demo-ui service."""

    session: DemoSession
    stopping: threading.Event

    def start_episode(self, fields: dict[str, Any]) -> str: ...

    def act(self, click: Click) -> Action: ...

    def page_defaults(self) -> dict[str, Any]: ...


def click_from_json(body: dict[str, Any]) -> Click:
    """A :class:`Click` from the page's JSON; :class:`BadRequest` naming a bad field."""
    known = {"object_id", "goal_id", "orientation_index", "family_action"}
    unknown = sorted(set(body) - known)
    if unknown:
        raise BadRequest(
            f"{unknown[0]}: not a field of a click (known: {', '.join(sorted(known))})"
        )
    ids: dict[str, str | None] = {}
    for name in ("object_id", "goal_id"):
        value = body.get(name)
        if value is not None and (not isinstance(value, str) or not 0 < len(value) <= 64):
            raise BadRequest(f"{name}: must be an id of 1-64 characters or null")
        ids[name] = value
    orientation = body.get("orientation_index")
    if orientation is not None and (
        isinstance(orientation, bool) or not isinstance(orientation, int)
    ):
        raise BadRequest("orientation_index: must be an integer 0..5 or null")
    family_action = body.get("family_action")
    if family_action is not None and (
        not isinstance(family_action, str) or not _FAMILY_NAME.fullmatch(family_action)
    ):
        raise BadRequest("family_action: must be a name of 1-32 of [a-z0-9_] or null")
    return Click(ids["object_id"], ids["goal_id"], orientation, family_action)


#: A family action's name, as the contract takes it (``Action.family_action``).
_FAMILY_NAME = re.compile(r"[a-z][a-z0-9_]{0,31}")


class DemoHttpServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, address: tuple[str, int], app: DemoApp) -> None:
        self.app = app
        super().__init__(address, _Handler)

    @property
    def port(self) -> int:
        return int(self.server_address[1])

    def allowed_hosts(self) -> set[str]:
        host = str(self.server_address[0])
        names = {host, "127.0.0.1", "localhost", "[::1]"}
        return {f"{name}:{self.port}" for name in names}


class _Handler(BaseHTTPRequestHandler):
    server: DemoHttpServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s " + format, self.address_string(), *args)

    # --- plumbing -----------------------------------------------------------------------------
    def _send(self, status: int, body: bytes, content_type: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, status: int, payload: dict[str, Any]) -> None:
        self._send(status, json.dumps(payload).encode(), "application/json")

    def _error(self, status: int, text: str) -> None:
        self._json(status, {"ok": False, "error": text})

    def _host_ok(self) -> bool:
        if self.headers.get("Host", "") in self.server.allowed_hosts():
            return True
        self._error(HTTPStatus.MISDIRECTED_REQUEST, "Host: not this server's address")
        return False

    def _body(self) -> dict[str, Any]:
        if self.headers.get("Content-Type", "").split(";")[0].strip() != "application/json":
            raise BadRequest("Content-Type: must be application/json")
        origin = self.headers.get("Origin")
        if origin is not None and origin.removeprefix("http://") not in self.server.allowed_hosts():
            raise BadRequest("Origin: requests from other sites are refused")
        try:
            length = int(self.headers.get("Content-Length", "0"))
        except ValueError:
            raise BadRequest("Content-Length: not a number") from None
        if not 0 < length <= MAX_BODY:
            raise BadRequest(f"Content-Length: a body of 1..{MAX_BODY} bytes is expected")
        try:
            body = json.loads(self.rfile.read(length))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise BadRequest(f"body: not JSON ({exc})") from None
        if not isinstance(body, dict):
            raise BadRequest("body: must be a JSON object")
        return body

    # --- routes -------------------------------------------------------------------------------
    def do_GET(self) -> None:
        if not self._host_ok():
            return
        path = self.path.split("?")[0]
        app = self.server.app
        if path in STATIC:
            name, content_type = STATIC[path]
            page = files("manigraph_tools.click_page").joinpath("static", name).read_bytes()
            self._send(HTTPStatus.OK, page, content_type)
        elif path == "/api/state":
            self._json(HTTPStatus.OK, {**app.session.snapshot(), "defaults": app.page_defaults()})
        elif path == "/api/events":
            self._events()
        else:
            self._error(HTTPStatus.NOT_FOUND, f"{path}: no such page")

    def do_POST(self) -> None:
        if not self._host_ok():
            return
        path = self.path.split("?")[0]
        app = self.server.app
        try:
            body = self._body()
            if path == "/api/episode":
                episode_id = app.start_episode(body)
                self._json(HTTPStatus.OK, {"ok": True, "episode_id": episode_id})
            elif path == "/api/action":
                action = app.act(click_from_json(body))
                # The session's version once the click is in: the page says "ready" again
                # only from a state at least this new (an older one predates the click).
                version = app.session.version
                self._json(
                    HTTPStatus.OK,
                    {"ok": True, "decision_id": action.decision_id, "version": version},
                )
            else:
                self._error(HTTPStatus.NOT_FOUND, f"{path}: no such action")
        except (BadRequest, ClickRefused) as exc:
            self._error(HTTPStatus.BAD_REQUEST, str(exc))
        except ServiceUnavailable as exc:
            self._error(HTTPStatus.SERVICE_UNAVAILABLE, str(exc))

    def _events(self) -> None:
        """Server-sent events: the snapshot after every change, until the client goes."""
        app = self.server.app
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        sent = -1
        try:
            while not app.stopping.is_set():
                version = app.session.version
                if version != sent:
                    data = json.dumps({**app.session.snapshot(), "defaults": app.page_defaults()})
                    self.wfile.write(f"data: {data}\n\n".encode())
                    sent = version
                else:
                    self.wfile.write(b": waiting\n\n")
                self.wfile.flush()
                app.session.wait_changed(sent, EVENT_WAIT)
        except (BrokenPipeError, ConnectionResetError):
            return


class ServiceUnavailable(RuntimeError):
    """The stack could not do what the page asked (no sim answering a reset)."""
