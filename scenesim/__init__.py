"""scenesim: acoustic scenes for a two-microphone hands-free phone.

Rooms with an own image-source method (cross-checked against pyroomacoustics), free-field
propagation, the endfire mic pair, noise fields and scene rendering.  Signals are
``(n_channels, n_samples)`` float arrays with ``fs`` in Hz passed beside them.

The names below are loaded on first use (PEP 562): ``import scenesim`` alone costs nothing
beyond this file, so a command that needs one module (``scenesim bench report``) does not pay for
scipy.signal (~1.5 s) through ``scenesim.audio``.
"""

from __future__ import annotations

from scenesim.lazy import lazy_exports

__version__ = "0.1.0"

# public name -> the module that defines it
_SOURCES = {
    "read_audio": "scenesim.audio",
    "resample": "scenesim.audio",
    "write_audio": "scenesim.audio",
    "ConfigError": "scenesim.errors",
    "DataError": "scenesim.errors",
    "MetricError": "scenesim.errors",
    "ParameterError": "scenesim.errors",
    "PluginError": "scenesim.errors",
    "ScenesimError": "scenesim.errors",
    "AirAbsorption": "scenesim.room.air",
    "OCTAVE_CENTERS_HZ": "scenesim.room.bands",
    "octave_rt60": "scenesim.room.bands",
    "cached_rir": "scenesim.room.cache",
    "calibrate_room": "scenesim.room.calibration",
    "compare_with_pyroomacoustics": "scenesim.room.crosscheck",
    "image_source_rir": "scenesim.room.ism",
    "render_moving_source": "scenesim.room.moving",
    "room_rir": "scenesim.room.render",
    "eyring_rt60": "scenesim.room.rt60",
    "measure_rt60": "scenesim.room.rt60",
    "sabine_rt60": "scenesim.room.rt60",
    "ShoeBox": "scenesim.room.shoebox",
    "NoiseSource": "scenesim.scene.compose",
    "RenderedScene": "scenesim.scene.compose",
    "Scene": "scenesim.scene.compose",
    "SceneImages": "scenesim.scene.compose",
    "SourcePlacement": "scenesim.scene.compose",
    "render_images": "scenesim.scene.compose",
    "render_scene": "scenesim.scene.compose",
    "delay_signal": "scenesim.scene.fractional_delay",
    "fractional_delay_filter": "scenesim.scene.fractional_delay",
    "plane_wave": "scenesim.scene.freefield",
    "point_source": "scenesim.scene.freefield",
    "DEFAULT_SPACING_M": "scenesim.scene.geometry",
    "SPEED_OF_SOUND_MPS": "scenesim.scene.geometry",
    "MicPair": "scenesim.scene.geometry",
    "unit_vector": "scenesim.scene.geometry",
    "mix_at_snr": "scenesim.scene.mixing",
    "noise_gain_for_snr": "scenesim.scene.mixing",
    "corcos_coherence": "scenesim.scene.noise_fields",
    "diffuse_noise": "scenesim.scene.noise_fields",
    "incoherent_noise": "scenesim.scene.noise_fields",
    "sensor_noise": "scenesim.scene.noise_fields",
    "wind_noise": "scenesim.scene.noise_fields",
    "MicResponse": "scenesim.scene.sensors",
    "SensorModel": "scenesim.scene.sensors",
    "SensorTolerance": "scenesim.scene.sensors",
}

__all__ = sorted(_SOURCES)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)
