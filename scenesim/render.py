"""``scenesim.render.room_rir`` is a fixed public name (design/contract.md); the renderer lives in
:mod:`scenesim.room.render`."""

from scenesim.room.render import room_rir  # noqa: F401  (re-export of the fixed public path)
