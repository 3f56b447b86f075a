"""Resumable HTTP download with a short connect timeout and no retry loop.

A download writes ``<file>.part`` and continues it with an HTTP ``Range`` request when
it already exists (server answers 206; a 200 restarts from zero).  Directories are
created only once the server has answered, so an offline machine fails at once
(within ``timeout_s``) without leaving anything behind.
"""

from __future__ import annotations

import os
import socket
import threading
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from data_recipes.local import sha256_of
from scenesim.errors import DataError

#: Seconds to wait for a connection / a read before giving up.
DEFAULT_TIMEOUT_S = 5.0

_CHUNK = 1 << 16


class DownloadError(DataError):
    """A file could not be fetched; ``.connect_failed`` tells whether any byte was received."""

    def __init__(self, message: str, *, url: str = "", connect_failed: bool = True):
        self.url = url
        self.connect_failed = connect_failed
        super().__init__(message)

    def __reduce__(self):
        return (_rebuild_download_error, (str(self), self.url, self.connect_failed))


def _rebuild_download_error(message, url, connect_failed):
    return DownloadError(message, url=url, connect_failed=connect_failed)


def cache_dir() -> Path:
    """``$SCENESIM_CACHE`` if set, else ``~/.cache/scenesim``."""
    env = os.environ.get("SCENESIM_CACHE", "").strip()
    return Path(env).expanduser() if env else Path.home() / ".cache" / "scenesim"


def fetch(url: str, dest: Path, *, timeout_s: float = DEFAULT_TIMEOUT_S) -> str:
    """Download ``url`` to ``dest`` (resuming ``dest.part``); return the file's SHA-256.

    Raises
    ------
    DownloadError
        On any network or HTTP failure (no retries).  A ``.part`` file that received
        bytes is kept so that the next call resumes it; an empty one is removed.
    """
    dest = Path(dest)
    part = dest.with_name(dest.name + ".part")
    have = part.stat().st_size if part.exists() else 0
    headers = {"User-Agent": "scenesim-data-recipes"}
    if have:
        headers["Range"] = f"bytes={have}-"
    request = urllib.request.Request(url, headers=headers)
    _resolve_or_fail(url, timeout_s)
    try:
        response = urllib.request.urlopen(request, timeout=timeout_s)  # noqa: S310 (http(s) only)
    except urllib.error.HTTPError as exc:
        if exc.code == 416 and have:  # range beyond the end: the .part is already complete
            part.replace(dest)
            return sha256_of(dest)
        raise DownloadError(f"HTTP {exc.code} for {url}", url=url) from exc
    except (urllib.error.URLError, OSError, ValueError) as exc:
        reason = getattr(exc, "reason", exc)
        raise DownloadError(f"cannot connect to {url} ({reason})", url=url) from exc
    received = 0
    try:
        with response:
            append = have and response.status == 206
            dest.parent.mkdir(parents=True, exist_ok=True)
            with open(part, "ab" if append else "wb") as fh:
                while True:
                    chunk = response.read(_CHUNK)
                    if not chunk:
                        break
                    fh.write(chunk)
                    received += len(chunk)
    except (OSError, urllib.error.URLError) as exc:
        if part.exists() and part.stat().st_size == 0:
            part.unlink()
        raise DownloadError(
            f"download of {url} interrupted after {received} bytes ({exc}); run again to resume",
            url=url,
            connect_failed=False,
        ) from exc
    part.replace(dest)
    return sha256_of(dest)



def _resolve_or_fail(url: str, timeout_s: float) -> None:
    """Resolve the URL's host within ``timeout_s`` (``urlopen``'s timeout does not cover DNS).

    The lookup runs in a daemon thread so that a hanging resolver on an offline machine
    cannot delay the error beyond the timeout.
    """
    host = urllib.parse.urlsplit(url).hostname
    if not host:
        raise DownloadError(f"cannot download {url!r}: no host in the URL", url=url)
    outcome: dict = {}

    def lookup():
        try:
            outcome["ok"] = socket.getaddrinfo(host, None)
        except OSError as exc:
            outcome["error"] = exc

    worker = threading.Thread(target=lookup, daemon=True)
    worker.start()
    worker.join(timeout_s)
    if "ok" in outcome:
        return
    reason = outcome.get("error", f"DNS lookup of {host} timed out after {timeout_s:g} s")
    raise DownloadError(f"cannot connect to {url} ({reason})", url=url)
