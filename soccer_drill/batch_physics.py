"""The batched physics' old module path: :mod:`soccer_drill.drill.spaces` holds it now."""

from __future__ import annotations

from soccer_drill.drill.spaces import DRILLS_PER_SPACE, BatchPhysics, check_drills_per_space

__all__ = ["DRILLS_PER_SPACE", "BatchPhysics", "check_drills_per_space"]
