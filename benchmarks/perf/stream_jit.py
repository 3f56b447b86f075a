"""First-call cost of the compiled streaming steps (:mod:`enhancers.kernels.stream`, :mod:`enhancers.kernels.frames`)
in a fresh process.

    python -m benchmarks.perf.stream_jit [--only NAME ...]

For each enhancer, two fresh interpreters share a new, empty ``NUMBA_CACHE_DIR``: the first
compiles the kernel its first 10 ms block needs (numba's import included), the second loads
that machine code from the cache (``cache=True``).  Each process first runs ``process`` on
0.1 s of audio, so filter design and calibration (``ss``'s ``omin``) are not counted: the time
printed is that of the first ``process_block`` call alone.  A later block costs microseconds
(``benchmarks/perf/enhancer_rtf.py``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

#: Streaming built-ins with a compiled per-block step.
COMPILED = ("eb", "eb-gated", "cardioid", "hypercardioid", "das", "ss", "ss-ms2001", "mmse-lsa", "eb-ss",
            "superdirective", "eb-robust-ss")

_CODE = """
import time
import numpy as np
import enhancers
e = enhancers.make({name!r})
x = 0.1 * np.random.default_rng(0).standard_normal((e.tags.channels_in, 1600))
e.process(x, 16000)
state = e.init_state(16000)
t = time.perf_counter()
e.process_block(x[:, :160], state)
print(time.perf_counter() - t)
"""


def first_block_seconds(name: str) -> tuple[float, float]:
    """Seconds of the first ``process_block`` of ``name`` in a fresh process: (empty cache, warm cache)."""
    out = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for _ in range(2):
            res = subprocess.run([sys.executable, "-c", _CODE.format(name=name)], env=env, capture_output=True,
                                 text=True, check=True)
            out.append(float(res.stdout.strip().splitlines()[-1]))
    return out[0], out[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", default=list(COMPILED), help="these enhancers only")
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print("| enhancer | first block, empty numba cache (s) | first block, warm cache (s) |")
    print("| --- | ---: | ---: |")
    for name in args.only:
        cold, warm = first_block_seconds(name)
        print(f"| {name} | {cold:.2f} | {warm:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
