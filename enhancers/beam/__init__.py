"""Two-microphone beamformers: the differential pair and Elko's EB (``differential``, ``eb``), the
sub-band EB (``subband_eb``, ``beam_pool``), rear-mic self-calibration (``mic_calibration``,
``calibration_model``), the robust EB and its named settings (``robust_eb``, ``presets``), the
superdirective beam and the fixed baselines (``superdirective``, ``baselines``)."""
