"""The annotation web server: the page, the clip's frames and the session's edits over HTTP.

Security rules, because a browser on the same machine may visit hostile pages:

* every request must carry the session's random token (``?token=`` or an ``X-Token`` header),
  so no other page can read frames or make edits;
* the Host header must name this server as the loopback address (or the ``--host`` given), so a
  hostile name that resolves to 127.0.0.1 (DNS rebinding) is refused;
* no request names a file: the page's three files are fixed, frames are addressed by number and
  the tracks are the session's own, so nothing outside INPUT, TRACKS and the output folder can
  be read through it.
"""

from __future__ import annotations

import json
import secrets
import socket
import sys
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import parse_qs, urlsplit

import numpy as np

from seedtrack.data.corrections import tracks_of
from seedtrack.data.errors import DataError
from seedtrack.data.numbers import MAX_ID
from seedtrack.tracking.tracks import Tracks

from .doubt import doubtful_places
from .frames import FrameCache
from .session import EditRefused, ReassignUnconfirmed, Session, edit_text

# The page's files: the only paths the server answers besides the API.
_PAGE = {"/": ("index.html", "text/html; charset=utf-8"), "/app.js": ("app.js", "text/javascript; charset=utf-8"), "/app.css": ("app.css", "text/css; charset=utf-8")}
_MAX_BODY = 4096
_LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
_WILDCARDS = ("0.0.0.0", "::", "")
# The page lists this many doubtful places, most doubtful first; the timeline shows where all are.
_LISTED_PLACES = 1000


class AnnotateServer(ThreadingHTTPServer):
    """Serves one session on ``host:port`` (port 0 picks a free one).

    Parameters
    ----------
    session : Session
    frames : FrameCache
    detections : dict of str to ndarray, optional
        Columns ``frame`` (0-based), ``x``, ``y`` (pixels) of the detections to offer as click
        targets.
    other : Tracks, optional
        A second result for the clip; the links where it disagrees are doubtful places.
    host : str
    port : int

    Attributes
    ----------
    token : str
        The secret every request must carry.
    url : str
        The address to open, token included.

    Example
    -------
    >>> server = AnnotateServer(session, FrameCache("clip.mp4"))  # doctest: +SKIP
    >>> print(server.url)  # doctest: +SKIP
    http://127.0.0.1:40211/?token=...
    """

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, session: Session, frames: FrameCache, detections: dict | None = None, other: Tracks | None = None, host: str = "127.0.0.1", port: int = 0) -> None:
        self.session = session
        self.frames = frames
        self.detections = detections
        self.other = other
        self.token = secrets.token_urlsafe(24)
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self.address_family = family
        super().__init__((host, port), _Handler)
        self.port = self.server_address[1]
        names = list(_LOOPBACK_NAMES)
        if host in _WILDCARDS:
            names += [socket.gethostname(), socket.getfqdn()]
        elif host not in names:
            names.append(f"[{host}]" if ":" in host else host)
        self.allowed_hosts = {f"{name}:{self.port}".lower() for name in names}
        shown = "127.0.0.1" if host in _WILDCARDS or host in _LOOPBACK_NAMES else names[-1]
        self.url = f"http://{shown}:{self.port}/?token={self.token}"
        self._detected_frames = _by_frame(detections, frames.frame_count)
        # The doubtful places of one version, computed once, by one request at a time.
        self._doubt: tuple[int, dict] | None = None
        self._doubt_lock = threading.Lock()
        # The page names its script and style sheet with the token, as every request must carry it.
        self._page = {path: (resources.files(__package__).joinpath("static", name).read_bytes().replace(b"__TOKEN__", self.token.encode()), kind) for path, (name, kind) in _PAGE.items()}

    def handle_error(self, request, client_address) -> None:
        # A browser closed or reloaded mid-answer is no fault of the session: nothing to print.
        if isinstance(sys.exc_info()[1], ConnectionError):
            return
        super().handle_error(request, client_address)

    def frame_of(self, body: dict, name: str = "frame") -> int:
        """``body[name]`` as a frame of the clip, as the readers of the session's files take it.

        Raises
        ------
        ValueError
            If it is not a whole number, or not a frame of the clip.
        """
        frame = _whole(body, name)
        count = self.frames.frame_count
        if frame < 0 or (count is not None and frame >= count):
            # A stream's length is not known until its end: only the start bounds it.
            frames = f"0..{count - 1}" if count is not None else ">= 0"
            raise ValueError(f"{name} must be a frame of the clip, {frames}, got {frame}")
        return frame

    def position_of(self, body: dict) -> tuple[float, float]:
        """``body``'s x and y as a position inside the clip's frames (pixels, centres at integers).

        Raises
        ------
        ValueError
            If either is not a finite number or lies outside the frames.
        """
        width, height = self.frames.size
        x, y = _number(body, "x"), _number(body, "y")
        for name, value, size in (("x", x, width), ("y", y, height)):
            if not -0.5 <= value <= size - 0.5:
                raise ValueError(f"{name} must lie inside the {width}x{height} frame ({-0.5:g}..{size - 0.5:g} pixels), got {value:g}")
        return x, y

    def clip_info(self) -> dict:
        """What the page needs once: the clip's size, length and the detections."""
        session = self.session
        with session.lock:
            tracks_end = max(session.by_frame, default=-1) + 1
        count = self.frames.frame_count if self.frames.frame_count is not None else tracks_end
        info = {
            "name": str(self.frames.path),
            "width": self.frames.size[0],
            "height": self.frames.size[1],
            "fps": self.frames.fps,
            "frame_count": int(count),
            "has_tracks": bool(session.start.n_tracks),
            "detections": None,
        }
        if self.detections is not None:
            info["detections"] = {"frame": self.detections["frame"].tolist(), "x": _rounded(self.detections["x"]), "y": _rounded(self.detections["y"])}
        return info

    def state(self) -> dict:
        """The whole session as the page draws it: every track's points, the edits and the version.

        ``since`` is None (the page replaces what it has) and ``removed`` empty; see :meth:`delta`.
        """
        version, tracks, edits, can_redo = self.session.snapshot()
        return _state(version, None, tracks.to_rows(), [], edits, can_redo)

    def delta(self, since: int | None) -> dict:
        """What changed after version ``since``: the points of the tracks changed and the ids of those gone.

        The page applies it to what it holds at ``since``; when that version is unknown (None, or
        not one this session made) the answer is the whole :meth:`state`.
        """
        session = self.session
        with session.lock:
            changed = session.changed_since(since) if since is not None else None
            if changed is not None:
                # An edit replaces a track's dict of points, never changes it: safe to read unlocked.
                kept = {track: session.points[track] for track in sorted(changed) if track in session.points}
                version, edits, can_redo = session.version, list(session.edits), session.can_redo
        if changed is None:
            return self.state()
        return _state(version, since, tracks_of(kept).to_rows(), sorted(changed - kept.keys()), edits, can_redo)

    def doubtful(self) -> dict:
        """The doubtful places of the tracks as they are now: the first ones and how many a frame.

        Computed once a version, outside the session's lock (it takes about a second at 10,000
        tracks), so the page asks for it apart from the tracks and edits never wait for it.
        """
        with self._doubt_lock:
            version, tracks, _, _ = self.session.snapshot()
            if self._doubt is None or self._doubt[0] != version:
                count = self.frames.frame_count
                places = doubtful_places(tracks, self._detected_frames, count, other=self.other)
                length = max(count or 0, max((place["frame"] for place in places), default=-1) + 1)
                per_frame = np.bincount(np.array([place["frame"] for place in places], np.int64), minlength=length)
                self._doubt = (version, {"version": version, "places": places[:_LISTED_PLACES], "count": len(places), "per_frame": per_frame.tolist()})
            return self._doubt[1]


def _state(version: int, since: int | None, rows: dict, removed: list[int], edits: list, can_redo: bool) -> dict:
    return {
        "version": version,
        "since": since,
        "tracks": {
            "track_id": rows["track_id"].tolist(),
            "frame": rows["frame"].tolist(),
            "x": _rounded(rows["x"]),
            "y": _rounded(rows["y"]),
            "interpolated": rows["interpolated"].tolist(),
        },
        "removed": removed,
        "edits": [edit_text(edit) for edit in edits],
        "can_redo": can_redo,
    }


def _rounded(values: np.ndarray) -> list[float]:
    # Hundredths of a pixel are all a picture can show, and make the JSON half as long.
    return np.round(np.asarray(values, float), 2).tolist()


def _by_frame(detections: dict | None, frame_count: int | None) -> list[np.ndarray] | None:
    if detections is None:
        return None
    frame = np.asarray(detections["frame"], np.int64)
    length = max(int(frame.max()) + 1 if frame.size else 0, frame_count or 0)
    xy = np.column_stack((detections["x"], detections["y"])).astype(float)
    order = np.argsort(frame, kind="stable")
    bounds = np.searchsorted(frame[order], np.arange(length + 1))
    return [xy[order[a:b]] for a, b in zip(bounds[:-1], bounds[1:])]


class _Handler(BaseHTTPRequestHandler):
    server: AnnotateServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format, *args) -> None:
        # The terminal shows the address and errors only; each frame fetched would drown them.
        pass

    def do_GET(self) -> None:
        self._handle("GET")

    def do_POST(self) -> None:
        self._handle("POST")

    def _handle(self, method: str) -> None:
        host = (self.headers.get("Host") or "").lower()
        if host not in self.server.allowed_hosts:
            return self._error(HTTPStatus.FORBIDDEN, "this server answers only to its own address (Host header refused)")
        url = urlsplit(self.path)
        query = parse_qs(url.query)
        token = self.headers.get("X-Token") or (query.get("token") or [""])[0]
        if not secrets.compare_digest(token.encode(), self.server.token.encode()):
            return self._error(HTTPStatus.FORBIDDEN, "missing or wrong token; open the address the command printed")
        route = (method, url.path)
        if method == "GET" and url.path in self.server._page:
            body, kind = self.server._page[url.path]
            return self._send(HTTPStatus.OK, body, kind)
        if route == ("GET", "/api/clip"):
            return self._json(self.server.clip_info())
        if route == ("GET", "/api/state"):
            return self._json(self.server.state())
        if route == ("GET", "/api/doubtful"):
            return self._json(self.server.doubtful())
        if route == ("GET", "/api/frame"):
            return self._frame(query)
        if method == "POST" and url.path in _ACTIONS:
            return self._act(_ACTIONS[url.path])
        return self._error(HTTPStatus.NOT_FOUND, "no such page")

    def _frame(self, query: dict) -> None:
        try:
            index = int((query.get("i") or [""])[0])
        except ValueError:
            return self._error(HTTPStatus.BAD_REQUEST, "frame number i must be a whole number")
        try:
            picture = self.server.frames.jpeg(index)
        except IndexError:
            return self._error(HTTPStatus.NOT_FOUND, f"the clip has no frame {index}")
        except DataError as error:
            return self._error(HTTPStatus.UNPROCESSABLE_ENTITY, str(error))
        self._send(HTTPStatus.OK, picture, "image/jpeg", cache=True)

    def _act(self, action) -> None:
        length = int(self.headers.get("Content-Length") or 0)
        if length > _MAX_BODY:
            return self._error(HTTPStatus.REQUEST_ENTITY_TOO_LARGE, "request too large")
        try:
            body = json.loads(self.rfile.read(length) or b"{}")
            if not isinstance(body, dict):
                raise ValueError("not an object")
            extra = action(self.server, body)
        except ReassignUnconfirmed as error:
            # The page asks, and sends the click again with "reassign": true if the user agrees.
            return self._send(HTTPStatus.CONFLICT, json.dumps({"error": str(error), "reassign": str(error)}).encode(), "application/json")
        except EditRefused as error:
            return self._error(HTTPStatus.CONFLICT, str(error))
        except (ValueError, TypeError, KeyError) as error:
            return self._error(HTTPStatus.BAD_REQUEST, f"bad request: {error}")
        # The page names the version it holds, and gets only what changed since.
        try:
            seen = int(self.headers.get("X-Version") or "")
        except ValueError:
            seen = None
        self._json({**self.server.delta(seen), **extra})

    def _json(self, value) -> None:
        self._send(HTTPStatus.OK, json.dumps(value, separators=(",", ":")).encode(), "application/json")

    def _error(self, status: HTTPStatus, message: str) -> None:
        self._send(status, json.dumps({"error": message}).encode(), "application/json")

    def _send(self, status: HTTPStatus, body: bytes, kind: str, cache: bool = False) -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        # A frame never changes within a session; everything else may after an edit.
        self.send_header("Cache-Control", "private, max-age=3600" if cache else "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        # The token is in the address: never hand it to another site.
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("Content-Security-Policy", "default-src 'self'; img-src 'self' data:; frame-ancestors 'none'")
        self.end_headers()
        self.wfile.write(body)


def _whole(body: dict, name: str, optional: bool = False) -> int | None:
    value = body.get(name)
    if value is None and optional:
        return None
    if not isinstance(value, int) or isinstance(value, bool):
        raise ValueError(f"{name} must be a whole number")
    if abs(value) > MAX_ID:
        raise ValueError(f"{name} must be at most {MAX_ID} in size, got {value}")
    return value


def _number(body: dict, name: str) -> float:
    value = body.get(name)
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite number")
    return float(value)


def _click(server: AnnotateServer, body: dict) -> dict:
    frame = server.frame_of(body)
    x, y = server.position_of(body)
    return {"selected": server.session.click(_whole(body, "selected", optional=True), frame, x, y, reassign=body.get("reassign") is True)}


# Each action changes the session and returns what the page should know besides the new state;
# every number is checked as the readers of the session's files check it, so that `correct` and
# `render` take whatever the session writes.
_ACTIONS = {
    "/api/click": _click,
    "/api/split": lambda server, body: {"selected": server.session.split(_whole(body, "track"), server.frame_of(body))},
    "/api/delete": lambda server, body: server.session.delete(_whole(body, "track"), server.frame_of(body) if "frame" in body else None) or {},
    "/api/undo": lambda server, body: {"changed": server.session.undo()},
    "/api/redo": lambda server, body: {"changed": server.session.redo()},
    "/api/export": lambda server, body: {"exported": [path.name for path in server.session.export()]},
}
