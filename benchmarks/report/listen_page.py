"""The page of ``scenesim listen``: one HTML document with its script, no external resources.

Views, in order: a name form (when the server has no ``--listener``), a training page (the labelled
extremes of the scales; skipped once any rating is stored), the trials, and a closing page.  A P.835
trial plays one clip and asks SIG, then BAK, then OVRL (5-point radio scales, P.835 Table 1-3's
wording), enabled once the clip has started playing.  A MUSHRA trial shows the open reference and
every stimulus of the condition with a 0-100 slider and its number box.  Every rating is POSTed as
it is given; ``window.pendingPosts`` counts requests in flight.  The "Next" button is enabled when
every scale of every stimulus of the trial is rated.
"""

from __future__ import annotations

import html
import json

#: P.835's category labels, 5 to 1 (ITU-T P.835 (2003), Tables 1-3).
P835_LABELS = {
    "sig": ("SIGNAL: attending ONLY to the SPEECH, the speech sounds",
            ["not distorted", "slightly distorted", "somewhat distorted", "fairly distorted", "very distorted"]),
    "bak": ("BACKGROUND: attending ONLY to the BACKGROUND, it is",
            ["not noticeable", "slightly noticeable", "noticeable but not intrusive", "somewhat intrusive",
             "very intrusive"]),
    "ovrl": ("OVERALL: the SPEECH and BACKGROUND together are",
             ["excellent", "good", "fair", "poor", "bad"]),
}  # fmt: skip

_CSS = """
body { font-family: sans-serif; max-width: 900px; margin: 1.5em auto; padding: 0 1em; color: #222; }
button { font-size: 1em; padding: 0.3em 0.9em; margin: 0.2em; }
fieldset { margin: 0.6em 0; } fieldset:disabled { opacity: 0.5; }
label { display: inline-block; margin-right: 0.8em; }
.stim { display: flex; align-items: center; gap: 0.8em; margin: 0.3em 0; }
.stim input[type=range] { width: 320px; } .stim input[type=number] { width: 4em; }
#status { color: #555; font-size: 0.9em; }
"""

_SCRIPT = r"""
const CFG = JSON.parse(document.getElementById('cfg').textContent);
const $ = (sel) => document.querySelector(sel);
const main = $('#main');
window.pendingPosts = 0;
let plan = null, current = 0;
const audio = new Audio();
const listener = CFG.listener || new URLSearchParams(location.search).get('listener');

function el(tag, attrs = {}, ...kids) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k.startsWith('on')) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
  }
  for (const k of kids) e.append(k);
  return e;
}
function play(token, onplaying) {
  audio.pause();
  audio.src = '/audio/' + token;
  if (onplaying) audio.addEventListener('playing', onplaying, {once: true});
  audio.play().catch((err) => { $('#status').textContent = 'cannot play: ' + err; });
}
function given(trial) { return plan.given[String(trial)] || (plan.given[String(trial)] = {}); }
function complete(t) {
  const g = given(t.index);
  return t.stimuli.every((s) => plan.scales.every((sc) => g[s] && g[s][sc] !== undefined));
}
// One chain of requests: the threaded server could store two quick changes of one rating in either
// order (a slider clicked, then moved), so each request waits for the one before it.
let posting = Promise.resolve();
async function send(t, stimulus, scale, value) {
  try {
    const r = await fetch('/api/rating', {method: 'POST', headers: {'Content-Type': 'application/json'},
      body: JSON.stringify({listener: plan.listener, trial: t.index, stimulus, scale, value})});
    const reply = await r.json();
    $('#status').textContent = r.ok ? 'saved' : ('not saved: ' + reply.error);
  } catch (err) {
    $('#status').textContent = 'not saved (server gone?): ' + err;
  } finally { window.pendingPosts--; }
}
async function rate(t, stimulus, scale, value) {
  const g = given(t.index);
  (g[stimulus] || (g[stimulus] = {}))[scale] = value;
  window.pendingPosts++;
  posting = posting.then(() => send(t, stimulus, scale, value));
  await posting;
  $('#next').disabled = !complete(t);
}
function askName() {
  const input = el('input', {id: 'name', type: 'text', placeholder: 'your name'});
  main.replaceChildren(el('p', {}, 'Your name (it keys your ratings; use the same one to resume):'), input,
    el('button', {id: 'go', onclick: () => { location.search = '?listener=' + encodeURIComponent(input.value); }}, 'Start'));
}
function training() {
  const intro = CFG.method === 'p835'
    ? 'Each clip is rated three times: the speech alone (SIG), the background alone (BAK), then both (OVRL). These two clips mark the ends of the scales.'
    : 'Each page plays the reference and several versions of it: rate each 0-100 against the reference. One version is the reference itself; these two clips mark the ends of the scale.';
  main.replaceChildren(el('h2', {id: 'title'}, 'Training'), el('p', {}, intro),
    ...plan.training.map((c, i) => el('p', {}, el('button', {class: 'train', 'data-i': i, onclick: () => play(c.token)}, 'Play'), ' ' + c.label)),
    el('button', {id: 'start', onclick: () => show(0)}, 'Start the test'));
}
function p835Trial(t) {
  const s = t.stimuli[0], g = given(t.index)[s] || {};
  const sets = plan.scales.map((sc) => {
    const [q, words] = CFG.labels[sc];
    const fs = el('fieldset', {id: 'scale-' + sc}, el('legend', {}, q));
    words.forEach((w, k) => {
      const v = 5 - k;
      const radio = el('input', {type: 'radio', name: sc, value: v, id: sc + '-' + v, onchange: () => rate(t, s, sc, v)});
      if (g[sc] === v) radio.checked = true;
      fs.append(el('label', {for: sc + '-' + v}, radio, ` ${v} ${w}`));
    });
    fs.disabled = Object.keys(g).length === 0;
    return fs;
  });
  const enable = () => sets.forEach((f) => { f.disabled = false; });
  return [el('p', {}, el('button', {id: 'play', onclick: () => play(s, enable)}, 'Play')), ...sets];
}
function mushraTrial(t) {
  const rows = t.stimuli.map((s, i) => {
    const v = (given(t.index)[s] || {}).mushra;
    const slider = el('input', {type: 'range', min: 0, max: 100, step: 1, class: 'slider', 'data-i': i, value: v ?? 0});
    const box = el('input', {type: 'number', min: 0, max: 100, step: 1, class: 'score', 'data-i': i, value: v ?? ''});
    const commit = (src) => {
      const value = Math.round(Number(src.value));
      if (src.value === '' || !(value >= 0 && value <= 100)) return;
      slider.value = value; box.value = value;
      rate(t, s, 'mushra', value);
    };
    slider.addEventListener('input', () => { box.value = slider.value; });
    slider.addEventListener('change', () => commit(slider));
    box.addEventListener('change', () => commit(box));
    return el('div', {class: 'stim'}, el('button', {class: 'play', 'data-i': i, onclick: () => play(s)}, 'Play ' + String.fromCharCode(65 + i)), slider, box);
  });
  return [el('p', {}, el('button', {id: 'play-ref', onclick: () => play(t.reference)}, 'Play reference')), ...rows];
}
function show(k) {
  audio.pause();
  current = k;
  if (k >= plan.trials.length) {
    document.body.dataset.view = 'done';
    main.replaceChildren(el('h2', {id: 'done'}, 'Done: thank you. Every rating is saved; you may close this page.'));
    return;
  }
  const t = plan.trials[k];
  document.body.dataset.view = 'trial';
  document.body.dataset.trial = String(t.index);
  const next = el('button', {id: 'next', onclick: () => show(k + 1)}, k + 1 < plan.trials.length ? 'Next' : 'Finish');
  next.disabled = !complete(t);
  main.replaceChildren(el('h2', {id: 'title'}, `Trial ${k + 1} of ${plan.trials.length}`),
    ...(CFG.method === 'p835' ? p835Trial(t) : mushraTrial(t)), next);
}
async function start() {
  if (!listener) { document.body.dataset.view = 'name'; askName(); return; }
  const r = await fetch('/api/plan?listener=' + encodeURIComponent(listener));
  const reply = await r.json();
  if (!r.ok) { main.replaceChildren(el('p', {id: 'error'}, reply.error)); return; }
  plan = reply;
  const fresh = Object.keys(plan.given).length === 0;  // read before complete() adds empty entries
  const first = plan.trials.findIndex((t) => !complete(t));
  if (fresh) { document.body.dataset.view = 'training'; training(); }
  else show(first < 0 ? plan.trials.length : first);
}
start();
"""


def page_html(method: str, listener: str | None) -> str:
    """The test page for ``method`` (``"p835"`` or ``"mushra"``); ``listener`` fixed by the server or None.

    >>> "P.835" in page_html("p835", None) and "MUSHRA" not in page_html("p835", None)
    True
    """
    title = "Listening test (ITU-T P.835)" if method == "p835" else "Listening test (MUSHRA, ITU-R BS.1534)"
    labels = {k: [q, words] for k, (q, words) in P835_LABELS.items()}
    cfg = json.dumps({"method": method, "listener": listener, "labels": labels}).replace("</", "<\\/")
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>", '<div id="main"></div><p id="status"></p>',
        f'<script id="cfg" type="application/json">{cfg}</script>', f"<script>{_SCRIPT}</script>",
        "</body></html>", "",
    ])  # fmt: skip


__all__ = ["P835_LABELS", "page_html"]
