"""
Scoring two files against a clean reference
===========================================

What ``scenesim score noisy.wav enhanced.wav --ref clean.wav`` does, in Python: each file is
time-aligned to the reference (here the enhanced file is written 20 ms late on purpose; the
cross-correlation finds that lag plus ``ss``'s own latency), then scored by PESQ, STOI, SI-SDR and the other metrics of
:mod:`benchmarks.metrics.scoring`. The files stand in for your own recordings.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import enhancers
import scenesim
from benchmarks.metrics.scoring import score_files
from data_recipes.artificial_voice import artificial_voice

fs = 16000
speech, _ = artificial_voice(4.0, fs=fs, seed=1)
r = scenesim.render_scene(scenesim.Scene(snr_db=5.0, seed=1), speech, [None])
noisy = r.mixture[0]
enhanced = enhancers.make("ss").process(r.mixture[:1], fs=fs).output[0]
late = np.concatenate([np.zeros(int(0.02 * fs)), enhanced])[: enhanced.size]

folder = Path(tempfile.mkdtemp())
for name, x in [("clean", r.reference[0]), ("noisy", noisy), ("enhanced", late)]:
    scenesim.write_audio(folder / f"{name}.wav", x, fs)
rows = score_files([folder / "noisy.wav", folder / "enhanced.wav"], folder / "clean.wav", dnsmos=False)

metrics = ["pesq_wb_mos_lqo", "stoi", "estoi"]
for row in rows:
    print(f"{Path(row['file']).name:>12}: lag {row['lag_samples']} samples, "
          + ", ".join(f"{m} {row[m]:.2f}" for m in metrics) + f", SI-SDR {row['si_sdr_db']:.1f} dB")
fig, ax = plt.subplots(figsize=(7, 3.5))
x = np.arange(len(metrics))
for k, row in enumerate(rows):
    ax.bar(x + 0.4 * k - 0.2, [row[m] for m in metrics], 0.4, label=Path(row["file"]).stem)
ax.set(xticks=x, xticklabels=metrics, ylabel="score", title="ss at 5 dB input, white noise")
ax.legend()
fig.tight_layout()
plt.show()
