"""Old flat import paths (``enhancers.eb``, ``enhancers.ss``, ...) kept working after the move by job.

A user script that imports ``enhancers.mic_calibration`` gets the module that now lives at
``enhancers.beam.mic_calibration`` (the same module object, so ``isinstance`` and pickles agree)
and a ``DeprecationWarning`` naming the new path. New code uses the new paths.

>>> import importlib, warnings
>>> with warnings.catch_warnings(record=True) as w:
...     warnings.simplefilter("always")
...     old = importlib.import_module("enhancers.filterbank")
>>> old is importlib.import_module("enhancers.core.filterbank"), "enhancers.core.filterbank" in str(w[0].message)
(True, True)
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

MOVED = {
    **{m: f"core.{m}" for m in ("base", "registry", "chain", "filterbank", "stft_stage", "eq")},
    **{m: f"single.{m}" for m in ("ss", "noise_tracking", "mmse_lsa")},
    **{m: f"beam.{m}" for m in ("baselines", "differential", "eb", "subband_eb", "beam_pool",
                                "calibration_model", "mic_calibration", "robust_eb", "superdirective",
                                "presets")},
    **{m: f"peers.{m}" for m in ("blackbox", "dfn3", "rnnoise", "webrtc_ns", "wpe")},
    "_kernels_wola": "kernels.wola", "_kernels_robust": "kernels.robust",
    "stream_kernels": "kernels.stream", "fast_frames": "kernels.frames",
}
"""Old module name under ``enhancers`` -> its new dotted path under ``enhancers``."""


class _Alias(importlib.abc.Loader):
    def __init__(self, target: str):
        self.target = target

    def create_module(self, spec):
        warnings.warn(f"{spec.name} moved to {self.target}; import it from there",
                      DeprecationWarning, stacklevel=3)
        return importlib.import_module(self.target)

    def exec_module(self, module):  # the target module is already executed
        pass


class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        head, _, tail = fullname.partition(".")
        if head != "enhancers" or tail not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, _Alias(f"enhancers.{MOVED[tail]}"))


def install() -> None:
    """Put the finder on ``sys.meta_path`` once (idempotent)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())
