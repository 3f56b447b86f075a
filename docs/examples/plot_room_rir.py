"""
A room's impulse response and its T30
=====================================

A 6 x 5 x 3 m shoebox asked for an RT60 of 0.5 s, its impulse response from scenesim's own
image-source method, and the reverberation time measured back from that response per octave
(ISO 3382: T30 from the Schroeder decay curve). ``rt60_method="calibrated"`` fits the walls in a
closed loop, with diffuse scattering, until the measured T30 matches the target; Sabine's formula,
the textbook choice, misses it in a room with specular walls.
"""

import matplotlib.pyplot as plt
import numpy as np

import scenesim
from scenesim.room.iso3382 import room_parameters

fs = 16000
target_s = 0.5
source, mic = (2.0, 3.0, 1.5), (4.0, 2.0, 1.2)
fig, (ax_h, ax_t) = plt.subplots(1, 2, figsize=(10, 3.8))
for method in ("sabine", "calibrated"):
    room = scenesim.ShoeBox(dims_m=(6.0, 5.0, 3.0), rt60_s=target_s, rt60_method=method)
    h = scenesim.image_source_rir(room, source, [mic], fs=fs)[0]
    p = room_parameters(h, fs)
    t = np.arange(h.size) / fs
    ax_h.plot(t, 20 * np.log10(np.abs(h) / np.abs(h).max() + 1e-9), lw=0.5, label=method)
    ax_t.plot(p["bands_hz"], p["t30_s"], "o-", label=f"{method}: T_mid {p['t_mid_s']:.2f} s")
    print(f"{method:>10}: T30 per octave {np.round(p['t30_s'], 2)} s, C50 {p['c50_db']:.1f} dB")

ax_h.set(xlabel="time (s)", ylabel="|h| (dB re peak)", ylim=(-80, 3), title="impulse response")
ax_h.legend()
ax_t.axhline(target_s, color="k", ls="--", lw=1, label="target")
ax_t.set(xscale="log", xlabel="octave centre (Hz)", ylabel="T30 (s)", title="measured T30")
ax_t.set_xticks(p["bands_hz"], [f"{f:g}" for f in p["bands_hz"]])
ax_t.minorticks_off()
ax_t.legend(fontsize=8)
fig.tight_layout()
plt.show()
