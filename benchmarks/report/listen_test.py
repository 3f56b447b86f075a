"""A blind listening test from a sweep's stored clips (``scenesim listen DIR``): the material and each
listener's trials.

The clips are the report's (:func:`benchmarks.report.listening.build_listening`: the same picker,
the sweep's saved clips or a checked re-render, every clip of a condition matched to the same
active speech level), written under ``DIR/listening/audio``.  Systems whose output equals the
mixture (``passthrough``) are played once, as the mixture.  Two methods:

* ITU-T P.835 (2003): one trial per clip, three 5-point ratings in the order the Recommendation
  gives (SIG: the speech signal alone; BAK: the background alone; OVRL: overall).  The clean
  reference and the unprocessed mixture are rated as hidden anchors among the systems.
* MUSHRA, ITU-R BS.1534-3 (2015): one trial per condition, every stimulus of the condition on one
  page with a 0-100 slider: the systems, the mixture, the hidden reference and the low-pass anchor
  (the reference band-limited to 3.5 kHz, §5.1), beside the open (labelled) reference.

A listener's order is drawn from :func:`session_seed` (the listener's name and the ``--seed``):
P.835 trials are shuffled over all conditions, MUSHRA conditions and the stimuli within each page
are shuffled.  The page sees stimuli only as opaque tokens (:func:`stimulus_token`), never names.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenesim.errors import DataError, ParameterError

METHODS = ("p835", "mushra")
#: The P.835 scales, in the order they are rated.
P835_SCALES = ("sig", "bak", "ovrl")
MUSHRA_SCALE = "mushra"
#: Inclusive range of each scale (P.835: integers 1-5; MUSHRA: integers 0-100).
SCALE_RANGE = {"sig": (1, 5), "bak": (1, 5), "ovrl": (1, 5), MUSHRA_SCALE: (0, 100)}
#: Names of the hidden anchors in the ``ratings`` table (never enhancer names).
REFERENCE, MIXTURE, ANCHOR = "reference", "mixture", "anchor-lp3.5k"
#: BS.1534-3's low-pass anchor cut-off (Hz).
ANCHOR_CUTOFF_HZ = 3500.0
#: Folder of the store directory the test's clips go to.
TEST_DIRNAME = "listening"


@dataclass(frozen=True)
class Material:
    """What a test plays: per condition, each system's loudness-matched clip file.

    Attributes
    ----------
    method : str
        ``"p835"`` or ``"mushra"``.
    clips : mapping
        ``{condition_id: {system: Path}}`` (systems include the anchors of the method).
    labels : mapping
        ``{condition_id: condition in words}`` (shown on the training page only).
    notes : tuple of str
        What was left out and why.
    """

    method: str
    clips: Mapping[str, Mapping[str, Path]]
    labels: Mapping[str, str]
    notes: tuple[str, ...] = ()

    @property
    def scales(self) -> tuple[str, ...]:
        return P835_SCALES if self.method == "p835" else (MUSHRA_SCALE,)


@dataclass(frozen=True)
class Trial:
    """One page of the test: a condition and the systems it plays, in presentation order."""

    index: int
    condition_id: str
    systems: tuple[str, ...]


def lowpass(x: np.ndarray, fs: int, *, cutoff_hz: float = ANCHOR_CUTOFF_HZ) -> np.ndarray:
    """The MUSHRA low-pass anchor: ``x`` with every DFT bin above ``cutoff_hz`` set to zero.

    A zero-phase brick-wall over the whole clip (BS.1534-3 §5.1 asks for a 3.5 kHz low-pass
    version of the reference and fixes no filter); shape ``(n_samples,)`` or ``(..., n_samples)``.

    >>> fs = 16000; t = np.arange(fs) / fs
    >>> y = lowpass(np.sin(2 * np.pi * 1000 * t) + np.sin(2 * np.pi * 5000 * t), fs)
    >>> bool(np.allclose(y, np.sin(2 * np.pi * 1000 * t), atol=1e-9))
    True
    """
    x = np.asarray(x, dtype=np.float64)
    spec = np.fft.rfft(x, axis=-1)
    freqs = np.fft.rfftfreq(x.shape[-1], 1.0 / fs)
    spec[..., freqs > cutoff_hz] = 0.0
    return np.fft.irfft(spec, n=x.shape[-1], axis=-1)


def session_seed(listener: str, seed: int) -> int:
    """The seed of one listener's order: SHA-256 of the name and ``seed`` (63 bits).

    >>> session_seed("ana", 0) == session_seed("ana", 0) != session_seed("ben", 0)
    True
    """
    digest = hashlib.sha256(f"{listener}\0{int(seed)}".encode()).digest()
    return int.from_bytes(digest[:8], "big") >> 1


def stimulus_token(listener_seed: int, condition_id: str, system: str) -> str:
    """The opaque name a page sees for a stimulus (differs per listener)."""
    return hashlib.sha256(f"{listener_seed}\0{condition_id}\0{system}".encode()).hexdigest()[:16]


def plan_trials(material: Material, listener_seed: int) -> list[Trial]:
    """A listener's trials in order (see the module docstring).

    >>> m = Material("p835", {"c1": {"a": Path("a"), "b": Path("b")}, "c2": {"a": Path("c")}}, {})
    >>> sorted((t.condition_id, t.systems) for t in plan_trials(m, 1))
    [('c1', ('a',)), ('c1', ('b',)), ('c2', ('a',))]
    """
    rng = np.random.default_rng(listener_seed)
    conds = sorted(material.clips)
    if material.method == "p835":
        pairs = [(c, s) for c in conds for s in sorted(material.clips[c])]
        order = rng.permutation(len(pairs))
        return [Trial(i, pairs[k][0], (pairs[k][1],)) for i, k in enumerate(order)]
    trials = []
    for i, k in enumerate(rng.permutation(len(conds))):
        systems = sorted(material.clips[conds[k]])
        trials.append(Trial(i, conds[k], tuple(systems[j] for j in rng.permutation(len(systems)))))
    return trials


def check_rating(method: str, scale: str, value) -> int:
    """``value`` as an int on ``scale`` of ``method``; ParameterError otherwise.

    >>> check_rating("mushra", "mushra", 73)
    73
    """
    allowed = P835_SCALES if method == "p835" else (MUSHRA_SCALE,)
    if scale not in allowed:
        raise ParameterError("scale", scale, f"one of {', '.join(allowed)} for {method}")
    lo, hi = SCALE_RANGE[scale]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value) or not lo <= value <= hi:
        raise ParameterError(scale, value, f"an integer {lo}..{hi}")
    return int(value)


# -- building the material -----------------------------------------------------------------


def _store_rows(store_dir: Path) -> list[dict]:
    from benchmarks.store.sqlite import STORE_NAME, ResultStore

    if not (Path(store_dir) / STORE_NAME).is_file():
        raise DataError(f"no results store at {Path(store_dir) / STORE_NAME} (run scenesim bench run first)")
    with ResultStore.open(store_dir, readonly=True) as store:
        return store.rows()


def _check_choice(option: str, asked: Sequence[str], known: Sequence[str]) -> None:
    for name in asked:
        if name not in known:
            listed = ", ".join(sorted(known)[:12]) + (" ..." if len(known) > 12 else "")
            raise ParameterError(option, name, f"one of the store's: {listed}")


def _system_of(clip) -> str:
    return {"reference": REFERENCE, "mixture": MIXTURE}.get(clip.role, clip.enhancer)


def _add_anchor(files: dict[str, Path]) -> None:
    """Write the low-pass anchor beside the (matched) reference clip, from that clip."""
    import soundfile as sf

    ref = files[REFERENCE]
    x, fs = sf.read(str(ref), dtype="float64")
    path = ref.with_name(ref.name.replace("_reference.", "_anchor-lp3.5k."))
    info = sf.info(str(ref))
    sf.write(str(path), np.clip(lowpass(x, fs), -1.0, 1.0), fs, format=info.format, subtype=info.subtype)
    files[ANCHOR] = path


def build_material(
    store_dir, *, method: str = "p835", conditions: Sequence[str] = (), systems: Sequence[str] = (),
    count: int | None = None,
) -> Material:
    """The clips of a test of ``method`` from the store in ``store_dir`` (written under
    ``store_dir/listening/audio``).

    Parameters
    ----------
    store_dir : path
        A sweep's output folder (``results.sqlite`` and its saved clips).
    method : {"p835", "mushra"}
    conditions : sequence of str
        Condition ids (default: the report's picker, :func:`~benchmarks.report.listening.choose_conditions`).
    systems : sequence of str
        Enhancers to rate (default: every one of the condition's ok rows); the anchors are always played.
    count : int, optional
        How many conditions the picker chooses (default :data:`~benchmarks.run.listen.DEFAULT_LISTEN_COUNT`).
    """
    from benchmarks.report.listening import DEFAULT_LISTEN_COUNT, ListenOptions, build_listening

    if method not in METHODS:
        raise ParameterError("--method", method, "p835 or mushra")
    rows = _store_rows(Path(store_dir))
    ok = [r for r in rows if r.get("status") == "ok"]
    _check_choice("--conditions", conditions, sorted({str(r["condition_id"]) for r in ok}))
    _check_choice("--systems", systems, sorted({str(r["enhancer"]) for r in ok}))
    options = ListenOptions(tuple(conditions), count=DEFAULT_LISTEN_COUNT if count is None else count)
    page = build_listening(rows, Path(store_dir) / TEST_DIRNAME, Path(store_dir), options)
    clips, labels, notes = {}, {}, list(page.notes)
    for cond in page.conditions:
        files = {_system_of(c): Path(store_dir) / TEST_DIRNAME / c.path for c in cond.clips if c.path}
        files = {s: p for s, p in files.items() if s in (REFERENCE, MIXTURE) or not systems or s in systems}
        notes += [f"{cond.condition_id}: {n}" for n in cond.notes]
        if len(files) <= 2:  # nothing but the anchors: no system to rate here
            continue
        if method == "mushra":
            _add_anchor(files)
        clips[cond.condition_id], labels[cond.condition_id] = files, cond.label
    if not clips:
        raise DataError(f"no clips of any system to play from {store_dir}: " + ("; ".join(notes) or "none chosen"))
    return Material(method, clips, labels, tuple(notes))


__all__ = [
    "ANCHOR",
    "ANCHOR_CUTOFF_HZ",
    "METHODS",
    "MIXTURE",
    "MUSHRA_SCALE",
    "P835_SCALES",
    "REFERENCE",
    "SCALE_RANGE",
    "TEST_DIRNAME",
    "Material",
    "Trial",
    "build_material",
    "check_rating",
    "lowpass",
    "plan_trials",
    "session_seed",
    "stimulus_token",
]
