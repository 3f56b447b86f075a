"""Audio file I/O and resampling: always float64 ``(n_channels, n_samples)`` arrays.

* :func:`read_audio` reads anything ``soundfile`` reads (WAV, FLAC, ...), optionally
  resampled to ``fs`` with a polyphase filter (``scipy.signal.resample_poly``).
* :func:`write_audio` writes atomically (temporary file in the target directory, then
  ``os.replace``), refuses NaN/Inf, and for integer PCM refuses samples beyond full scale
  (``|x| > 1``) unless ``normalize=True`` asks for peak normalisation -- nothing is clipped
  silently.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import soundfile as sf

from scenesim.errors import DataError, ParameterError
from scenesim.files import chmod_as_umask
from scenesim.validate import PHYSICAL_RANGES, check_choice, check_fs

SUBTYPES = ("FLOAT", "DOUBLE", "PCM_16", "PCM_24", "PCM_32")


def resample(x, fs_from: int, fs_to: int) -> np.ndarray:
    """Resample ``x`` ((n,) or (n_ch, n)) from ``fs_from`` to ``fs_to`` Hz along the last axis.

    Polyphase FIR (``resample_poly``, Kaiser window beta 5) with the ratio reduced by the
    gcd; the output has ``ceil(n * fs_to / fs_from)`` samples.  Same rate: a copy.
    """
    fs_from = check_fs(fs_from)
    fs_to = check_fs(fs_to)
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim not in (1, 2):
        raise ParameterError("x", arr, "a 1-D or (n_channels, n_samples) array")
    if fs_from == fs_to:
        return arr.copy()
    g = math.gcd(fs_from, fs_to)
    from scipy import signal as sps  # lazy: scipy.signal costs ~1.5 s to import (scipy 1.17)

    return sps.resample_poly(arr, fs_to // g, fs_from // g, axis=-1)


def _riff_rate(path: Path) -> int | None:
    """The rate field of a RIFF/RF64 WAV's ``fmt`` chunk (libsndfile will not open rate 0)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return None
    if head[:4] not in (b"RIFF", b"RF64") or head[8:12] != b"WAVE":
        return None
    i = head.find(b"fmt ", 12)
    return int.from_bytes(head[i + 12:i + 16], "little") if 0 < i <= len(head) - 16 else None


def audio_rate(path) -> int:
    """The sample rate (Hz) an audio file's header states, unchecked (a WAV's 0 Hz included).

    Raises
    ------
    DataError
        The file is missing or libsndfile cannot read its header (the message names it).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"no such file: {path}" if not path.exists() else f"{path} is not a file")
    try:
        return int(sf.info(str(path)).samplerate)
    except (sf.LibsndfileError, RuntimeError, OSError) as exc:
        rate = _riff_rate(path)
        if rate is None:
            raise DataError(f"cannot read audio file {path}: {exc}") from exc
        return rate


def check_rate(path, rate: int) -> int:
    """``rate`` if it is within the range of ``--fs``, else a DataError naming the file and its rate.

    The range is :data:`scenesim.validate.PHYSICAL_RANGES` ``["fs"]`` (8000-192000 Hz).

    >>> check_rate("a.wav", 1)
    Traceback (most recent call last):
    scenesim.errors.DataError: audio file a.wav says its sample rate is 1 Hz: expected a rate \
in [8000, 192000] Hz (the range of --fs); fix or resample the file
    """
    lo, hi = PHYSICAL_RANGES["fs"][:2]
    if not lo <= rate <= hi:
        raise DataError(
            f"audio file {path} says its sample rate is {rate} Hz: expected a rate in [{lo}, {hi}] Hz "
            "(the range of --fs); fix or resample the file"
        )
    return rate


def check_audio_rate(path) -> int:
    """The header's sample rate of ``path`` (Hz), held to the range of ``--fs`` before any work.

    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "fine.wav")
    >>> _ = sf.write(path, np.zeros(100), 16000)
    >>> check_audio_rate(path)
    16000
    """
    return check_rate(path, audio_rate(path))


def read_audio(path, *, fs: int | None = None) -> tuple[np.ndarray, int]:
    """Read an audio file as float64 ``(n_channels, n_samples)`` in [-1, 1] full-scale units.

    Parameters
    ----------
    path : str or Path
    fs : int, optional
        Resample to this rate (Hz) when the file's rate differs.

    Returns
    -------
    x : ndarray (n_channels, n_samples)
    fs : int
        The rate of ``x`` (the file's, or ``fs`` when given).

    Raises
    ------
    DataError
        The file is missing, unreadable, has no samples, or its header's sample rate is outside the
        range of ``--fs`` (the message names the file and the rate).
    """
    if fs is not None:
        fs = check_fs(fs)
    path = Path(path)
    if not path.exists():
        raise DataError(f"no such file: {path}")
    if path.is_dir():
        raise DataError(f"{path} is a directory, not an audio file")
    check_audio_rate(path)  # before the samples are read or resampled: a 1 Hz header would ask for GiB
    try:
        data, file_fs = sf.read(str(path), dtype="float64", always_2d=True)
    except (sf.LibsndfileError, RuntimeError, OSError) as exc:
        raise DataError(f"cannot read audio file {path}: {exc}") from exc
    if data.size == 0:
        raise DataError(f"audio file {path} has no samples")
    _warn_if_truncated(path, data.shape)
    x = np.ascontiguousarray(data.T)
    if not np.all(np.isfinite(x)):
        raise DataError(f"audio file {path} contains NaN or Inf samples")
    if fs is not None and fs != file_fs:
        return resample(x, file_fs, fs), fs
    return x, int(file_fs)


def _warn_if_truncated(path: Path, shape: tuple[int, int]) -> None:
    """Warn when the header promises more samples than the file holds (a cut-off copy or
    download): libsndfile reads what is there and notes the shortfall in its log only."""
    try:
        with sf.SoundFile(str(path)) as f:
            log = f.extra_info
    except (sf.LibsndfileError, RuntimeError, OSError):  # pragma: no cover - it was just read
        return
    m = re.search(r"^data\s*:\s*(\d+)\s*\(should be (\d+)\)", log, flags=re.M)
    if m and int(m.group(1)) > int(m.group(2)):
        promised = int(m.group(1)) * shape[0] // max(int(m.group(2)), 1)
        warnings.warn(
            f"audio file {path} is shorter than its header says ({shape[0]} of {promised} samples "
            f"per channel): it was probably cut off; using the {shape[0]} samples present",
            stacklevel=3,
        )


def write_audio(path, x, fs: int, *, subtype: str = "FLOAT", normalize: bool = False,
                comment: str | None = None) -> Path:
    """Write ``x`` ((n,) or (n_channels, n_samples)) to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        Target file; the format follows the extension (``.wav``, ``.flac``).
    x : array
        Samples in full-scale units; not modified.
    fs : int
        Sampling rate in Hz.
    subtype : {"FLOAT", "DOUBLE", "PCM_16", "PCM_24", "PCM_32"}
        Sample format.
    normalize : bool
        Integer PCM only: scale to a peak of 0.99 when ``|x| > 1`` (otherwise that raises).
    comment : str, optional
        Text for the file's ``comment`` field (WAV ``ICMT``, FLAC Vorbis comment).

    Returns
    -------
    Path
        The path written.
    """
    fs = check_fs(fs)
    subtype = check_choice("subtype", subtype, SUBTYPES)
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] == 0 or arr.shape[0] == 0:
        raise ParameterError("x", arr, "a non-empty (n_channels, n_samples) array")
    if not np.all(np.isfinite(arr)):
        raise ParameterError("x", arr, "finite samples only (no NaN or Inf)")
    if subtype.startswith("PCM"):
        peak = float(np.max(np.abs(arr)))
        if peak > 1.0:
            if not normalize:
                raise ParameterError(
                    "x",
                    arr,
                    f"samples within [-1, 1] for {subtype} (peak {peak:.3g}); pass normalize=True",
                )
            arr = arr * (0.99 / peak)
    path = Path(path)
    fmt = path.suffix[1:].upper()
    if fmt not in sf.available_formats():
        raise ParameterError(
            "path", str(path), "a file name ending in .wav, .flac or another soundfile format"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        # The temporary name has no audio extension, so the format is given explicitly.
        with sf.SoundFile(tmp, "w", fs, arr.shape[0], subtype=subtype, format=fmt) as f:
            if comment:
                f.comment = comment
            f.write(arr.T)
        chmod_as_umask(tmp)  # mkstemp made it 0600; the user's umask decides
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
