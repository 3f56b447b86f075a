"""``scenesim listen`` (issue 35): P.835 and MUSHRA sessions driven in headless Chromium as a listener
would (play, rate, next), closed halfway and resumed; the ratings in the store equal those given.

Oracle: the values the test clicked and typed, keyed through the server's plan of the listener
(trial -> condition, system); the store must hold exactly those, one row per (listener,
condition, system, scale).  The server binds 127.0.0.1 on a free port and is shut down at the end.
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import threading
import urllib.error
import urllib.request

import numpy as np
import pytest
from headless_browser import BrowserPage, DevToolsPipe

from benchmarks.cli.main import main
from benchmarks.report.listen_server import ListeningTest, make_server, server_url
from benchmarks.report.listen_test import (
    ANCHOR,
    MIXTURE,
    P835_SCALES,
    REFERENCE,
    build_material,
    stimulus_token,
)
from benchmarks.run.runner import run_sweep
from benchmarks.store.sqlite import ResultStore


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """The smoke sweep on 2 conditions: clips of eb, ss, eb-ss (passthrough is the mixture)."""
    out = tmp_path_factory.mktemp("listen") / "run"
    run_sweep("smoke", out, workers=1, limit=2, report=False, progress=False, listen_count=2)
    return out




class _Serving:
    """A listening test served on 127.0.0.1 (free port) in a thread; stopped on exit."""

    def __init__(self, sweep, method):
        self.test = ListeningTest(build_material(sweep, method=method), sweep, seed=7)
        self.server = make_server(self.test, host="127.0.0.1", port=0)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.server.shutdown()
        self.server.server_close()
        self.thread.join(timeout=10)

    def url(self, listener):
        return f"{server_url(self.server)}?listener={listener}"

    def stored(self, listener):
        with ResultStore.open(self.test.store_dir, readonly=True) as store:
            return {(r["condition_id"], r["system"], r["scale"]): r["rating"] for r in store.ratings(listener)
                    if r["method"] == self.test.material.method}


def _next(page, trial):
    page.wait_for("window.pendingPosts === 0")
    page.click("#next")
    page.wait_for(f"document.body.dataset.view === 'done' || document.body.dataset.trial !== '{trial}'")


def _p835(page, plan, rng, given, *, stop=None):
    """Rate every trial from the one shown (only the scales not yet checked); True when stopped at ``stop``."""
    while page.wait_for("document.body.dataset.view") != "done":
        trial = int(page.evaluate("document.body.dataset.trial"))
        cid, (system,) = plan[trial].condition_id, plan[trial].systems
        page.click("#play")
        page.wait_for("!document.querySelector('#scale-sig').disabled")
        for scale in P835_SCALES:
            if (trial, scale) == stop:
                page.wait_for("window.pendingPosts === 0")
                return True
            if page.evaluate(f"document.querySelector('input[name={scale}]:checked') !== null"):
                continue
            value = int(rng.integers(1, 6))
            page.click(f"#{scale}-{value}")
            given[(cid, system, scale)] = value
        _next(page, trial)
    return False


def test_p835_session_closed_halfway_resumes_and_stores_what_was_given(sweep, chromium):
    rng, given = np.random.default_rng(1), {}
    with _Serving(sweep, "p835") as srv, DevToolsPipe(chromium) as browser:
        _, plan = srv.test.plan("ana")
        assert len(plan) == 2 * 5  # 2 conditions x (reference, mixture, eb, ss, eb-ss)
        page = BrowserPage(browser, srv.url("ana"))
        page.wait_for("document.body.dataset.view === 'training'")
        page.click(".train[data-i='0']")
        page.click("#start")
        assert _p835(page, plan, rng, given, stop=(4, "ovrl"))  # SIG and BAK of trial 4 given, then closed
        page.close()
        page = BrowserPage(browser, srv.url("ana"))
        assert page.wait_for("document.body.dataset.view") == "trial"  # no training again
        assert page.evaluate("document.body.dataset.trial") == "4"
        checked = page.evaluate("[...document.querySelectorAll('input:checked')].map(e => e.id)")
        cid, (system,) = plan[4].condition_id, plan[4].systems
        assert sorted(checked) == sorted(f"{s}-{given[(cid, system, s)]}" for s in ("sig", "bak"))
        assert not _p835(page, plan, rng, given)
        assert page.console_errors() == []
        stored = srv.stored("ana")
    assert stored == given and len(given) == 3 * len(plan)
    assert {s for _, s, _ in given} == {REFERENCE, MIXTURE, "eb", "ss", "eb-ss"}  # the hidden anchors are rated


def _mushra_page(page, plan, rng, given, *, stop_after=None):
    """Rate the stimuli of the page shown that have no score; True when stopped after ``stop_after`` of them."""
    trial = int(page.evaluate("document.body.dataset.trial"))
    page.click("#play-ref")
    rated = 0
    for i, system in enumerate(plan[trial].systems):
        if page.evaluate(f"document.querySelector('.score[data-i=\"{i}\"]').value") != "":
            continue
        page.click(f".play[data-i='{i}']")
        if i == 0:  # a slider moved by keyboard: clicked (a first value), then End -> 100
            page.click(f".slider[data-i='{i}']")
            page.press("End")
            value = 100
        else:
            value = int(rng.integers(0, 101))
            page.type_text(f".score[data-i='{i}']", str(value))
            page.click("#title")  # leaving the box commits it
        page.wait_for(f"document.querySelector('.score[data-i=\"{i}\"]').value === '{value}'")
        given[(plan[trial].condition_id, system, "mushra")] = value
        rated += 1
        if rated == stop_after:
            page.wait_for("window.pendingPosts === 0")
            return True
    _next(page, trial)
    return False


def test_mushra_session_closed_halfway_resumes_and_stores_what_was_given(sweep, chromium):
    rng, given = np.random.default_rng(2), {}
    with _Serving(sweep, "mushra") as srv, DevToolsPipe(chromium) as browser:
        _, plan = srv.test.plan("ana")
        assert len(plan) == 2 and all(len(t.systems) == 6 for t in plan)  # + hidden reference, anchor, mixture
        page = BrowserPage(browser, srv.url("ana"))
        page.wait_for("document.body.dataset.view === 'training'")
        page.click("#start")
        assert not _mushra_page(page, plan, rng, given)  # the first page complete
        assert _mushra_page(page, plan, rng, given, stop_after=3)  # half of the second, then closed
        page.close()
        page = BrowserPage(browser, srv.url("ana"))
        assert page.wait_for("document.body.dataset.view") == "trial" and page.evaluate("document.body.dataset.trial") == "1"
        boxes = page.evaluate("[...document.querySelectorAll('.score')].map(e => e.value)")
        assert boxes[:3] == [str(given[(plan[1].condition_id, s, "mushra")]) for s in plan[1].systems[:3]]
        assert boxes[3:] == ["", "", ""]
        while page.wait_for("document.body.dataset.view") != "done":
            _mushra_page(page, plan, rng, given)
        assert page.console_errors() == []
        stored = srv.stored("ana")
    assert stored == given and len(given) == 12
    assert {s for _, s, _ in given} == {REFERENCE, MIXTURE, ANCHOR, "eb", "ss", "eb-ss"}


@pytest.mark.parametrize("method", ["p835", "mushra"])
def test_a_second_listener_hears_another_order(sweep, method):
    test = ListeningTest(build_material(sweep, method=method), sweep, seed=7)
    first, second = ([(t.condition_id, t.systems) for t in test.plan(name)[1]] for name in ("ana", "ben"))
    assert sorted(first) != first or sorted(second) != second  # shuffled at all
    assert first != second
    again = ListeningTest(test.material, sweep, seed=7)
    assert [(t.condition_id, t.systems) for t in again.plan("ana")[1]] == first  # a function of name and seed


def _post(url, body):
    req = urllib.request.Request(url + "api/rating", data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json"})  # fmt: skip
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def test_the_server_refuses_ratings_outside_the_plan(sweep):
    with _Serving(sweep, "p835") as srv:
        url = server_url(srv.server)
        seed, plan = srv.test.plan("cy")
        tok = stimulus_token(seed, plan[0].condition_id, plan[0].systems[0])
        base = {"listener": "cy", "trial": 0, "stimulus": tok, "scale": "sig"}
        assert _post(url, {**base, "value": 6})[0] == 400
        assert _post(url, {**base, "value": 3, "scale": "mushra"})[0] == 400
        assert _post(url, {**base, "value": 3, "trial": 1})[0] == 400  # a stimulus of another trial
        assert _post(url, {**base, "value": 3, "listener": "<b>"})[0] == 400
        assert srv.stored("cy") == {}
        assert _post(url, {**base, "value": 3}) [0] == 200
        assert _post(url, {**base, "value": 4})[0] == 200  # changed: replaced, not duplicated
        assert srv.stored("cy") == {(plan[0].condition_id, plan[0].systems[0], "sig"): 4.0}
        with urllib.request.urlopen(url + "audio/" + tok, timeout=10) as r:
            assert r.read()[:4] in (b"OggS", b"RIFF")
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(url + "audio/..%2Fresults.sqlite", timeout=10)


def _one_line_error(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("scenesim: error:"), err
    return err


def test_listen_errors_are_one_line(sweep, tmp_path, capsys):
    assert "no results store" in _one_line_error(capsys, ["listen", str(tmp_path / "nowhere")])
    failed = tmp_path / "failed"  # a store whose only row failed: nothing to play
    with ResultStore.open(failed) as store:
        store.write_rows([{"condition_id": "c1", "enhancer": "eb", "status": "error", "error": "x"}])
    assert "no clips" in _one_line_error(capsys, ["listen", str(failed), "--port", "0"])
    with pytest.raises(SystemExit) as exit_:  # argparse's own refusal, naming the option
        main(["listen", str(sweep), "--count", "0"])
    assert exit_.value.code == 2 and "argument --count: expected an integer >= 1, got '0'" in capsys.readouterr().err
    assert "--systems" in _one_line_error(capsys, ["listen", str(sweep), "--systems", "nope"])
    assert "--conditions" in _one_line_error(capsys, ["listen", str(sweep), "--conditions", "nope"])
    assert "--listener" in _one_line_error(capsys, ["listen", str(sweep), "--listener", "../x"])
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert "--port" in _one_line_error(capsys, ["listen", str(sweep), "--port", str(port)])


def test_ctrl_c_stops_the_server_and_says_what_was_saved(sweep):
    proc = subprocess.Popen([sys.executable, "-m", "benchmarks.cli.main", "listen", str(sweep), "--port", "0",
                             "--listener", "dee"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        line = proc.stdout.readline()
        url = line[line.index("http://"):].split()[0]
        test = ListeningTest(build_material(sweep, method="p835"), sweep)  # the same plan as the server's
        seed, plan = test.plan("dee")
        tok = stimulus_token(seed, plan[0].condition_id, plan[0].systems[0])
        assert _post(url, {"listener": "dee", "trial": 0, "stimulus": tok, "scale": "bak", "value": 2})[0] == 200
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert "1 rating(s) saved this session" in out  # the module's other tests rated as other listeners
    assert re.search(r"from \d+ listener\(s\): (.+, )?dee(,|$)", out.strip()), out
