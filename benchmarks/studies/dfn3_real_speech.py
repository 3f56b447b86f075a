"""DeepFilterNet3 on real speech in real babble: DNSMOS, PESQ and STOI before and after.

    python -m benchmarks.studies.dfn3_real_speech --data-dir ../shared/data [--snr 5] [--noise cafe]

The learned suppressor must be measured on real speech: the built-in artificial voice
misleads it (as it misleads RNNoise).  Each CMU ARCTIC utterance in ``DATA/speech`` (at
-26 dBFS) gets a different excerpt of the noise recording ``DATA/noise/<noise>_*.wav``
(``cafe``: a restaurant with many talkers, the real babble) at ``--snr`` dB (active speech
level, :func:`scenesim.scene.mixing.mix_at_snr`), single channel; ``dfn3`` (default parameters)
processes it, the output is aligned by its declared latency and scored against the clean
utterance by :func:`benchmarks.metrics.scoring.score`.  Targets (issue 19): DNSMOS BAK up by >= 0.5,
wide-band PESQ up, DNSMOS OVRL of the clean speech above the noisy.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.metrics.scoring import score
from benchmarks.metrics.speech import align
from scenesim.audio import read_audio
from scenesim.scene.mixing import mix_at_snr

FS = 16000
KEYS = ("dnsmos_sig", "dnsmos_bak", "dnsmos_ovrl", "pesq_wb_mos_lqo", "pesq_nb_mos_lqo", "stoi", "si_sdr_db")


def _noise(data_dir: Path, noise: str) -> np.ndarray:
    files = sorted((data_dir / "noise").glob(f"{noise}_*.wav")) + sorted((data_dir / "noise").glob(f"{noise}.wav"))
    if not files:
        raise SystemExit(f"no {noise}_*.wav in {data_dir / 'noise'}")
    return read_audio(files[0], fs=FS)[0][0]


def measure(data_dir: Path, *, snr_db: float = 5.0, noise: str = "cafe") -> list[dict]:
    """One dict per utterance: ``{"file", "<key>_clean", "<key>_noisy", "<key>_dfn3"}`` for :data:`KEYS`."""
    import enhancers

    e = enhancers.make("dfn3")
    lat = e.tags.latency_samples
    bank = _noise(data_dir, noise)
    rows = []
    for i, path in enumerate(sorted((data_dir / "speech").glob("*.wav"))):
        s = read_audio(path, fs=FS)[0][0]
        s = 0.05 * s / np.sqrt(np.mean(s**2))
        start = (i * 7919) % max(1, bank.size - s.size)  # a different excerpt per utterance
        x = mix_at_snr(s, bank[start:start + s.size], snr_db, mode="active", fs=FS)[0]
        y, ref = align(e.process(x[None], FS).output[0], s, latency_samples=lat)
        row = {"file": path.name}
        for label, sig, r in (("clean", s, s), ("noisy", x, s), ("dfn3", y, ref)):
            scores = score(sig, FS, reference=r)
            row.update({f"{k}_{label}": scores[k] for k in KEYS})
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, required=True, help="folder with speech/ and noise/")
    ap.add_argument("--snr", type=float, default=5.0)
    ap.add_argument("--noise", default="cafe")
    args = ap.parse_args(argv)
    rows = measure(args.data_dir, snr_db=args.snr, noise=args.noise)
    print(f"dfn3 on {len(rows)} real utterances in {args.noise} noise at {args.snr:g} dB (mean over utterances)")
    print("| metric | clean | noisy | dfn3 | dfn3 - noisy |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for k in KEYS:
        vals = {lab: float(np.mean([r[f"{k}_{lab}"] for r in rows if r[f"{k}_{lab}"] is not None]))
                for lab in ("clean", "noisy", "dfn3")}
        print(f"| {k} | {vals['clean']:.2f} | {vals['noisy']:.2f} | {vals['dfn3']:.2f} | {vals['dfn3'] - vals['noisy']:+.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
