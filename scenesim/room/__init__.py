"""The room-acoustics engine: shoebox rooms, the image-source method (full, per band, hybrid),
air absorption and directivity, RT60 tools and calibration, moving sources, the RIR cache and
the pyroomacoustics cross-checks.  Imports only scenesim's core modules (errors, validate, files,
memo, audio), never the scene package."""

from scenesim.room.shoebox import register_calibrator as _register_calibrator


def _calibrate_on_first_use(*args, **kwargs):
    """``ShoeBox(rt60_method="calibrated")``'s calibrator until :mod:`scenesim.room.calibration` is
    imported (importing it registers the real one in this one's place).

    Why here: ``shoebox`` must not import the calibration (which imports it), and ``scenesim``
    loads its names lazily, so a sweep worker may build a calibrated room in a process that never
    imported the calibration; the package's ``__init__`` runs before any of its modules.
    """
    from scenesim.room.calibration import _compat_calibrator

    return _compat_calibrator(*args, **kwargs)


_register_calibrator(_calibrate_on_first_use)
