"""
An enhancer on a scene, measured by replay
==========================================

The thesis' condition (talker at 45 deg, one point noise at 270 deg, anechoic, 5 dB at the front
mic) rendered twice: with ideal microphones, and with a rear microphone 1 dB less sensitive and
3 deg off in phase, as an untrimmed phone's. Each system's recorded operation is replayed on the
speech and on the noise apart (``Result.replay``), which gives its SNR improvement; the same
systems are also measured by phase inversion (process ``s + n`` and ``s - n``). Where the two
disagree the system adapted differently on the two mixtures, and neither number is the whole story.
"""

import matplotlib.pyplot as plt
import numpy as np

import enhancers
import scenesim
from benchmarks.metrics.speech import snr_db
from data_recipes.artificial_voice import artificial_voice

fs = 16000
speech, _ = artificial_voice(4.0, fs=fs, seed=0)
phone = scenesim.SensorModel(mics=(scenesim.MicResponse(), scenesim.MicResponse(gain_db=-1.0, phase_deg=3.0)))
systems = ["eb", "ss", "eb-ss", "eb-robust-ss"]


def snr_improvements(rendered, name):
    """(replay SNR-I, phase-inversion SNR-I) in dB of system ``name`` on one rendered scene."""
    e = enhancers.make(name)
    k = e.tags.channels_in  # a single-channel system takes the front (reference) mic
    s, n = rendered.speech_image[:k], rendered.noise_image[:k]
    result = e.process(s + n, fs=fs)
    snr_in = snr_db(s[0], n[0])
    replay = snr_db(result.replay(s), result.replay(n)) - snr_in
    y1, y2 = result.output, e.process(s - n, fs=fs).output
    hagerman = snr_db((y1 + y2) / 2, (y1 - y2) / 2) - snr_in
    return replay, hagerman


fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
for ax, (label, sensors) in zip(axes, [("ideal microphones", None), ("rear mic 1 dB / 3 deg off", phone)]):
    r = scenesim.render_scene(scenesim.Scene(snr_db=5.0, seed=0, sensors=sensors), speech, [None])
    values = np.array([snr_improvements(r, name) for name in systems])
    x = np.arange(len(systems))
    ax.bar(x - 0.2, values[:, 0], 0.4, label="replay")
    ax.bar(x + 0.2, values[:, 1], 0.4, label="phase inversion")
    ax.set(xticks=x, xticklabels=systems, title=label)
    ax.axhline(0, color="k", lw=0.8)
    for name, (rep, hag) in zip(systems, values):
        print(f"{label:>26} {name:>13}: replay {rep:6.1f} dB, phase inversion {hag:6.1f} dB")
axes[0].set_ylabel("SNR improvement (dB)")
axes[0].legend()
fig.tight_layout()
plt.show()
