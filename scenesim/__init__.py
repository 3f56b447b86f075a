"""scenesim: acoustic scenes for a two-microphone hands-free phone.

Rooms with an own image-source method (cross-checked against pyroomacoustics), free-field
propagation, the endfire mic pair, noise fields and scene rendering.  Signals are
``(n_channels, n_samples)`` float arrays with ``fs`` in Hz passed beside them.
"""

from scenesim.audio import read_audio, resample, write_audio
from scenesim.errors import (
    ConfigError,
    DataError,
    MetricError,
    ParameterError,
    PluginError,
    ScenesimError,
)
from scenesim.room.air import AirAbsorption
from scenesim.room.bands import OCTAVE_CENTERS_HZ, octave_rt60
from scenesim.room.cache import cached_rir
from scenesim.room.calibration import calibrate_room
from scenesim.room.crosscheck import compare_with_pyroomacoustics
from scenesim.room.ism import image_source_rir
from scenesim.room.moving import render_moving_source
from scenesim.room.render import room_rir
from scenesim.room.rt60 import eyring_rt60, measure_rt60, sabine_rt60
from scenesim.room.shoebox import ShoeBox
from scenesim.scene.compose import (
    NoiseSource,
    RenderedScene,
    Scene,
    SceneImages,
    SourcePlacement,
    render_images,
    render_scene,
)
from scenesim.scene.fractional_delay import delay_signal, fractional_delay_filter
from scenesim.scene.freefield import plane_wave, point_source
from scenesim.scene.geometry import DEFAULT_SPACING_M, SPEED_OF_SOUND_MPS, MicPair, unit_vector
from scenesim.scene.mixing import mix_at_snr, noise_gain_for_snr
from scenesim.scene.noise_fields import (
    corcos_coherence,
    diffuse_noise,
    incoherent_noise,
    sensor_noise,
    wind_noise,
)
from scenesim.scene.sensors import MicResponse, SensorModel, SensorTolerance

__version__ = "0.1.0"
