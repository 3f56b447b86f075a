"""The enhancer contract and the blocks every enhancer shares.

``base`` (``Enhancer``, ``Params``, ``Tags``, ``Result`` with ``replay``), ``registry`` (versioned
names, lazy ``"module:Class"`` entries, entry-point plugins), ``chain`` (a cascade is an enhancer),
``filterbank`` (WOLA analysis/synthesis), ``stft_stage`` (the shared STFT-domain stage) and ``eq``
(the differential pair's look-direction equaliser). Nothing here imports another floor of
``enhancers``; the conformance suite that checks every enhancer is :mod:`enhancers.testing`.
"""
