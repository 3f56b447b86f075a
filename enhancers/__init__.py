"""Speech enhancers for scenesim and their plugin registry.

>>> import enhancers
>>> enhancers.available()                      # doctest: +SKIP
['cardioid', 'das', 'eb', 'eb-ss', 'hypercardioid', 'passthrough', 'ss', 'ss-ms2001']
>>> e = enhancers.make("eb-ss", ss={"alpha": 0.9})   # doctest: +SKIP

Algorithm modules are imported only when an enhancer is first used (registry entries
are ``"module:Class"`` strings); third-party plugins come from the entry-point group
``scenesim.enhancers``.
"""

from enhancers.base import Enhancer, Params, Result, Tags
from enhancers.chain import Chain, chain_class
from enhancers.registry import (
    EnhancerNotFound,
    available,
    describe,
    get,
    make,
    register,
    with_geometry,
)

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
