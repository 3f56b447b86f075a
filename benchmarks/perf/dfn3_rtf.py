"""Where ``dfn3``'s time goes: the C library alone, the resampling, the wrapper, the model load.

    python -m benchmarks.perf.dfn3_rtf [--seconds 10] [--runs 3] [--data-dir ../shared/data]

CPU time (``time.process_time``: every thread of the process) per second of audio, median of
``--runs`` runs after one warm-up:

- **C library alone**: ``df_process_frame`` over pre-made 48 kHz float32 frames (the input
  upsampled once, before timing), one handle made before timing; also the calling thread's own
  CPU time (``time.thread_time``) and the process's thread count before and after, which show
  whether the library works in threads of its own (it does not: tract runs on the caller's thread).
- **resampling alone**: :class:`enhancers.peers.blackbox.Resampler16to48` up and down per 10 ms frame.
- **dfn3 streaming**: ``process_block`` on 10 ms blocks, the state made before timing (steady
  state), and **with init**: ``init_state`` timed too (as ``enhancer_rtf`` times it), i.e. plus
  ``df_create`` (parsing and optimising the ONNX model, once per stream).

The input is seeded white noise at -20 dBFS (as ``enhancer_rtf``'s), or with ``--data-dir`` CMU ARCTIC
speech at -26 dBFS plus white noise 20 dB below: the network skips its decoders on frames it
judges silent or clean, so its cost depends on the input.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

from benchmarks.perf.timing import median_time

FS = 16000
FRAME = 160  # 10 ms at 16 kHz


def _threads() -> int:
    return len(os.listdir("/proc/self/task")) if os.path.isdir("/proc/self/task") else -1


def _speech(data_dir: Path, seconds: float) -> np.ndarray:
    from scenesim.audio import read_audio

    parts, n = [], int(seconds * FS)
    for path in sorted((data_dir / "speech").glob("*.wav")):
        parts.append(read_audio(path, fs=FS)[0][0])
        if sum(p.size for p in parts) >= n:
            break
    s = np.concatenate(parts)
    s = np.resize(s, n)  # repeats if the folder holds less than `seconds`
    s = 0.05 * s / np.sqrt(np.mean(s**2))
    return s + 0.005 * np.random.default_rng(3).standard_normal(n)


def library_alone(x16: np.ndarray, runs: int) -> dict:
    """CPU seconds per audio second of ``df_process_frame`` alone on ``x16`` upsampled once; thread facts."""
    from enhancers.peers.blackbox import Resampler16to48
    from enhancers.peers.dfn3 import _FLOAT_P, _lib, bundled_model

    lib, n_frames = _lib(), x16.size // FRAME
    frames = np.empty((n_frames, 3 * FRAME), dtype=np.float32)
    r = Resampler16to48()
    for i in range(n_frames):
        r.up_into(np.ascontiguousarray(x16[i * FRAME:(i + 1) * FRAME]), frames[i])
    out = np.zeros(3 * FRAME, dtype=np.float32)
    ptr_out = out.ctypes.data_as(_FLOAT_P)
    ptrs = [frames[i].ctypes.data_as(_FLOAT_P) for i in range(n_frames)]
    threads_before = _threads()
    c0 = time.process_time()
    handle = lib.df_create(bundled_model().encode(), 100.0, None)
    create_cpu = time.process_time() - c0
    cpu, own = [], []
    try:
        for run in range(runs + 1):
            c0, t0 = time.process_time(), time.thread_time()
            for p in ptrs:
                lib.df_process_frame(handle, p, ptr_out)
            if run:  # the first pass is the warm-up
                cpu.append(time.process_time() - c0)
                own.append(time.thread_time() - t0)
        threads_after = _threads()
    finally:
        lib.df_free(handle)
    seconds = n_frames * FRAME / FS
    return {"cpu_rtf": statistics.median(cpu) / seconds, "thread_rtf": statistics.median(own) / seconds,
            "create_cpu_s": create_cpu, "threads_before": threads_before, "threads_after": threads_after}


def wrapper(x16: np.ndarray, runs: int) -> dict:
    """CPU RTFs of the resampling alone and of ``dfn3`` streaming, without and with ``init_state``."""
    import enhancers
    from enhancers.peers.blackbox import Resampler16to48

    seconds = x16.size / FS
    frames = [np.ascontiguousarray(x16[i:i + FRAME]) for i in range(0, x16.size - FRAME + 1, FRAME)]

    def resample():
        r = Resampler16to48()
        for f in frames:
            r.down(r.up(f))

    e, x = enhancers.make("dfn3"), x16[None]

    def stream(st):
        for i in range(0, x.shape[-1], FRAME):
            _, st = e.process_block(x[:, i:i + FRAME], st)

    steady = []
    stream(e.init_state(FS))  # warm-up
    for _ in range(runs):
        st = e.init_state(FS)
        c0 = time.process_time()
        stream(st)
        steady.append(time.process_time() - c0)
    with_init = median_time(lambda: stream(e.init_state(FS)), runs)[1]
    return {"resample_rtf": median_time(resample, runs)[1] / seconds,
            "stream_rtf": statistics.median(steady) / seconds, "stream_init_rtf": with_init / seconds}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--data-dir", type=Path, default=None, help="folder with speech/ (CMU ARCTIC) instead of noise")
    args = ap.parse_args(argv)
    noise = 0.1 * np.random.default_rng(7).standard_normal(int(args.seconds * FS))
    x16 = _speech(args.data_dir, args.seconds) if args.data_dir else noise
    lib = library_alone(x16, args.runs)
    wr = wrapper(x16, args.runs)
    what = "CMU ARCTIC speech + white noise at 20 dB SNR" if args.data_dir else "seeded white noise"
    print(f"dfn3 CPU real-time factor on {args.seconds:g} s of {what}, median of {args.runs} runs "
          f"(target: streaming <= 0.2 on one core)")
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}; "
          f"threads in this process before/after the library ran: {lib['threads_before']}/{lib['threads_after']}")
    print()
    print("| part | CPU RTF |")
    print("| --- | ---: |")
    print(f"| C library alone (df_process_frame, all threads) | {lib['cpu_rtf']:.4f} |")
    print(f"| C library alone (calling thread only) | {lib['thread_rtf']:.4f} |")
    print(f"| resampling alone (16 -> 48 -> 16 kHz) | {wr['resample_rtf']:.4f} |")
    print(f"| dfn3 streaming, 10 ms blocks, state made before timing | {wr['stream_rtf']:.4f} |")
    print(f"| dfn3 streaming incl. init_state (as enhancer_rtf) | {wr['stream_init_rtf']:.4f} |")
    print(f"\ndf_create (model load, once per stream): {lib['create_cpu_s']:.3f} s CPU")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
