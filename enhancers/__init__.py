"""Speech enhancers for scenesim and their plugin registry.

>>> import enhancers
>>> enhancers.available()                      # doctest: +SKIP
['cardioid', 'das', 'eb', 'eb-ss', 'hypercardioid', 'passthrough', 'ss', 'ss-ms2001']
>>> e = enhancers.make("eb-ss", ss={"alpha": 0.9})   # doctest: +SKIP

Algorithm modules are imported only when an enhancer is first used (registry entries
are ``"module:Class"`` strings); third-party plugins come from the entry-point group
``scenesim.enhancers``.

The modules live in floors by job, each importing only the floors beneath it:
``core`` (contract, registry, chain, filter bank, STFT stage, EQ) < ``kernels`` (numba copies) <
``single`` (SS, noise trackers, MMSE-LSA) < ``beam`` (differential, EB, sub-band, calibration, robust,
superdirective, baselines) < ``peers`` (black-box wrappers); ``enhancers.testing`` (the conformance
suite) sits on top. The flat paths of earlier releases (``enhancers.eb``) still import, with a
``DeprecationWarning`` (:mod:`enhancers._aliases`).
"""

from enhancers import _aliases
from enhancers.core.base import Enhancer, Params, Result, Tags
from enhancers.core.chain import Chain, chain_class
from enhancers.core.registry import (
    EnhancerNotFound,
    available,
    describe,
    get,
    make,
    register,
    with_geometry,
)

_aliases.install()

__all__ = [
    "Chain",
    "Enhancer",
    "EnhancerNotFound",
    "Params",
    "Result",
    "Tags",
    "available",
    "chain_class",
    "describe",
    "get",
    "make",
    "register",
    "with_geometry",
]
