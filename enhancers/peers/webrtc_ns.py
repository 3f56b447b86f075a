"""WebRTC noise suppression as a black-box peer, through the ``webrtc-noise-gain`` package.

Optional: ``pip install -e '.[webrtc]'`` (``webrtc-noise-gain``, Apache-2.0, a binary
wheel of the freedesktop ``webrtc-audio-processing`` library; it loads no model and
fetches nothing at run time).  ``scenesim bench list`` shows the install command when the
package is absent.

The library takes 10 ms frames (160 samples) of 16 kHz mono int16 audio: full-scale
float input is scaled by 32768, rounded and clipped to int16, and the output scaled back.
Settings (``Params``): ``noise_suppression_level`` 1-4 (WebRTC's low / moderate / high /
very-high suppression, targets 6 / 12 / 18 / 21 dB; default 2 = moderate, the package
README's example; measured on white noise: 12.2 dB at level 2, 21.3 dB at level 4) and ``auto_gain_dbfs``
0 (automatic gain control off, default: a level-changing AGC would confound the SNR
measurement; 1-31 turns it on with that target).  The audio processing module also runs
its fixed high-pass filter; that is part of the black box.

Not replayable (``tags.replayable`` False): measured by phase inversion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from webrtc_noise_gain import AudioProcessor

from enhancers.core.base import Params
from enhancers.peers.blackbox import INT16_SCALE, FramedBlackBox, to_int16_scale
from scenesim.validate import check_int

__all__ = ["WebrtcNoiseSuppression"]


class WebrtcNoiseSuppression(FramedBlackBox):
    """WebRTC noise suppression (``webrtc-noise-gain``), 16 kHz mono, 10 ms int16 frames.

    Latency: 159 samples of frame buffering plus the noise suppressor's own 96 samples
    (its 256-sample analysis window minus the 160-sample frame); the output's
    cross-correlation with speech peaks at 252-255 samples (the high-pass filter's phase
    moves the peak a little), see tests.

    Example
    -------
    >>> import numpy as np
    >>> x = 0.1 * np.random.default_rng(0).standard_normal((1, 16000))
    >>> WebrtcNoiseSuppression().process(x, 16000).output.shape
    (1, 16000)
    """

    name: ClassVar[str] = "webrtc-ns"
    version: ClassVar[str] = "1"
    summary: ClassVar[str] = "WebRTC noise suppression (webrtc-noise-gain; black box, 16 kHz)"
    frame_samples: ClassVar[int] = 160
    library_delay_samples: ClassVar[int] = 96

    @dataclass(frozen=True)
    class Params(Params):
        noise_suppression_level: int = 2
        auto_gain_dbfs: int = 0

        def __post_init__(self):
            check_int("noise_suppression_level", self.noise_suppression_level, minimum=1, maximum=4)
            check_int("auto_gain_dbfs", self.auto_gain_dbfs, minimum=0, maximum=31)

    def _open(self) -> AudioProcessor:
        return AudioProcessor(int(self.params.auto_gain_dbfs), int(self.params.noise_suppression_level))

    def _run_frame(self, engine: AudioProcessor, frame: np.ndarray) -> np.ndarray:
        pcm = np.round(to_int16_scale(frame)).astype("<i2")
        result = engine.Process10ms(pcm.tobytes())
        return np.frombuffer(result.audio, dtype="<i2").astype(np.float64) / INT16_SCALE
