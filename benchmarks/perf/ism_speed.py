"""Speed of our image-source RIRs against pyroomacoustics 0.10.1 in the same process.

Same image set (``max_order`` from pyroomacoustics' ``inverse_sabine``), same uniform
absorption, both mics of the 2.14 cm pair, fs = 16 kHz, rooms 6x5x3 m and 5x4x3 m,
RT60 0.2/0.4/0.6/1.0 s.  Each timing is the median of ``--runs`` (default 5) runs; rooms are
constructed outside the timed region for both:

* ours:   ``image_source_rir(room, source, pair, fs=16000, max_order=N)`` (method "auto");
* theirs: ``room.image_source_model(); room.compute_rir()`` (its 10 Hz high-pass disabled,
  as in the cross-check, so both produce the same thing).

Also printed: the ratio of process CPU times (pyroomacoustics runs ``num_threads`` threads,
2 on this machine; ours one), the agreement (max relative L2 over the two mics after alignment) and our peak
traced memory at RT60 1.0 s (``tracemalloc``; numpy reports its buffers to it).

Run: ``python -m benchmarks.perf.ism_speed [--runs 5]``.  Timings are wall-clock and noisy on
a shared machine.
"""

from __future__ import annotations

import argparse
import statistics
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

    from scenesim.crosscheck import PRA_GLOBAL_DELAY
    from scenesim.geometry import MicPair
    from scenesim.ism import image_source_rir
    from scenesim.room import ShoeBox

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--rt60", type=float, nargs="+", default=[0.2, 0.4, 0.6, 1.0])
    args = parser.parse_args(argv)
    fs = 16000
    previous = pra.constants.get("rir_hpf_enable")
    pra.constants.set("rir_hpf_enable", False)
    rows = []
    peak = {}
    try:
        for dims in ([6.0, 5.0, 3.0], [5.0, 4.0, 3.0]):
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
                if rt60 == max(args.rt60):
                    tracemalloc.start()
                    image_source_rir(room, src, mics, fs=fs, max_order=max_order)
                    peak[tuple(dims)] = tracemalloc.get_traced_memory()[1]
                    tracemalloc.stop()
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
    for dims, bytes_ in peak.items():
        room_s = "x".join(f"{v:g}" for v in dims)
        print(f"peak traced memory of ours at RT60 {max(args.rt60):g} s in {room_s}: "
              f"{bytes_ / 2**20:.1f} MiB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
