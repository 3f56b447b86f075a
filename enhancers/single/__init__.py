"""Single-channel post-filters: spectral subtraction (``ss``: Martin 1994 and 2001 noise trackers),
the noise trackers themselves (``noise_tracking``) and the MMSE log-spectral amplitude estimator
(``mmse_lsa``)."""
