"""The batched drill's old module path: :mod:`soccer_drill.drill` holds it now."""

from __future__ import annotations

from soccer_drill.drill.drills import OUTCOME_NAMES, BatchDrill, rows
from soccer_drill.rules.cycle import RUNNING

__all__ = ["OUTCOME_NAMES", "RUNNING", "BatchDrill", "rows"]
