"""scenesim: acoustic scenes for a two-microphone hands-free phone.

Rooms with an own image-source method (cross-checked against pyroomacoustics), free-field
propagation, the endfire mic pair, noise fields and scene rendering.  Signals are
``(n_channels, n_samples)`` float arrays with ``fs`` in Hz passed beside them.
"""

from scenesim.air import AirAbsorption
from scenesim.audio import read_audio, resample, write_audio
from scenesim.bands import OCTAVE_CENTERS_HZ, octave_rt60
from scenesim.cache import cached_rir
from scenesim.calibration import calibrate_room
from scenesim.crosscheck import compare_with_pyroomacoustics
from scenesim.errors import (
    ConfigError,
    DataError,
    MetricError,
    ParameterError,
    PluginError,
    ScenesimError,
)
from scenesim.fractional_delay import delay_signal, fractional_delay_filter
from scenesim.freefield import plane_wave, point_source
from scenesim.geometry import DEFAULT_SPACING_M, SPEED_OF_SOUND_MPS, MicPair, unit_vector
from scenesim.ism import image_source_rir
from scenesim.mixing import mix_at_snr, noise_gain_for_snr
from scenesim.moving import render_moving_source
from scenesim.noise_fields import (
    corcos_coherence,
    diffuse_noise,
    incoherent_noise,
    sensor_noise,
    wind_noise,
)
from scenesim.render import room_rir
from scenesim.room import ShoeBox
from scenesim.rt60 import eyring_rt60, measure_rt60, sabine_rt60
from scenesim.scene import (
    NoiseSource,
    RenderedScene,
    Scene,
    SceneImages,
    SourcePlacement,
    render_images,
    render_scene,
)
from scenesim.sensors import MicResponse, SensorModel, SensorTolerance

__version__ = "0.1.0"
