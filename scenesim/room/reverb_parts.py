"""The speech image split into direct path, early reflections and late reverberation (issue 10).

Reverberation is counted once if every metric agrees on what is target and what is not.
Here the target is the **direct path + early reflections** (the first ``early_window_s``,
50 ms by default, after the direct sound reaches the reference mic: ISO 3382's C50 split,
the part of a room's response that adds to intelligibility); the **late** part is
interference like noise.

The RIR of each mic is split in time, ``h = h_direct + h_early + h_late``:

* ``h_direct``: the order-0 image alone (the RIR rendered with ``max_order=0``);
* ``h_early = h * [n < cut] - h_direct``: every other image arriving before the cut;
* ``h_late = h * [n >= cut]``;

with ``cut = ceil((r0 / c + early_window_s) * fs)`` and ``r0`` the talker's distance to the
reference mic (channel 0) -- the same cut as ``Scene(reference="early50")``, one cut for both
mics so the parts of a pair stay time-aligned.  Each part is convolved with the dry speech
and passed through the scene's sensors (linear), so the three part images sum to the speech
image to rounding.  In free field the direct part is the whole speech image.

Room-acoustic parameters of an RIR (:func:`rir_acoustics`) use the same split; the
critical distance (:func:`critical_distance_m`) is Sabine's ``r_c = 0.057 sqrt(V / RT60)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from scenesim.errors import ParameterError
from scenesim.room.cache import cached_rir
from scenesim.room.iso3382 import critical_distance_m  # noqa: F401  (re-exported: its former home)
from scenesim.room.rt60 import measure_rt60
from scenesim.validate import check_range

EARLY_WINDOW_S = 0.05
"""Default early window after the direct path (s): the C50 split."""


@dataclass(frozen=True)
class SpeechParts:
    """Direct, early and late speech images ``(2, n)`` of one scene (sensors applied).

    ``direct + early + late == speech_image`` to rounding.  ``cut_sample`` is the RIR sample
    where the late part begins (None in free field, where there is no reverberation).
    """

    direct: np.ndarray
    early: np.ndarray
    late: np.ndarray
    fs: int
    early_window_s: float
    cut_sample: int | None

    @property
    def target(self) -> np.ndarray:
        """Direct + early ``(2, n)``: the speech the metrics count as signal."""
        return self.direct + self.early

    @property
    def reverberant(self) -> bool:
        return self.cut_sample is not None


def early_cut_sample(distance_m: float, *, fs: int, c: float, early_window_s: float = EARLY_WINDOW_S) -> int:
    """First RIR sample of the late part: ``ceil((distance_m / c + early_window_s) * fs)``."""
    return int(np.ceil((distance_m / c + early_window_s) * fs))


def split_rir(h, h_direct, cut_sample: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(direct, early, late)`` parts of RIRs ``h`` ``(..., taps)``; they sum to ``h`` exactly.

    ``h_direct`` (same leading shape, any length <= taps) is the direct-path RIR.

    >>> import numpy as np
    >>> d, e, l = split_rir(np.array([0.0, 1.0, 0.5, 0.25]), np.array([0.0, 1.0]), 3)
    >>> e.tolist(), l.tolist()
    ([0.0, 0.0, 0.5, 0.0], [0.0, 0.0, 0.0, 0.25])
    """
    h = np.asarray(h, dtype=np.float64)
    hd = np.asarray(h_direct, dtype=np.float64)
    if hd.shape[-1] > h.shape[-1]:
        if np.any(hd[..., h.shape[-1]:]):
            raise ParameterError("h_direct", hd.shape, f"a direct path within the RIR's {h.shape[-1]} taps")
        hd = hd[..., : h.shape[-1]]
    direct = np.zeros_like(h)
    direct[..., : hd.shape[-1]] = hd
    cut = int(np.clip(cut_sample, 0, h.shape[-1]))
    late = np.zeros_like(h)
    late[..., cut:] = h[..., cut:]
    early = h - late - direct
    return direct, early, late


def speech_parts(images, speech, *, early_window_s: float = EARLY_WINDOW_S) -> SpeechParts:
    """Split a scene's speech image into direct / early / late images.

    Parameters
    ----------
    images : scenesim.scene.compose.SceneImages
        From :func:`scenesim.scene.compose.render_images` (its RIRs are reused).
    speech : array (n,)
        The dry speech the images were rendered from.
    early_window_s : float
        Early window after the direct path, in s (0.05 = C50 split).

    Returns
    -------
    SpeechParts
    """
    early_window_s = check_range("early_window_s", early_window_s, 0.0, 1.0)
    scene = images.scene
    s = np.asarray(speech, dtype=np.float64).reshape(-1)
    n = images.speech_image.shape[1]
    if s.size != n:
        raise ParameterError("speech", s.shape, f"the {n} samples the images were rendered from")
    if scene.room is None:
        zeros = np.zeros_like(images.speech_image)
        return SpeechParts(np.array(images.speech_image), zeros, zeros.copy(), images.fs, early_window_s, None)
    pair, fs = scene.pair, scene.fs
    pos = scene.speech.position(pair)
    h = images.rirs["speech"]
    h_direct = cached_rir(scene.room, pos, pair.positions_m, fs=fs, max_order=0)
    r0 = float(np.linalg.norm(pair.positions_m[0] - pos))
    cut = early_cut_sample(r0, fs=fs, c=scene.speed_of_sound_mps, early_window_s=early_window_s)
    parts = []
    for part in split_rir(h, h_direct, cut):
        img = sps.oaconvolve(s[None, :], part, mode="full", axes=1)[:, :n]
        if scene.sensors is not None and not scene.sensors.linear_ideal:
            img = scene.sensors.apply(img, fs=fs)
        parts.append(img)
    return SpeechParts(*parts, fs=fs, early_window_s=early_window_s, cut_sample=cut)


def _db(num: float, den: float) -> float:
    if num <= 0.0 and den <= 0.0:
        raise ParameterError("h", "silent", "an impulse response with energy")
    if den <= 0.0:
        return float("inf")
    return float(10.0 * np.log10(max(num, 1e-300) / den))


def rir_acoustics(h, h_direct, *, fs: int, cut_sample: int) -> dict[str, float | None]:
    """Room-acoustic parameters of one RIR ``h`` ``(taps,)`` (ISO 3382-1 style).

    Returns ``t30_s`` and ``edt_s`` (Schroeder backward integration, line fits -5..-35 dB and
    0..-10 dB, :func:`scenesim.room.rt60.measure_rt60`; None when the RIR does not decay far
    enough), ``drr_db = 10 log10(E_direct / E_rest)`` with the exact order-0 image as the
    direct sound, and ``c50_db = 10 log10(E[n < cut] / E[n >= cut])`` with ``cut`` the direct
    arrival + 50 ms (:func:`early_cut_sample`).
    """
    h = np.asarray(h, dtype=np.float64).reshape(-1)
    direct, early, late = split_rir(h, np.asarray(h_direct, dtype=np.float64).reshape(-1), cut_sample)
    out: dict[str, float | None] = {}
    for key, method in (("t30_s", "T30"), ("edt_s", "EDT")):
        try:
            out[key] = float(measure_rt60(h, fs, method=method))
        except ParameterError:
            out[key] = None
    out["drr_db"] = _db(float(np.sum(direct**2)), float(np.sum((early + late) ** 2)))
    out["c50_db"] = _db(float(np.sum((direct + early) ** 2)), float(np.sum(late**2)))
    return out


__all__ = [
    "EARLY_WINDOW_S",
    "SpeechParts",
    "critical_distance_m",
    "early_cut_sample",
    "rir_acoustics",
    "speech_parts",
    "split_rir",
]
