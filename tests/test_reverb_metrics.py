"""SINR / DRR / C50 / SRMR columns from the speech parts (benchmarks/metrics/reverb.py)."""

import dataclasses

import numpy as np
import pytest

from benchmarks.metrics import speech as M
from benchmarks.metrics.evaluate import ROW_COLUMNS, evaluate_enhancer, input_metrics
from benchmarks.metrics.reverb import theory_drr_c50_db
from enhancers.core.registry import make, with_geometry
from scenesim.room.reverb_parts import speech_parts
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import NoiseSource, Scene, SourcePlacement, render_images
from scenesim.scene.geometry import MicPair

FS = 16000


@pytest.fixture(scope="module")
def case():
    scene = Scene(
        pair=MicPair((2.0, 1.8, 0.9), axis_azimuth_deg=90.0),
        room=ShoeBox((5.0, 4.0, 2.8), rt60_s=0.5),
        speech=SourcePlacement(60.0, 1.0),
        noises=(NoiseSource(field="point", azimuth_deg=200.0, distance_m=1.5),),
        far_field=False,
        reference="early50",
        snr_db=5.0,
    )
    rng = np.random.default_rng(7)
    s = rng.standard_normal(int(1.5 * FS)) * (1 + np.sin(2 * np.pi * 3 * np.arange(int(1.5 * FS)) / FS))
    images = render_images(scene, s, [None])
    parts = speech_parts(images, s)
    rendered = images.mix()
    inputs = input_metrics(rendered, speech_parts=parts, reference="early50")
    return rendered, parts, inputs


def _row(enhancer, case):
    rendered, parts, inputs = case
    return evaluate_enhancer(enhancer, rendered, input_metrics=inputs, speech_parts=parts)


def test_columns_are_registered():
    for name in ("sinr_in_db", "sinr_out_db", "sinr_i_db", "drr_in_db", "drr_out_db", "c50_in_db",
                 "c50_out_db", "srmr_in", "srmr_out", "metric_target", "early_window_ms"):
        assert name in ROW_COLUMNS


def test_input_columns_by_definition(case):
    # Oracle: the definitions on the parts' channel 0 (direct d, early e, late l, noise n).
    rendered, parts, inputs = case
    d, e, late, n = parts.direct[0], parts.early[0], parts.late[0], rendered.noise_image[0]
    p = lambda x: float(np.mean(x**2))  # noqa: E731
    assert inputs["sinr_in_db"] == pytest.approx(10 * np.log10(p(d + e) / p(late + n)), abs=1e-9)
    assert inputs["drr_in_db"] == pytest.approx(10 * np.log10(p(d) / p(e + late)), abs=1e-9)
    assert inputs["c50_in_db"] == pytest.approx(10 * np.log10(p(d + e) / p(late)), abs=1e-9)
    assert inputs["metric_target"] == "early50" and inputs["early_window_ms"] == 50.0
    # SINR counts the late reverberation as interference: below the noise-only SNR.
    assert inputs["sinr_in_db"] < inputs["snr_in_db_measured"]


def test_passthrough_output_equals_input(case):
    # Oracle: the identity leaves every ratio unchanged (tolerance: rounding, 1e-9 dB).
    row = _row(make("passthrough"), case)
    assert row["status"] == "ok" and row["error"] is None
    assert row["sinr_i_db"] == pytest.approx(0.0, abs=1e-9)
    assert row["sinr_out_db"] == pytest.approx(row["sinr_in_db"], abs=1e-9)
    assert row["drr_out_db"] == pytest.approx(row["drr_in_db"], abs=1e-9)
    assert row["c50_out_db"] == pytest.approx(row["c50_in_db"], abs=1e-9)
    assert row["srmr_out"] == pytest.approx(row["srmr_in"], rel=1e-9)


def _das():
    return with_geometry(make("das"), spacing_m=0.0214)


def _das_row_and_parts(case):
    """The DAS row, and the direct, early, late and noise parts each processed on their own
    (no replay) and latency-aligned to the reference: the oracle of the replayed ratios."""
    rendered, parts, _ = case
    enh = _das()
    row = _row(enh, case)
    lat = enh.tags.latency_samples
    ref = rendered.reference[0]

    def out(x):
        return M.align(enh.process(x, FS).output[0], ref, latency_samples=lat)[0]

    return row, tuple(out(x) for x in (parts.direct, parts.early, parts.late, rendered.noise_image))


def test_replay_through_a_linear_enhancer_matches_processing_each_part(case):
    # Oracle: a fixed (LTI) beamformer processed on each part separately -- no replay --
    # gives the output parts; the ratios over the latency-aligned first channel must agree
    # with the replayed ones to 1e-9 dB.
    row, (d, e, late, n) = _das_row_and_parts(case)
    assert row["sinr_out_db"] == pytest.approx(M.snr_db(d + e, late + n), abs=1e-9)
    assert row["drr_out_db"] == pytest.approx(M.snr_db(d, e + late), abs=1e-9)
    assert row["c50_out_db"] == pytest.approx(M.snr_db(d + e, late), abs=1e-9)


def test_black_box_sinr_by_phase_inversion_equals_replay_for_an_lti_system(case):
    # Oracle: phase inversion is exact for a linear time-invariant system (Hagerman &
    # Olofsson 2004), so a black-box copy of the same LTI beamformer gives the replay SINR
    # (tolerance 1e-6 dB); DRR/C50 of a black box stay None (documented).
    enh = _das()
    replay_row = _row(enh, case)

    class BlackBox(type(enh)):
        @property
        def tags(self):
            return dataclasses.replace(super().tags, replayable=False)

    bb = BlackBox(**enh.params.to_dict())
    row = _row(bb, case)
    assert row["sinr_out_db"] == pytest.approx(replay_row["sinr_out_db"], abs=1e-6)
    assert row["drr_out_db"] is None and row["c50_out_db"] is None


def test_theory_drr_c50():
    # At the critical distance the direct and reverberant energies are equal: DRR = 0 dB;
    # C50 = 10 log10((1 + 1 - q) / q), q = exp(-13.82 * 0.05 / T).
    q = np.exp(-6 * np.log(10) * 0.05 / 0.5)
    drr, c50 = theory_drr_c50_db(1.0, 1.0, 0.5)
    assert drr == pytest.approx(0.0, abs=1e-12)
    assert c50 == pytest.approx(10 * np.log10((2 - q) / q), abs=1e-12)


def test_sinr_i_db_of_a_beamformer_is_the_independent_difference_with_its_sign(case):
    # Issue 15 part 5: on passthrough SINR-I is 0 whatever its sign; here a fixed beamformer.
    # Oracle: each part processed separately (no replay), ratios by the definition over the
    # latency-aligned samples; SINR-I = out - in, non-zero, with the oracle's sign (1e-9 dB).
    rendered, parts, _ = case
    row, (d, e, late, n) = _das_row_and_parts(case)
    m = d.size
    p = lambda x: float(np.sum(x**2))  # noqa: E731
    sinr_in = 10 * np.log10(p(parts.target[0][:m]) / p(parts.late[0][:m] + rendered.noise_image[0][:m]))
    expected = 10 * np.log10(p(d + e) / p(late + n)) - sinr_in
    assert abs(expected) > 0.3  # a real change, so a flipped sign or a dropped term shows
    assert row["sinr_i_db"] == pytest.approx(expected, abs=1e-9)
