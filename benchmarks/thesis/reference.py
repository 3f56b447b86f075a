"""The source thesis' published results (tables 7.1-7.9), shipped as ``reference/thesis_tables.csv``.

Conditions of every table: anechoic, far field, 16 kHz, two omni mics 0.0214 m apart,
speech at 45 deg, one point noise source at 270 deg, input SNR 0-25 dB in 5 dB steps,
NOISEX-92 babble / factory / wind.  PESQ is P.862 (narrow- or wide-band not stated).
Printed quirks are kept as printed (the SS tables' input PESQ differs from the EB tables';
table 7.8's 25 dB input PESQ is 3.525 where 7.2 has 3.725).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

#: Our enhancer names -> the thesis' system names.
THESIS_SYSTEMS: dict[str, str] = {"eb": "EB", "ss": "SS", "eb-ss": "EB-SS"}
#: The noises the thesis reports.
THESIS_NOISES: tuple[str, ...] = ("babble", "factory", "wind")
#: The thesis geometry: anechoic (RT60 0), speech at 45 deg, noise at 270 deg.
THESIS_GEOMETRY: dict[str, float] = {"rt60_s": 0.0, "speech_az_deg": 45.0, "noise_az_deg": 270.0}
#: The thesis' headline: EB-SS average SNR-I per noise, in dB (as quoted in its abstract).
THESIS_HEADLINE_SNR_I_DB: dict[str, float] = {"babble": 17.0, "factory": 22.0, "wind": 18.0}


@dataclass(frozen=True)
class ThesisRow:
    """One printed row: system, noise, input SNR (dB) and the printed results."""

    table: str
    system: str
    noise: str
    snr_in_db: float
    snr_out_db: float
    snr_i_db: float
    pesq_in: float
    pesq_out: float
    pesq_i: float


@lru_cache(maxsize=1)
def load_thesis_tables() -> tuple[ThesisRow, ...]:
    """All rows of tables 7.1-7.9, in file order."""
    text = resources.files("benchmarks").joinpath("reference/thesis_tables.csv").read_text()
    rows = []
    for rec in csv.DictReader(io.StringIO(text)):
        rows.append(
            ThesisRow(
                table=rec["table"],
                system=rec["system"],
                noise=rec["noise"],
                **{
                    k: float(rec[k])
                    for k in (
                        "snr_in_db",
                        "snr_out_db",
                        "snr_i_db",
                        "pesq_in",
                        "pesq_out",
                        "pesq_i",
                    )
                },
            )
        )
    return tuple(rows)


def base_name(enhancer: str) -> str:
    """The registry name without a sweep's version pin: ``"eb@1"`` -> ``"eb"``."""
    return str(enhancer).split("@", 1)[0].strip().lower()


SYSTEM_ORDER = ("passthrough", "eb", "eb-gated", "ss", "eb-ss")
"""Order in which tables and figures list systems: reference mic first, then the thesis' order."""


def system_rank(enhancer: str) -> int:
    """Sort key placing known systems in :data:`SYSTEM_ORDER` and any other plugin after them."""
    base = base_name(enhancer)
    return SYSTEM_ORDER.index(base) if base in SYSTEM_ORDER else len(SYSTEM_ORDER)


def system_order(names) -> list[str]:
    """Distinct system names in :data:`SYSTEM_ORDER`, other plugins after them by name."""
    return sorted(set(names), key=lambda n: (system_rank(n), str(n)))


def thesis_system(enhancer: str) -> str | None:
    """The thesis system our enhancer reproduces (``"eb-ss"``, ``"eb-ss@1"`` -> ``"EB-SS"``)."""
    return THESIS_SYSTEMS.get(base_name(enhancer))


def thesis_row(enhancer: str, noise: str, snr_in_db: float) -> ThesisRow | None:
    """The printed row for our ``enhancer`` name, a noise type and an input SNR, or None."""
    system = thesis_system(enhancer)
    if system is None or snr_in_db is None:
        return None
    for row in load_thesis_tables():
        if row.system == system and row.noise == noise and math.isclose(row.snr_in_db, snr_in_db):
            return row
    return None


#: The thesis' array: d = c/fs at 16 kHz (its "0.0214 cm" is a typo for metres).
THESIS_SPACING_M = 0.0214

#: Sensor keys of a condition that make its mics non-ideal when set.
_SENSOR_KEYS = ("mic_gain_db", "mic_phase_deg", "mic_highpass_hz", "self_noise_dba",
                "mic_gain_tol_db", "mic_phase_tol_deg", "mic_highpass_tol_hz")  # fmt: skip


def condition_params(row: dict) -> dict:
    """The row's condition parameters (its ``condition_json``), or {} when absent/unreadable."""
    try:
        return json.loads(row.get("condition_json") or "{}")
    except (TypeError, ValueError):
        return {}


def is_thesis_condition(row: dict) -> bool:
    """True when a results row has the thesis' exact conditions: anechoic, far field, the
    2.14 cm pair, speech at 45 deg, one point noise at 270 deg, ideal sensors, one of its noises.

    Near-field rows (``far_field`` false, e.g. the ``reverb``/``angles`` presets), other
    spacings and any non-ideal sensor (mismatch, high-pass, self-noise, tolerances) are not
    thesis conditions and are never set beside its tables.
    """
    try:
        rt60 = float(row.get("rt60_s") or 0.0)
        saz = float(row["speech_az_deg"]) % 360
        naz = float(row["noise_az_deg"]) % 360
    except (KeyError, TypeError, ValueError):
        return False
    cond = condition_params(row)
    far = row.get("far_field", cond.get("far_field"))
    spacing = row.get("spacing_m", cond.get("spacing_m"))
    ideal = row.get("ideal_sensors")
    if ideal is None:
        ideal = not any(k in cond for k in _SENSOR_KEYS)
    return (
        rt60 == 0.0
        and math.isclose(saz, THESIS_GEOMETRY["speech_az_deg"])
        and math.isclose(naz, THESIS_GEOMETRY["noise_az_deg"])
        and row.get("noise") in THESIS_NOISES
        and row.get("noise_field") in (None, "point")  # a point interferer, when recorded
        and far is not None and bool(far)
        and spacing is not None and math.isclose(float(spacing), THESIS_SPACING_M, rel_tol=1e-6)
        and bool(ideal)
    )


def thesis_averages() -> dict[tuple[str, str], dict[str, float]]:
    """Mean over the six input SNRs per (system, noise): SNR-I, output PESQ, PESQ-I.

    EB-SS gives 17.38 / 22.38 / 18.62 dB SNR-I, the thesis' "17 / 22 / 18 dB" headline.
    """
    groups: dict[tuple[str, str], list[ThesisRow]] = {}
    for row in load_thesis_tables():
        groups.setdefault((row.system, row.noise), []).append(row)
    return {
        key: {
            "snr_i_db": sum(r.snr_i_db for r in rows) / len(rows),
            "pesq_out": sum(r.pesq_out for r in rows) / len(rows),
            "pesq_i": sum(r.pesq_i for r in rows) / len(rows),
        }
        for key, rows in groups.items()
    }
