"""The drill's rules, each written once for one drill's arrays and compiled per drill.

| module | holds |
|---|---|
| :mod:`~soccer_drill.rules.compiled` | the ``compiled`` decorator (numba, or plain Python with the same floats), ``hypot``, ``warm_up`` |
| :mod:`~soccer_drill.rules.motion` | the skills: a command to a desired velocity and a ball action |
| :mod:`~soccer_drill.rules.cycle` | around the physics: the acceleration cap, the ball, the speed caps, possession and tackles, the outcome; an episode's start |
| :mod:`~soccer_drill.rules.first_use` | every rule called once, so that ``warm_up`` compiles them before a team's time bound |

The drill (:class:`~soccer_drill.drill.BatchDrill`, one drill or many) and the batched
teams run them through their loops over drills; the single teams and skills call them
for one drill. The observations' rules are in
:mod:`soccer_drill.rules.features`, the support player's in :mod:`soccer_drill.rules.support`.
"""
