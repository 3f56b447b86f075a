"""Compiled (numba) copies of the enhancers' inner loops; the numpy code stays the reference.

``wola`` (FFT tables and the fused analysis/synthesis loops), ``stream`` (streaming steps of EB,
SS and the fixed beams), ``robust`` (the sub-band robust EB's frame loop), ``noise_stats`` (the
noise-statistics stage's frame loops), ``spp_eb`` (``eb-spp``'s per-frame closed forms) and
``frames`` (the glue that packs an enhancer's parameters into the kernels' arrays). A kernel imports
only ``enhancers.core``: the algorithm modules above call down into it, never the reverse.
"""
