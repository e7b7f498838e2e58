"""The drill without any API around it: one cycle of physics and rules, for one drill or many.

| module | holds |
|---|---|
| :mod:`~soccer_drill.drill.drills` | :class:`~soccer_drill.drill.drills.BatchDrill`: the cycle, written once, for ``n`` drills on their records |
| :mod:`~soccer_drill.drill.spaces` | the pymunk side: :class:`~soccer_drill.drill.spaces.DrillSpace` (one drill, the ball a body too: the single environments') and :class:`~soccer_drill.drill.spaces.BatchPhysics` (the players of many drills in shared spaces) |
"""
