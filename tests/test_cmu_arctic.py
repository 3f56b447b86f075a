"""The ``cmu-arctic`` recipe: fails fast offline without leftovers; resumes a .part over HTTP Range.

No test sends traffic beyond the loopback interface: the "offline" site is a closed
port on 127.0.0.1 and the resume test runs its own tiny HTTP server on 127.0.0.1.
"""

from __future__ import annotations

import hashlib
import http.server
import json
import threading
import time

import pytest

import data_recipes.registry as registry
from data_recipes.cmu_arctic import prepare_cmu_arctic
from scenesim.errors import DataError, ParameterError

CLOSED = "http://127.0.0.1:9/"  # discard port, nothing listens: connection refused at once


def test_offline_fails_fast_with_local_folder_hint_and_no_cache(tmp_path):
    dest = tmp_path / "cache" / "cmu"
    start = time.monotonic()
    with pytest.raises(DataError) as info:
        registry.prepare("cmu-arctic", dest, talkers=("bdl", "slt"), base_url=CLOSED, timeout_s=5.0)
    elapsed = time.monotonic() - start
    assert elapsed < 15.0  # one attempt with a 5 s connect timeout, no retry loop
    message = str(info.value)
    assert "--data-dir" in message and "SCENESIM_DATA" in message and "speech/" in message
    assert not dest.exists()  # nothing left behind


def test_offline_leaves_a_preexisting_empty_dest_empty(tmp_path):
    with pytest.raises(DataError):
        prepare_cmu_arctic(tmp_path, base_url=CLOSED)
    assert list(tmp_path.iterdir()) == []


class _RangeHandler(http.server.BaseHTTPRequestHandler):
    """Serves ``files`` (path -> bytes) and honours ``Range: bytes=N-`` with 206."""

    files: dict = {}
    ranges: list = []

    def do_GET(self):  # noqa: N802 (http.server API)
        body = self.files.get(self.path)
        if body is None:
            self.send_error(404)
            return
        rng = self.headers.get("Range")
        self.ranges.append(rng)
        if rng:
            start = int(rng.split("=")[1].rstrip("-"))
            self.send_response(206)
            body = body[start:]
        else:
            self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def local_server():
    server = http.server.HTTPServer(("127.0.0.1", 0), _RangeHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


def test_download_resumes_part_file_and_records_sha256(tmp_path, local_server):
    payload = bytes(range(256)) * 40
    _RangeHandler.files = {"/cmu_us_slt_arctic/wav/arctic_a0001.wav": payload}
    _RangeHandler.ranges = []
    part = tmp_path / "speech" / "cmu_arctic_us_slt_a0001.wav.part"
    part.parent.mkdir(parents=True)
    part.write_bytes(payload[:1000])
    manifest = prepare_cmu_arctic(tmp_path, talkers=("slt",), utterances=("a0001",), base_url=local_server)
    out = tmp_path / "speech" / "cmu_arctic_us_slt_a0001.wav"
    assert out.read_bytes() == payload
    assert _RangeHandler.ranges == ["bytes=1000-"]
    assert not part.exists()
    # Oracle: hashlib over the served bytes.
    assert manifest["files"][0]["sha256"] == hashlib.sha256(payload).hexdigest()
    assert json.loads((tmp_path / "manifest.json").read_text())["files"] == manifest["files"]
    # A second run finds the file complete (sha256 matches the manifest): no request.
    prepare_cmu_arctic(tmp_path, talkers=("slt",), utterances=("a0001",), base_url=local_server)
    assert _RangeHandler.ranges == ["bytes=1000-"]


def test_bad_talker_and_utterance_name_the_parameter(tmp_path):
    with pytest.raises(ParameterError, match="talkers"):
        prepare_cmu_arctic(tmp_path, talkers=("zzz",), base_url=CLOSED)
    with pytest.raises(ParameterError, match="utterances"):
        prepare_cmu_arctic(tmp_path, utterances=("0001",), base_url=CLOSED)
