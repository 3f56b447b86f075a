"""Speed of our image-source RIRs against pyroomacoustics 0.10.1 in the same process.

Same image set (``max_order`` from pyroomacoustics' ``inverse_sabine``), same uniform
absorption, both mics of the 2.14 cm pair, fs = 16 kHz, rooms 6x5x3 m and 5x4x3 m,
RT60 0.2/0.4/0.6/1.0 s.  Each timing is the median of ``--runs`` (default 5) runs; rooms are
constructed outside the timed region for both:

* ours:   ``image_source_rir(room, source, pair, fs=16000, max_order=N)`` (method "auto");
* theirs: ``room.image_source_model(); room.compute_rir()`` (its 10 Hz high-pass disabled,
  as in the cross-check, so both produce the same thing).

Also printed: the ratio of process CPU times (pyroomacoustics runs ``num_threads`` threads,
2 on this machine; ours one), the agreement (max relative L2 over the two mics after alignment).

Hybrid rows: ``method="hybrid"`` (default mixing time) against the full ISM (``"fast"``), both
with the default length (1.2 RT60 + direct path) and every image within it, in the rooms of
:data:`HYBRID_ROOMS`, ``specular`` (``ShoeBox(rt60_s=...)``, Sabine absorption, no scattering)
and ``scattered`` (``calibrate_room(dims, rt60)``: scattering 0.5, as scenes build rooms);
T30 and EDT of mic 0 after a 20 Hz high-pass (``scenesim.room.rt60``) as the ratio
hybrid / full, and the early taps' max difference relative to the peak.  A warm-up render
precedes each row's timed runs (numba's first call and the caches are not the renderer's cost).

Memory: peak traced memory (``tracemalloc``; numpy reports its buffers to it) of one RIR at
RT60 ``--memory-rt60`` (default 2 s) by the fast renderer and, with ``--exact-memory``, by the
exact one (several minutes: ~25 M images x 80 taps x 2 mics in numpy).

JIT: the first calls of the compiled kernels (``ism_kernels.warm_up``) in fresh processes, with an
empty numba cache (compile) and then with the cache written by that run (load); the imports
before them (numba, scipy via scenesim) are timed apart.

Run: ``python -m benchmarks.perf.ism_speed [--runs 5] [--exact-memory]``.  Timings are
wall-clock and noisy on a shared machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np


def _pra_room(pra, dims, e_abs, max_order, src, mics, fs):
    room = pra.ShoeBox(
        dims, fs=fs, materials=pra.Material(e_abs), max_order=max_order,
        air_absorption=False, ray_tracing=False,
    )
    room.add_source(list(src))
    room.add_microphone_array(mics.T)
    return room


def main(argv=None) -> int:
    import pyroomacoustics as pra

    from scenesim.room.crosscheck import PRA_GLOBAL_DELAY
    from scenesim.room.ism import image_source_rir
    from scenesim.room.shoebox import ShoeBox
    from scenesim.scene.geometry import MicPair

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--rt60", type=float, nargs="+", default=[0.2, 0.4, 0.6, 1.0])
    parser.add_argument("--hybrid-rt60", type=float, nargs="+", default=[0.6, 1.0, 2.0])
    parser.add_argument("--hybrid-walls", nargs="+", choices=("specular", "scattered"),
                        default=["specular", "scattered"],
                        help="hybrid rows: Sabine rooms without scattering and/or calibrated scattered rooms")
    parser.add_argument("--memory-rt60", type=float, default=2.0)
    parser.add_argument("--exact-memory", action="store_true",
                        help="also trace the exact renderer at --memory-rt60 (minutes)")
    parser.add_argument("--skip-pra", action="store_true", help="only hybrid, memory and JIT rows")
    args = parser.parse_args(argv)
    jit = _jit_cost()
    fs = 16000
    previous = pra.constants.get("rir_hpf_enable")
    pra.constants.set("rir_hpf_enable", False)
    rows = []
    try:
        for dims in ([] if args.skip_pra else [[6.0, 5.0, 3.0], [5.0, 4.0, 3.0]]):
            d = np.asarray(dims)
            pair = MicPair(tuple(d * [0.62, 0.55, 0.0] + [0, 0, 1.2]))
            mics = pair.positions_m
            src = d * [0.3, 0.35, 0.0] + [0, 0, 1.5]
            for rt60 in args.rt60:
                e_abs, max_order = pra.inverse_sabine(rt60, dims)
                room = ShoeBox(tuple(dims), e_abs)
                t_ours, t_pra, c_ours, c_pra = [], [], [], []
                for _ in range(args.runs):
                    t0, c0 = time.perf_counter(), time.process_time()
                    ours = image_source_rir(room, src, mics, fs=fs, max_order=max_order)
                    t_ours.append(time.perf_counter() - t0)
                    c_ours.append(time.process_time() - c0)
                    proom = _pra_room(pra, dims, e_abs, max_order, src, mics, fs)
                    t0, c0 = time.perf_counter(), time.process_time()
                    proom.image_source_model()
                    proom.compute_rir()
                    t_pra.append(time.perf_counter() - t0)
                    c_pra.append(time.process_time() - c0)
                n_images = proom.sources[0].images.shape[1]
                rel = []
                for m in range(2):
                    theirs = np.asarray(proom.rir[m][0], float)[PRA_GLOBAL_DELAY:] / (4 * np.pi)
                    n = min(theirs.size, ours.shape[1])
                    rel.append(np.linalg.norm(ours[m, :n] - theirs[:n]) / np.linalg.norm(theirs[:n]))
                mo, mp = statistics.median(t_ours), statistics.median(t_pra)
                cpu = statistics.median(c_pra) / max(statistics.median(c_ours), 1e-9)
                rows.append((dims, rt60, max_order, n_images, mo, mp, mp / mo, cpu, max(rel)))
    finally:
        pra.constants.set("rir_hpf_enable", previous)

    print(f"ISM speed, fs={fs} Hz, 2 mics (2.14 cm pair), median of {args.runs} runs "
          f"(shared machine: timings are noisy)")
    print(f"{'room':>10} {'rt60':>5} {'order':>5} {'images':>9} {'t_ours s':>9} {'t_pra s':>9} "
          f"{'speedup':>8} {'cpu x':>7} {'rel_l2':>9}")
    for dims, rt60, mo, n_img, t_o, t_p, sp, cpu, rel in rows:
        room_s = "x".join(f"{v:g}" for v in dims)
        print(f"{room_s:>10} {rt60:5.2f} {mo:5d} {n_img:9d} {t_o:9.4f} {t_p:9.4f} {sp:7.2f}x "
              f"{cpu:6.2f}x {rel:9.2e}")
    print(f"speedup = median wall time ratio; cpu x = median process-CPU-time ratio "
          f"(pyroomacoustics uses num_threads={pra.constants.get('num_threads')}, ours 1 thread)")
    _hybrid_rows(args, fs)
    _memory_rows(args, fs)
    print(f"JIT (first calls of every kernel in a fresh process): compile {jit[0]:.2f} s with an empty "
          f"numba cache, {jit[1]:.2f} s loading the cache (cache=True); import of numba + scenesim "
          f"before them {jit[2]:.2f} s")
    return 0


def _scene(dims):
    from scenesim.scene.geometry import MicPair

    d = np.asarray(dims)
    mics = MicPair(tuple(d * [0.62, 0.55, 0.0] + [0, 0, 1.2])).positions_m
    return d * [0.3, 0.35, 0.0] + [0, 0, 1.5], mics


HYBRID_ROOMS = ([6.0, 5.0, 3.0], [5.0, 4.0, 3.0], [6.0, 5.5, 3.0], [14.0, 2.2, 2.8])
"""Hybrid rows' rooms: the two ISM rooms, a ~100 m^3 room and a corridor (issue 18's targets)."""


def _hybrid_room(dims, rt60, kind):
    """``"specular"``: Sabine absorption, no scattering; ``"scattered"``: the calibrated room
    (closed loop, the default scattering 0.5), as scenes build it."""
    from scenesim.room.calibration import calibrate_room
    from scenesim.room.shoebox import ShoeBox

    return ShoeBox(tuple(dims), rt60_s=rt60) if kind == "specular" else calibrate_room(tuple(dims), rt60)


def _hybrid_rows(args, fs):
    from scipy import signal

    from scenesim.room.ism import DEFAULT_MIXING_TIME_S, image_source_rir
    from scenesim.room.rt60 import measure_rt60

    sos = signal.butter(2, 20.0, btype="highpass", fs=fs, output="sos")
    print(f"\nhybrid (mixing time {DEFAULT_MIXING_TIME_S:g} s) vs full ISM, default length, "
          f"median of {args.runs} runs; T30/EDT ratios of mic 0 after a 20 Hz high-pass; load {_load()}")
    print(f"{'room':>12} {'walls':>9} {'rt60':>5} {'t_full s':>9} {'t_hyb s':>9} {'speedup':>8} {'cpu x':>7} "
          f"{'T30 h/f':>8} {'EDT h/f':>8} {'early err':>9}")
    for dims in HYBRID_ROOMS:
        src, mics = _scene(dims)
        for kind in args.hybrid_walls:
            for rt60 in args.hybrid_rt60:
                room = _hybrid_room(dims, rt60, kind)
                image_source_rir(room, src, mics, fs=fs, method="hybrid", seed=0)  # warm (numba, caches)
                t_f, t_h, c_f, c_h = [], [], [], []
                for _ in range(args.runs):
                    t0, c0 = time.perf_counter(), time.process_time()
                    full = image_source_rir(room, src, mics, fs=fs, method="fast", seed=0)  # same scattered noise
                    t_f.append(time.perf_counter() - t0)
                    c_f.append(time.process_time() - c0)
                    t0, c0 = time.perf_counter(), time.process_time()
                    hyb = image_source_rir(room, src, mics, fs=fs, method="hybrid", seed=0)
                    t_h.append(time.perf_counter() - t0)
                    c_h.append(time.process_time() - c0)
                hp_f, hp_h = signal.sosfilt(sos, full[0]), signal.sosfilt(sos, hyb[0])
                t30 = measure_rt60(hp_h, fs, method="T30") / measure_rt60(hp_f, fs, method="T30")
                edt = measure_rt60(hp_h, fs, method="EDT") / measure_rt60(hp_f, fs, method="EDT")
                n_mix = round(DEFAULT_MIXING_TIME_S * fs)
                early = np.abs(hyb[:, :n_mix] - full[:, :n_mix]).max() / np.abs(full).max()
                mf, mh = statistics.median(t_f), statistics.median(t_h)
                cpu = statistics.median(c_f) / max(statistics.median(c_h), 1e-9)
                room_s = "x".join(f"{v:g}" for v in dims)
                print(f"{room_s:>12} {kind:>9} {rt60:5.2f} {mf:9.4f} {mh:9.4f} {mf / mh:7.1f}x {cpu:6.1f}x "
                      f"{t30:8.3f} {edt:8.3f} {early:9.1e}")
    print(f"speedup = median wall-time ratio, cpu x = median process-CPU-time ratio (less affected by load); "
          f"load after the hybrid rows: {_load()}")


def _load() -> str:
    """The 1/5/15-minute load averages (the machine is shared: timings depend on them)."""
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def _memory_rows(args, fs):
    import pyroomacoustics as pra

    from scenesim.room.ism import image_source_rir
    from scenesim.room.shoebox import ShoeBox

    methods = ["fast", "hybrid"] + (["exact"] if args.exact_memory else [])
    print(f"\npeak traced memory of one RIR pair at RT60 {args.memory_rt60:g} s "
          f"(pyroomacoustics' inverse-Sabine order; hybrid: default length)")
    for dims in ([6.0, 5.0, 3.0], [5.0, 4.0, 3.0]):
        src, mics = _scene(dims)
        e_abs, max_order = pra.inverse_sabine(args.memory_rt60, dims)
        room = ShoeBox(tuple(dims), e_abs)
        for method in methods:
            kw = {} if method == "hybrid" else {"max_order": max_order}
            tracemalloc.start()
            t0 = time.perf_counter()
            h = image_source_rir(room, src, mics, fs=fs, method=method, **kw)
            dt = time.perf_counter() - t0
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            room_s = "x".join(f"{v:g}" for v in dims)
            print(f"  {room_s:>8} {method:>6}: {peak / 2**20:7.1f} MiB peak "
                  f"(output {h.nbytes / 2**20:.1f} MiB, order {max_order}, {dt:.1f} s)")


def _jit_cost():
    """Seconds in a fresh process: (first kernel calls with an empty numba cache, the same
    with the cache that run wrote, import of numba + scenesim.room.ism_kernels in the second)."""
    code = ("import time; t = time.perf_counter(); from scenesim.room.ism_kernels import warm_up; "
            "t1 = time.perf_counter(); warm_up(); print(t1 - t, time.perf_counter() - t1)")
    out = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for _ in range(2):
            res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                 text=True, check=True)
            imp, first = (float(v) for v in res.stdout.strip().splitlines()[-1].split())
            out.append(first)
    return out[0], out[1], imp


if __name__ == "__main__":
    raise SystemExit(main())
