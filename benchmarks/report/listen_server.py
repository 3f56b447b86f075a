"""The local server of ``scenesim listen``: the test page, its audio and one POST per rating.

Standard library only (:class:`http.server.ThreadingHTTPServer`).  Routes:

* ``GET /`` -- the page (:mod:`benchmarks.report.listen_page`); ``?listener=NAME`` names the listener
  (the page asks for a name when the server was not started with one);
* ``GET /api/plan?listener=NAME`` -- that listener's trials as opaque stimulus tokens, the training
  clips, and the ratings already stored (so a reopened page resumes where it stopped);
* ``GET /audio/TOKEN`` -- a clip by token (nothing else on disk is served);
* ``POST /api/rating`` -- JSON ``{listener, trial, stimulus, scale, value}``: checked against the
  listener's plan and written at once to the store's ``ratings`` table
  (:meth:`benchmarks.store.sqlite.ResultStore.write_rating`).
"""

from __future__ import annotations

import json
import mimetypes
import re
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from benchmarks.report.listen_test import (
    ANCHOR,
    MIXTURE,
    REFERENCE,
    Material,
    check_rating,
    plan_trials,
    session_seed,
    stimulus_token,
)
from scenesim.errors import ParameterError, ScenesimError

#: A listener's name: what the ratings table keys on (no path or markup characters).
_LISTENER = re.compile(r"^[\w][\w .@+-]{0,63}$")
_MAX_BODY = 4096


def check_listener(name) -> str:
    """``name`` stripped, if it is 1-64 letters, digits, spaces or ``_.@+-``; ParameterError otherwise.

    >>> check_listener(" ana ")
    'ana'
    """
    text = str(name).strip()
    if not _LISTENER.match(text):
        raise ParameterError("--listener", name, "1-64 letters, digits, spaces or _.@+- (starting with a letter or digit)")
    return text


class ListeningTest:
    """The state the server answers from: material, store, seed and each listener's plan.

    Parameters
    ----------
    material : Material
        The clips (:func:`benchmarks.report.listen_test.build_material`).
    store_dir : path
        Where ``results.sqlite`` is (ratings are written to its ``ratings`` table).
    seed : int
        Mixed with each listener's name into their order (:func:`session_seed`).
    listener : str, optional
        The only listener this server takes (the page does not ask for a name).
    """

    def __init__(self, material: Material, store_dir, *, seed: int = 0, listener: str | None = None):
        self.material, self.store_dir, self.seed = material, Path(store_dir), int(seed)
        self.listener = None if listener is None else check_listener(listener)
        self._lock = threading.Lock()
        self._plans: dict[str, tuple[int, list]] = {}
        self._tokens: dict[str, Path] = {}
        self.saved = 0

    def plan(self, listener: str) -> tuple[int, list]:
        """``(session seed, trials)`` of ``listener`` (memoised; registers their audio tokens)."""
        listener = check_listener(listener)
        if self.listener is not None and listener != self.listener:
            raise ParameterError("listener", listener, f"{self.listener!r} (this server's --listener)")
        with self._lock:
            if listener not in self._plans:
                seed = session_seed(listener, self.seed)
                self._plans[listener] = (seed, plan_trials(self.material, seed))
                for cid, files in self.material.clips.items():
                    for system, path in files.items():
                        self._tokens[stimulus_token(seed, cid, system)] = path
            return self._plans[listener]

    def audio(self, token: str) -> Path | None:
        with self._lock:
            return self._tokens.get(token)

    def _given(self, listener: str, seed: int, trials) -> dict[str, dict[str, dict[str, float]]]:
        from benchmarks.store.sqlite import ResultStore

        with ResultStore.open(self.store_dir) as store:
            stored = {(r["condition_id"], r["system"], r["scale"]): r["rating"] for r in store.ratings(listener)}
        given: dict[str, dict[str, dict[str, float]]] = {}
        for t in trials:
            for s in t.systems:
                for scale in self.material.scales:
                    if (t.condition_id, s, scale) in stored:
                        tok = stimulus_token(seed, t.condition_id, s)
                        given.setdefault(str(t.index), {}).setdefault(tok, {})[scale] = stored[(t.condition_id, s, scale)]
        return given

    def plan_json(self, listener: str) -> dict[str, Any]:
        """What the page needs for ``listener`` (no system names: tokens only)."""
        seed, trials = self.plan(listener)
        first = trials[0].condition_id
        labelled = [(REFERENCE, "Clean speech (reference)"), (MIXTURE, "Unprocessed noisy mixture")]
        if self.material.method == "mushra":
            labelled = [(REFERENCE, "Reference (rate its hidden copy 100)"), (ANCHOR, "Low-pass anchor (3.5 kHz)")]
        return {
            "method": self.material.method,
            "listener": check_listener(listener),
            "scales": list(self.material.scales),
            "training": [{"label": label, "token": stimulus_token(seed, first, s)} for s, label in labelled],
            "trials": [{"index": t.index, "reference": stimulus_token(seed, t.condition_id, REFERENCE),
                        "stimuli": [stimulus_token(seed, t.condition_id, s) for s in t.systems]} for t in trials],
            "given": self._given(listener, seed, trials),
        }  # fmt: skip

    def rate(self, body: dict[str, Any]) -> dict[str, Any]:
        """Check one rating against the listener's plan and write it; the row written."""
        seed, trials = self.plan(body.get("listener", ""))
        index = body.get("trial")
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(trials):
            raise ParameterError("trial", index, f"0..{len(trials) - 1}")
        trial = trials[index]
        systems = {stimulus_token(seed, trial.condition_id, s): s for s in trial.systems}
        if body.get("stimulus") not in systems:
            raise ParameterError("stimulus", body.get("stimulus"), f"a stimulus of trial {index}")
        row = {"listener": check_listener(body["listener"]), "method": self.material.method,
               "condition_id": trial.condition_id, "system": systems[body["stimulus"]],
               "scale": body.get("scale"), "trial": index, "session_seed": seed,
               "rating": check_rating(self.material.method, str(body.get("scale")), body.get("value"))}  # fmt: skip
        from benchmarks.store.sqlite import ResultStore

        with self._lock, ResultStore.open(self.store_dir) as store:
            store.write_rating(row)
            self.saved += 1
        return row


class _Handler(BaseHTTPRequestHandler):
    server: _Server

    def log_message(self, format, *args):  # noqa: A002 -- the base class's name
        pass  # one line per clip request would bury the console's summary

    def _send(self, code: int, body: bytes, ctype: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _json(self, code: int, obj) -> None:
        self._send(code, json.dumps(obj).encode(), "application/json")

    def do_GET(self):  # noqa: N802 -- http.server's name
        from benchmarks.report.listen_page import page_html

        url = urlsplit(self.path)
        query = {k: v[0] for k, v in parse_qs(url.query).items()}
        test = self.server.test
        try:
            if url.path == "/":
                return self._send(200, page_html(test.material.method, test.listener).encode(), "text/html; charset=utf-8")
            if url.path == "/api/plan":
                return self._json(200, test.plan_json(query.get("listener", test.listener or "")))
            path = test.audio(url.path[len("/audio/"):]) if url.path.startswith("/audio/") else None
            if path is None:
                return self._json(404, {"error": f"not found: {url.path}"})
            return self._send(200, path.read_bytes(), mimetypes.guess_type(path.name)[0] or "application/octet-stream")
        except ScenesimError as exc:
            return self._json(400, {"error": str(exc)})

    def do_POST(self):  # noqa: N802
        if urlsplit(self.path).path != "/api/rating":
            return self._json(404, {"error": f"not found: {self.path}"})
        try:
            n = int(self.headers.get("Content-Length") or 0)
            if not 0 < n <= _MAX_BODY:
                raise ParameterError("Content-Length", n, f"1..{_MAX_BODY}")
            body = json.loads(self.rfile.read(n))
            if not isinstance(body, dict):
                raise ParameterError("body", body, "a JSON object")
            return self._json(200, {"saved": self.server.test.rate(body)})
        except (ScenesimError, ValueError) as exc:
            return self._json(400, {"error": str(exc)})


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    test: ListeningTest

    def handle_error(self, request, client_address):
        import sys

        if not isinstance(sys.exc_info()[1], (BrokenPipeError, ConnectionResetError)):
            super().handle_error(request, client_address)
        # else: the page dropped a clip it no longer wants (another clip played, tab closed): no traceback


def make_server(test: ListeningTest, *, host: str = "127.0.0.1", port: int = 0) -> _Server:
    """A bound (not yet serving) server for ``test``; ``port`` 0 takes a free port.

    Raises ParameterError naming ``--port`` or ``--host`` when the address cannot be bound.
    """
    import errno

    try:
        server = _Server((host, port), _Handler)
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise ParameterError("--port", port, "a port no other program is using") from None
        raise ParameterError("--host", host, f"an address of this machine ({exc.strerror or exc})") from None
    server.test = test
    return server


def server_url(server: _Server) -> str:
    host, port = server.server_address[:2]
    return f"http://{host}:{port}/"


__all__ = ["ListeningTest", "check_listener", "make_server", "server_url"]
