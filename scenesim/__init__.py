"""scenesim: acoustic scenes for a two-microphone hands-free phone.

Rooms with an own image-source method (cross-checked against pyroomacoustics), free-field
propagation, the endfire mic pair, noise fields and scene rendering.  Signals are
``(n_channels, n_samples)`` float arrays with ``fs`` in Hz passed beside them.
"""

from scenesim.errors import (
    ConfigError,
    DataError,
    MetricError,
    ParameterError,
    PluginError,
    ScenesimError,
)
from scenesim.geometry import DEFAULT_SPACING_M, SPEED_OF_SOUND_MPS, MicPair, unit_vector

__version__ = "0.1.0"
