"""Drive the distribution's headless Chromium from tests, with no Python dependency.

Chromium is started with ``--remote-debugging-pipe``: it reads DevTools-protocol commands
(JSON, each terminated by a NUL byte) from file descriptor 3 and writes replies and events
to descriptor 4.  :func:`inspect_page` opens one page in a fresh profile, waits for its load
event, runs a script that waits for every ``<audio>`` element's metadata and reads every
``<img>``'s ``naturalWidth``, collects console errors (``console.error``, uncaught
exceptions, and log entries such as a failed resource load), checks that every in-page
link (``href="#..."``) has its target, and takes a full-page screenshot.  Used by tests/test_html_report.py; skipped there when Chromium is absent.
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")

#: Flags that work in containers without a display, a GPU or a network (see the brief).
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--mute-audio",
    "--window-size=1300,1000",
)

# Runs in the page: waits (<= timeout) for each audio element's metadata or error.
_PROBE_JS = """
(async (timeoutMs) => {
  const wait = (a) => new Promise((resolve) => {
    if (a.readyState >= 1 || a.error) { resolve(); return; }
    const done = () => resolve();
    a.addEventListener('loadedmetadata', done, {once: true});
    a.addEventListener('error', done, {once: true});
    setTimeout(done, timeoutMs);
    a.load();
  });
  const audios = Array.from(document.querySelectorAll('audio'));
  await Promise.all(audios.map(wait));
  return {
    audio: audios.map((a) => ({src: a.currentSrc || a.getAttribute('src'),
                               attr: a.getAttribute('src'),
                               duration: isFinite(a.duration) ? a.duration : null,
                               expected: parseFloat(a.dataset.durationS),
                               error: a.error ? a.error.code : null,
                               readyState: a.readyState})),
    images: Array.from(document.images).map((i) => ({src: i.getAttribute('src'),
                                                     complete: i.complete,
                                                     naturalWidth: i.naturalWidth})),
    links: Array.from(document.querySelectorAll('a[href^="#"]')).map((a) => ({
      href: a.getAttribute('href'),
      resolves: document.getElementById(decodeURIComponent(a.getAttribute('href').slice(1))) !== null})),
  };
})
"""


def find_chromium() -> str | None:
    """Path of a Chromium binary (``$SCENESIM_CHROMIUM`` first), or None."""
    env = os.environ.get("SCENESIM_CHROMIUM")
    if env:
        return env if os.path.exists(env) else None
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


@dataclass
class PageReport:
    """What the browser saw on one page."""

    console_errors: list[str] = field(default_factory=list)
    audio: list[dict] = field(default_factory=list)
    images: list[dict] = field(default_factory=list)
    links: list[dict] = field(default_factory=list)
    screenshot_png: bytes = b""


class DevToolsPipe:
    """A Chromium process and its DevTools pipe (use as a context manager)."""

    def __init__(self, binary: str, *, timeout_s: float = 60.0):
        self.timeout_s = timeout_s
        self._profile = tempfile.mkdtemp(prefix="scenesim-chromium-")
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()

        # A small Python trampoline puts our pipe ends at fds 3 and 4 and execs the browser
        # (no preexec_fn, unsafe in a process with threads; no shell, whose redirections
        # only reach fds 0-9).  Copies first, as an end may already sit at 3 or 4; then 3
        # and 4 are made inheritable (a dup2 onto itself would keep close-on-exec).
        trampoline = (
            "import os, sys; r, w = (os.dup(int(a)) for a in sys.argv[1:3]); "
            "os.dup2(r, 3); os.dup2(w, 4); os.set_inheritable(3, True); os.set_inheritable(4, True); "
            "os.execv(sys.argv[3], sys.argv[3:])"
        )
        args = [binary, *FLAGS, f"--user-data-dir={self._profile}", "--remote-debugging-pipe", "about:blank"]
        self.proc = subprocess.Popen(
            [sys.executable, "-c", trampoline, str(to_browser_r), str(from_browser_w), *args],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            pass_fds=(to_browser_r, from_browser_w),
        )
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._buf = b""
        self._next_id = 0
        self.events: list[dict] = []

    def __enter__(self) -> DevToolsPipe:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send("Browser.close", timeout_s=10.0)
            except Exception:
                pass
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        for fd in (self._to_browser, self._from_browser):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self._profile, ignore_errors=True)

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no reply from Chromium's DevTools pipe")
            ready, _, _ = select.select([self._from_browser], [], [], left)
            if ready:
                chunk = os.read(self._from_browser, 1 << 20)
                if not chunk:
                    raise ConnectionError("Chromium closed its DevTools pipe")
                self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method: str, params: dict | None = None, *, session: str | None = None,
             timeout_s: float | None = None) -> dict:
        """Send one command and return its ``result`` (events seen meanwhile go to ``events``)."""
        self._next_id += 1
        msg = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._to_browser, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while True:
            reply = self._read_message(deadline)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method: str, *, timeout_s: float | None = None) -> dict:
        """The first event ``method`` (already received or arriving within the timeout)."""
        for ev in self.events:
            if ev.get("method") == method:
                return ev
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while True:
            ev = self._read_message(deadline)
            self.events.append(ev)
            if ev.get("method") == method:
                return ev


def _console_errors(events: list[dict]) -> list[str]:
    out = []
    for ev in events:
        method, p = ev.get("method"), ev.get("params", {})
        if method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            out.append("console." + p["type"] + ": " + " ".join(str(a.get("value", a.get("description"))) for a in p.get("args", [])))
        elif method == "Runtime.exceptionThrown":
            out.append("exception: " + json.dumps(p.get("exceptionDetails", {}))[:500])
        elif method == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            e = p["entry"]
            out.append(f"log ({e.get('source')}): {e.get('text')} {e.get('url', '')}")
    return out


def inspect_page(url: str, *, binary: str, media_timeout_s: float = 20.0) -> PageReport:
    """Load ``url`` in headless Chromium; console errors, audio/image states and a screenshot."""
    with DevToolsPipe(binary) as b:
        target = b.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = b.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Page"):
            b.send(f"{domain}.enable", session=session)
        b.events.clear()
        b.send("Page.navigate", {"url": url}, session=session)
        b.wait_event("Page.loadEventFired")
        probe = b.send(
            "Runtime.evaluate",
            {"expression": f"{_PROBE_JS}({int(media_timeout_s * 1000)})", "awaitPromise": True,
             "returnByValue": True},
            session=session,
            timeout_s=media_timeout_s + 30.0,
        )
        if "exceptionDetails" in probe:
            raise RuntimeError(f"probe script failed: {probe['exceptionDetails']}")
        value = probe["result"]["value"]
        size = b.send("Page.getLayoutMetrics", session=session)["cssContentSize"]
        shot = b.send(
            "Page.captureScreenshot",
            {"format": "png", "captureBeyondViewport": True,
             "clip": {"x": 0, "y": 0, "width": size["width"], "height": size["height"], "scale": 1}},
            session=session,
        )
        return PageReport(
            console_errors=_console_errors(b.events),
            audio=value["audio"],
            images=value["images"],
            links=value["links"],
            screenshot_png=base64.b64decode(shot["data"]),
        )


class BrowserPage:
    """One tab of a :class:`DevToolsPipe`, driven as a user would: real mouse clicks and typing
    (``Input.dispatchMouseEvent`` / ``Input.insertText`` / ``Input.dispatchKeyEvent``), waits on
    page state through ``Runtime.evaluate``.  Used by tests/test_listen_browser.py."""

    #: DevTools key events of the keys the tests press (``windowsVirtualKeyCode`` as Chromium expects).
    KEYS = {"End": 35, "Home": 36, "Tab": 9, "Enter": 13}

    def __init__(self, browser: DevToolsPipe, url: str):
        self.browser = browser
        self.target = browser.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = browser.send("Target.attachToTarget", {"targetId": self.target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Page"):
            browser.send(f"{domain}.enable", session=self.session)
        browser.events.clear()
        browser.send("Page.navigate", {"url": url}, session=self.session)
        browser.wait_event("Page.loadEventFired")

    def evaluate(self, expression: str, *, timeout_s: float = 30.0):
        """The value of ``expression`` in the page (promises awaited); RuntimeError on an exception."""
        reply = self.browser.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                                       "returnByValue": True}, session=self.session,
                                  timeout_s=timeout_s)  # fmt: skip
        if "exceptionDetails" in reply:
            raise RuntimeError(f"{expression!r} failed: {reply['exceptionDetails']}")
        return reply["result"].get("value")

    def wait_for(self, expression: str, *, timeout_s: float = 20.0):
        """Poll ``expression`` until it is truthy; its value.  TimeoutError naming it otherwise."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            value = self.evaluate(expression)
            if value:
                return value
            time.sleep(0.05)
        raise TimeoutError(f"page never satisfied {expression!r}")

    def click(self, selector: str) -> None:
        """A left click at the centre of the first element matching ``selector`` (scrolled into view)."""
        box = self.wait_for(
            f"(() => {{ const e = document.querySelector({json.dumps(selector)}); if (!e) return null;"
            " e.scrollIntoView({block: 'center'}); const r = e.getBoundingClientRect();"
            " return {x: r.left + r.width / 2, y: r.top + r.height / 2}; })()"
        )
        for kind in ("mousePressed", "mouseReleased"):
            self.browser.send("Input.dispatchMouseEvent", {"type": kind, "x": box["x"], "y": box["y"],
                                                           "button": "left", "clickCount": 1},
                              session=self.session)  # fmt: skip

    def type_text(self, selector: str, text: str) -> None:
        """Click into ``selector``, select what it holds and type ``text`` over it."""
        self.click(selector)
        self.evaluate(f"document.querySelector({json.dumps(selector)}).select()")
        self.browser.send("Input.insertText", {"text": text}, session=self.session)

    def press(self, key: str) -> None:
        """Press and release ``key`` (a name of :data:`KEYS`) in the focused element."""
        code = self.KEYS[key]
        for kind in ("rawKeyDown", "keyUp"):
            self.browser.send("Input.dispatchKeyEvent", {"type": kind, "key": key, "code": key,
                                                         "windowsVirtualKeyCode": code},
                              session=self.session)  # fmt: skip

    def close(self) -> None:
        """Close the tab (as a listener closing it)."""
        self.browser.send("Target.closeTarget", {"targetId": self.target})

    def console_errors(self) -> list[str]:
        return _console_errors(self.browser.events)
