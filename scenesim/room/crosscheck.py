"""Cross-check our image-source RIRs against pyroomacoustics 0.10.1 (algorithms.md section 3).

The same room is built in pyroomacoustics with per-wall flat energy absorption, the same
``max_order`` (so the same L1 image set), ``air_absorption=False`` and ray tracing off.
The known differences are aligned before comparing:

* its RIRs carry a global delay of ``frac_delay_length // 2 = 40`` samples: removed;
* its amplitude is ``g / r`` (no ``4 pi``): we divide its RIR by ``4 pi`` (equivalently,
  multiply ours by ``4 pi`` -- algorithms.md says "multiply a physical RIR by 4 pi");
* its 10 Hz Butterworth high-pass is disabled for the run with
  ``pyroomacoustics.constants.set("rir_hpf_enable", False)`` and the previous value restored;
* lengths differ by a sample or two: both are compared over the common length.

Remaining differences: its fractional delay uses a Hann window on the integer grid and a
float32 sinc table (1/20 steps, linear interpolation) in float32 arithmetic; ours centres the
window on the true delay in float64 (each accounts for about half of the residual).  Agreement
is then 1e-3..4.2e-3 relative L2 (60 random rooms, orders 0..30, 8 and 16 kHz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from scenesim.errors import ParameterError, ScenesimError
from scenesim.room.ism import image_source_rir
from scenesim.room.rt60 import measure_rt60
from scenesim.room.shoebox import ShoeBox
from scenesim.validate import check_fs, check_int

PRA_GLOBAL_DELAY = 40
"""pyroomacoustics' global RIR delay in samples (``frac_delay_length // 2``)."""
PRA_WALL_NAMES = ("west", "east", "south", "north", "floor", "ceiling")
"""pyroomacoustics' wall names in our wall order [x=0, x=Lx, y=0, y=Ly, z=0, z=Lz]."""


@dataclass(frozen=True)
class CrossCheck:
    """Agreement between our RIR and pyroomacoustics' for one room and mic set.

    Attributes
    ----------
    rel_l2 : tuple of float
        Per mic ``||ours - theirs|| / ||theirs||`` after alignment.
    max_rel_l2 : float
    argmax_equal : bool
        Every mic's largest-|h| tap is at the same index in both.
    inter_mic_delay_error_samples : float
        Inter-mic delay (mic 1 vs mic 0, cross-correlation peak with parabolic refinement)
        ours minus theirs, in samples; NaN with one mic.
    t20_ours_s, t30_ours_s, t20_theirs_s, t30_theirs_s : float
        Measured on mic 0 (NaN when the truncated decay does not reach the fit range).
    target_rt60_s : float
        The room's ``rt60_s`` if given, else its Sabine RT60.
    their_rt60_error : float
        ``t30_theirs / target - 1`` (relative); ``our_rt60_error`` likewise for ours.
    our_rt60_error : float
    n_images : int
        Images pyroomacoustics generated (visible ones, per source).
    max_order : int
    fs : int
    ours, theirs : (n_mics, n) arrays
        The compared RIRs over their common length (theirs aligned); not in :meth:`to_dict`.
    """

    rel_l2: tuple[float, ...]
    max_rel_l2: float
    argmax_equal: bool
    inter_mic_delay_error_samples: float
    t20_ours_s: float
    t30_ours_s: float
    t20_theirs_s: float
    t30_theirs_s: float
    target_rt60_s: float
    their_rt60_error: float
    our_rt60_error: float
    n_images: int
    max_order: int
    fs: int
    ours: np.ndarray = field(repr=False, compare=False, default=None)
    theirs: np.ndarray = field(repr=False, compare=False, default=None)

    def to_dict(self) -> dict:
        """Plain JSON-ready dict of the numbers (NaN kept as float NaN; arrays left out)."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("ours", "theirs")}
        d["rel_l2"] = list(self.rel_l2)
        return d


def pyroomacoustics_rirs(room: ShoeBox, source_m, mics_m, *, fs: int, max_order: int, materials=None,
                         directivity=None, air_absorption=None):
    """pyroomacoustics' RIRs in our convention ``(n_mics, n)``, and its room (for image counts).

    Removes the 40-sample global delay, divides by ``4 pi``, and runs with its high-pass off
    (restoring the previous ``rir_hpf_enable`` afterwards, even on error).  ``materials``
    (default: the room's flat wall absorptions), ``directivity`` (a pyroomacoustics
    directivity) and ``air_absorption`` (per-band energy coefficients) are passed through:
    every cross-check (flat, octave bands, air, directivity) renders through here.
    """
    import pyroomacoustics as pra

    src = room.check_inside(source_m, name="source_m")
    mics = np.atleast_2d(np.asarray(mics_m, dtype=float))
    if materials is None:
        materials = {
            name: pra.Material(energy_absorption=float(a))
            for name, a in zip(PRA_WALL_NAMES, room.wall_absorption)
        }
    previous = pra.constants.get("rir_hpf_enable")
    pra.constants.set("rir_hpf_enable", False)
    try:
        proom = pra.ShoeBox(
            list(room.dims_m), fs=fs, materials=materials, max_order=max_order,
            air_absorption=False, ray_tracing=False,
        )
        proom.set_sound_speed(room.c)
        if air_absorption is not None:
            proom.set_air_absorption([float(v) for v in air_absorption])
        proom.add_source(list(src), directivity=directivity)
        proom.add_microphone_array(mics.T)
        proom.compute_rir()
    finally:
        pra.constants.set("rir_hpf_enable", previous)
    rirs = [np.asarray(proom.rir[m][0], dtype=float)[PRA_GLOBAL_DELAY:] for m in range(len(mics))]
    n = min(r.size for r in rirs)
    return np.stack([r[:n] for r in rirs]) / (4.0 * np.pi), proom


def pyroomacoustics_rir(room: ShoeBox, source_m, mics_m, *, fs: int, max_order: int):
    """pyroomacoustics' RIRs aligned to our convention: ``(n_mics, n)`` and its image count."""
    out, proom = pyroomacoustics_rirs(room, source_m, mics_m, fs=fs, max_order=max_order)
    return out, int(proom.sources[0].images.shape[1])


def _xcorr_delay(a: np.ndarray, b: np.ndarray) -> float:
    """Delay of ``b`` relative to ``a`` in samples (cross-correlation peak, parabolic refinement)."""
    from scipy.signal import correlate

    xc = correlate(b, a, mode="full", method="fft")
    k = int(np.argmax(xc))
    frac = 0.0
    if 0 < k < xc.size - 1:
        y0, y1, y2 = xc[k - 1], xc[k], xc[k + 1]
        den = y0 - 2 * y1 + y2
        frac = 0.5 * (y0 - y2) / den if den != 0 else 0.0
    return k - (a.size - 1) + frac


def _rt(h, fs, method):
    try:
        return float(measure_rt60(h, fs, method=method))
    except ScenesimError:
        return math.nan


def compare_with_pyroomacoustics(
    room: ShoeBox, source_m, mics_m, *, fs: int, max_order: int, method: str = "exact"
) -> CrossCheck:
    """Build the same room in pyroomacoustics and measure the agreement.

    Parameters
    ----------
    room, source_m, mics_m, fs, max_order
        As for :func:`scenesim.room.ism.image_source_rir` (``max_order`` is required: both use the
        same L1 image set).
    method : {"exact", "fast", "auto"}
        Our renderer.

    Returns
    -------
    CrossCheck
        With the compared RIRs in ``.ours`` / ``.theirs`` (common length, theirs aligned).
    """
    if not isinstance(room, ShoeBox):
        raise ParameterError("room", room, "a scenesim.room.shoebox.ShoeBox")
    fs = check_fs(fs)
    max_order = check_int("max_order", max_order, minimum=0)
    ours = image_source_rir(room, source_m, mics_m, fs=fs, max_order=max_order, method=method)
    theirs, n_images = pyroomacoustics_rir(room, source_m, mics_m, fs=fs, max_order=max_order)
    n = min(ours.shape[1], theirs.shape[1])
    ours, theirs = ours[:, :n], theirs[:, :n]
    rel = tuple(
        float(np.linalg.norm(o - t) / max(np.linalg.norm(t), 1e-300)) for o, t in zip(ours, theirs)
    )
    argmax_equal = bool(np.all(np.argmax(np.abs(ours), axis=1) == np.argmax(np.abs(theirs), axis=1)))
    if ours.shape[0] >= 2:
        delay_err = _xcorr_delay(ours[0], ours[1]) - _xcorr_delay(theirs[0], theirs[1])
    else:
        delay_err = math.nan
    target = room.nominal_rt60_s
    t30_ours, t30_theirs = _rt(ours[0], fs, "T30"), _rt(theirs[0], fs, "T30")
    check = CrossCheck(
        rel_l2=rel,
        max_rel_l2=max(rel),
        argmax_equal=argmax_equal,
        inter_mic_delay_error_samples=float(delay_err),
        t20_ours_s=_rt(ours[0], fs, "T20"),
        t30_ours_s=t30_ours,
        t20_theirs_s=_rt(theirs[0], fs, "T20"),
        t30_theirs_s=t30_theirs,
        target_rt60_s=target,
        their_rt60_error=t30_theirs / target - 1.0,
        our_rt60_error=t30_ours / target - 1.0,
        n_images=n_images,
        max_order=max_order,
        fs=fs,
        ours=ours,
        theirs=theirs,
    )
    return check


def plot_crosscheck(check: CrossCheck, ours=None, theirs=None, path="crosscheck.png") -> None:
    """Write a PNG: mic-0 RIRs overlaid (first 50 ms), their difference, and both EDCs.

    ``ours``/``theirs`` default to the arrays stored in ``check``.
    """
    ours = check.ours if ours is None else ours
    theirs = check.theirs if theirs is None else theirs
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from scenesim.room.rt60 import schroeder_decay_db

    fs = check.fs
    o, t = np.atleast_2d(ours)[0], np.atleast_2d(theirs)[0]
    time_ms = np.arange(o.size) / fs * 1e3
    fig, axes = plt.subplots(3, 1, figsize=(8, 9))
    early = time_ms <= 50.0
    axes[0].plot(time_ms[early], t[early], label="pyroomacoustics (aligned)", lw=1.5)
    axes[0].plot(time_ms[early], o[early], "--", label="scenesim", lw=1.0)
    axes[0].set(xlabel="time (ms)", ylabel="h", title=f"mic 0, first 50 ms; rel L2 {check.rel_l2[0]:.2e}")
    axes[0].legend()
    axes[1].plot(time_ms, o - t, lw=0.6)
    axes[1].set(xlabel="time (ms)", ylabel="ours - theirs", title="difference")
    axes[2].plot(time_ms, schroeder_decay_db(t), label=f"pyroomacoustics T30 {check.t30_theirs_s:.3f} s")
    axes[2].plot(time_ms, schroeder_decay_db(o), "--", label=f"scenesim T30 {check.t30_ours_s:.3f} s")
    axes[2].set(xlabel="time (ms)", ylabel="EDC (dB)", ylim=(-80, 3),
                title=f"target RT60 {check.target_rt60_s:.3f} s")
    axes[2].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


__all__ = [
    "PRA_GLOBAL_DELAY",
    "PRA_WALL_NAMES",
    "CrossCheck",
    "compare_with_pyroomacoustics",
    "plot_crosscheck",
    "pyroomacoustics_rir",
    "pyroomacoustics_rirs",
]
