"""WAV files whose header states a rate libsndfile would not write (0 Hz) or nonsense (1 Hz, 100 MHz)."""

from __future__ import annotations

import numpy as np
import soundfile as sf


def wav_with_rate(path, rate: int, *, channels: int = 1):
    """A 0.1 s silent float WAV at ``path`` whose ``fmt`` chunk says ``rate`` Hz; returns ``path``."""
    sf.write(path, np.zeros((1600, channels)), 16000, subtype="FLOAT")
    data = bytearray(path.read_bytes())
    i = data.find(b"fmt ")
    data[i + 12:i + 16] = int(rate).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    return path
