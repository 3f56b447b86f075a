"""A sweep's CPU time against its metric floor: what it costs beyond the metrics it must compute.

    python -m benchmarks.perf.sweep_floor [--preset phone --preset thesis] [--limit N]
        [--seeds K] [--duration S] [--runs R] [--data-dir DIR]

For each preset this runs ``bench run PRESET --workers 1 --no-report`` in this process (the
serial executor: every unit of work is timed here; CPU time of this process plus its
children) into a fresh store, after an untimed one-condition warm-up run that fills a fresh
disk cache (the per-machine warm-up arrays and rooms, as on a user's machine), and records every signal pair the
sweep hands to a metric (``benchmarks.metrics.speech.pesq_scores``, ``stoi_scores``, and
``benchmarks.metrics.srmr.srmr`` as the reverberation columns call it) to a temporary directory.
The recording's own CPU time is measured and subtracted.

The **metric floor** is then the CPU time of the libraries alone on exactly those signals:

* PESQ: the ``pesq`` package's C library (``cypesq``), narrow band and (at 16 kHz) wide band,
  on the arrays the package would pass it (normalised float32, prepared outside the timing);
* STOI: ``pystoi.stoi`` twice, ``extended=False`` and ``extended=True`` (pystoi as shipped);
* SRMR: :func:`benchmarks.metrics.srmr.srmr` after one warm-up call (its filter design is not floor).

It prints the sweep CPU, the floor and their ratio (target <= 1.3 for ``phone`` and
``thesis``), the median over ``--runs`` sweeps (the floor is measured once per recording).
``--limit``, ``--seeds`` and ``--duration`` shrink the sweep (the first N conditions, the
first K seeds, shorter signals); what was run is printed.  The machine's load average is
printed before each sweep: CPU time is robust to load, wall time is not.
"""

from __future__ import annotations

import os

# As the CLI does (benchmarks/cli/main.py), before numpy is imported: one BLAS thread, or a
# second thread spinning on a loaded machine counts as the sweep's CPU time.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402


def cpu_now() -> float:
    """CPU seconds (user + system) of this process and its waited-for children so far."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


class Recorder:
    """Wraps the metric entry points; saves each call's signals under ``root`` as ``.npz``."""

    def __init__(self, root: Path):
        self.root = root
        self.count = 0
        self.cpu = 0.0  # CPU spent recording, subtracted from the sweep's
        self._undo: list = []

    def _save(self, kind: str, **arrays) -> None:
        c0 = time.process_time()
        self.count += 1
        np.savez(self.root / f"{kind}-{self.count:06d}.npz", **arrays)
        self.cpu += time.process_time() - c0

    def _wrap(self, module, name: str, kind: str, pack) -> None:
        original = getattr(module, name)

        def wrapper(*args, **kwargs):
            self._save(kind, **pack(*args, **kwargs))
            return original(*args, **kwargs)

        setattr(module, name, wrapper)
        self._undo.append((module, name, original))

    def __enter__(self):
        from benchmarks.metrics import reverb as reverb_metrics
        from benchmarks.metrics import speech as metrics

        def pair(reference, degraded, *, fs):
            return {"ref": np.asarray(reference), "deg": np.asarray(degraded), "fs": np.asarray(fs)}

        def single(x, fs):
            return {"x": np.asarray(x), "fs": np.asarray(fs)}

        self._wrap(metrics, "pesq_scores", "pesq", pair)
        self._wrap(metrics, "stoi_scores", "stoi", pair)
        self._wrap(reverb_metrics, "srmr", "srmr", single)
        return self

    def __exit__(self, *exc):
        for module, name, original in reversed(self._undo):
            setattr(module, name, original)


def _pesq_floor(data) -> float:
    from pesq.cypesq import cypesq

    from scenesim.audio import resample

    fs = int(data["fs"])
    fs_pesq = 16000 if fs >= 16000 else 8000
    ref = resample(np.asarray(data["ref"], dtype=np.float64), fs, fs_pesq)
    deg = resample(np.asarray(data["deg"], dtype=np.float64), fs, fs_pesq)
    peak = max(np.max(np.abs(ref)), np.max(np.abs(deg)))
    r, d = (ref / peak).astype(np.float32), (deg / peak).astype(np.float32)
    c0 = time.process_time()
    for mode in (0, 1) if fs_pesq == 16000 else (0,):
        try:
            cypesq(fs_pesq, r, d, mode)
        except Exception:  # the sweep's call failed too (e.g. no utterance): its cost still counts
            pass
    return time.process_time() - c0


def _stoi_floor(data) -> float:
    import warnings

    from pystoi import stoi

    ref, deg, fs = np.asarray(data["ref"], dtype=np.float64), np.asarray(data["deg"], dtype=np.float64), int(data["fs"])
    c0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stoi(ref, deg, fs, extended=False)
        stoi(ref, deg, fs, extended=True)
    return time.process_time() - c0


def _srmr_floor(data) -> float:
    from benchmarks.metrics.srmr import srmr

    c0 = time.process_time()
    srmr(np.asarray(data["x"], dtype=np.float64), int(data["fs"]))
    return time.process_time() - c0


def metric_floor(root: Path) -> dict[str, float]:
    """CPU seconds of the libraries on every recorded call, per metric (see the module doc)."""
    floor = {"pesq": 0.0, "stoi": 0.0, "srmr": 0.0}
    timers = {"pesq": _pesq_floor, "stoi": _stoi_floor, "srmr": _srmr_floor}
    warmed = set()
    for path in sorted(root.glob("*.npz")):
        kind = path.name.split("-")[0]
        with np.load(path) as data:
            if kind not in warmed:  # imports and first-call set-up are not the floor
                timers[kind](data)
                warmed.add(kind)
            floor[kind] += timers[kind](data)
    return floor


def _sweep(preset: str, args, seeds):
    """The sweep as run: the preset with ``--seeds``/``--duration`` applied."""
    import dataclasses

    from benchmarks.run.sweep import load_sweep

    sweep = load_sweep(preset)
    axes = dict(sweep.axes)
    if seeds is not None:
        axes["seed"] = tuple(axes["seed"])[:seeds]
    if args.duration is not None:
        axes["duration_s"] = (float(args.duration),)
    return dataclasses.replace(sweep, axes=axes)


def sweep_cpu(preset: str, args, tmp: Path, run: int, record: bool) -> tuple[float, Path | None]:
    """CPU seconds of one serial sweep without its report (recording subtracted)."""
    from benchmarks.run.runner import run_sweep
    from scenesim.memo import clear_memory_cache

    out = tmp / f"{preset}-{run}"
    rec_dir = tmp / f"{preset}-{run}-signals" if record else None
    clear_memory_cache()  # the disk cache (warmed by measure()) stays, as on a user's machine
    sweep = _sweep(preset, args, args.seeds)
    print(f"  {preset} run {run + 1}: load average {os.getloadavg()[0]:.2f}", flush=True)
    if record:
        rec_dir.mkdir()
        rec = Recorder(rec_dir)
        c0 = cpu_now()
        with rec:
            run_sweep(sweep, out, workers=1, data_dir=args.data_dir, limit=args.limit, report=False, progress=False)
        return cpu_now() - c0 - rec.cpu, rec_dir
    c0 = cpu_now()
    run_sweep(sweep, out, workers=1, data_dir=args.data_dir, limit=args.limit, report=False, progress=False)
    return cpu_now() - c0, None


def measure(preset: str, args) -> dict:
    """Median sweep CPU over ``args.runs`` runs (the first one recorded) and its metric floor."""
    with tempfile.TemporaryDirectory(prefix="sweep-floor-") as tmp:
        tmp = Path(tmp)
        cpus, rec_dir = [], None
        os.environ["SCENESIM_CACHE"] = str(tmp / "cache")
        # Untimed warm-up (imports, the per-machine disk cache of warm-up arrays and rooms).
        from benchmarks.run.runner import run_sweep

        run_sweep(_sweep(preset, args, args.seeds), tmp / "warm-up", workers=1, data_dir=args.data_dir, limit=1,
                  report=False, progress=False)  # fmt: skip
        for run in range(args.runs):
            cpu, rec = sweep_cpu(preset, args, tmp, run, record=run == 0)
            rec_dir = rec or rec_dir
            cpus.append(cpu)
            print(f"    sweep CPU {cpu:.1f} s", flush=True)
        calls = len(list(rec_dir.glob("*.npz")))
        floor = metric_floor(rec_dir)
    total = sum(floor.values())
    return {"preset": preset, "cpu": statistics.median(cpus), "cpus": cpus, "floor": floor,
            "floor_total": total, "calls": calls}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", action="append", help="preset name or TOML (repeatable; default phone and thesis)")
    ap.add_argument("--limit", type=int, default=None, help="only the first N conditions")
    ap.add_argument("--seeds", type=int, default=None, help="only the first K seeds of the preset")
    ap.add_argument("--duration", type=float, default=None, help="signal length in seconds (default the preset's)")
    ap.add_argument("--runs", type=int, default=1, help="sweeps per preset; the median CPU is reported")
    ap.add_argument("--data-dir", default=None)
    args = ap.parse_args(argv)
    presets = args.preset or ["phone", "thesis"]
    print(f"# sweep CPU vs metric floor; cpu_count {os.cpu_count()}, load average "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}; limit {args.limit}, seeds {args.seeds}, "
          f"duration {args.duration or 'preset'}, runs {args.runs}, workers 1, no report", flush=True)  # fmt: skip
    rows = [measure(p, args) for p in presets]
    print()
    print("| preset | metric calls | sweep CPU (s) | floor PESQ / STOI+ESTOI / SRMR (s) | floor (s) | sweep / floor |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        f = r["floor"]
        print(f"| {r['preset']} | {r['calls']} | {r['cpu']:.1f} | {f['pesq']:.1f} / {f['stoi']:.1f} / {f['srmr']:.1f} "
              f"| {r['floor_total']:.1f} | {r['cpu'] / r['floor_total']:.2f} |")  # fmt: skip
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
