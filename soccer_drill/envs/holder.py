"""The ball holder's view of the drill, an SMDP: :class:`HolderLoop`, the one loop of a
holder's decisions over a core's drills, and :class:`HolderEnv`, one drill of it as a
Gymnasium environment (``soccer_drill/Holder-v0``).
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Mapping
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from soccer_drill.commands import (
    HOLDER_ACTIONS,
    Skill,
    action_letters,
    attacker_action_skills,
    holder_action_names,
)
from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import DrillSpace
from soccer_drill.envs.core import (
    SEED,
    BatchCore,
    Observation,
    check_reset_options,
    make_config,
    not_reset,
)
from soccer_drill.envs.pickling import Pickled
from soccer_drill.rendering.scene import FrameStyle, Scene
from soccer_drill.rendering.screen import RENDER_MODES, HeaderTexts, Screen, frames_per_second
from soccer_drill.rules.arrays import OUTCOME_NAMES, Outcome
from soccer_drill.rules.compiled import bind, compiled, warms
from soccer_drill.rules.motion import ranked_teammate
from soccer_drill.rules.support import SupportDraws, support_commands
from soccer_drill.rules.task_rules import cycle_reward, task_rules
from soccer_drill.teams.registry import DEFAULT_TEAM_TIMEOUT, Team

DECISION_CYCLES_RANGE = (1, 50)
"""The cycles a HOLD or DRIBBLE may last (``decision_cycles``)."""
DECISION_CYCLES = Integer(*DECISION_CYCLES_RANGE)
"""What ``decision_cycles`` may be: an integer in :data:`DECISION_CYCLES_RANGE`."""
HOLDER_ACTION = Integer(0, len(HOLDER_ACTIONS) - 1)
"""The holder's actions in the 2v2 drill (``holder_action(attackers)`` for any size)."""


def holder_action(attackers: int) -> Integer:
    """What a holder's action may be with ``attackers`` attackers: an index of
    :func:`~soccer_drill.commands.holder_action_names`."""
    return Integer(0, len(holder_action_names(attackers)) - 1)


def check_holder_action(action: object, attackers: int = 2,
                        names: tuple[str, ...] | None = None) -> int:
    """``action`` as an int in [0, n - 1] (``n`` the holder's actions with ``attackers``
    attackers: 3 in the 2v2 drill; or the ``names`` given, a task's), as
    ``HolderEnv.step`` takes it: an int, a NumPy integer or a 0-d integer array; bools,
    floats and values out of range are refused."""
    count = _action_count(attackers) if names is None else len(names)
    if type(action) is int and 0 <= action < count:  # the common case
        return action
    if isinstance(action, np.ndarray) and action.shape == ():
        action = action.item()
    names = holder_action_names(attackers) if names is None else names
    if not Integer(0, len(names) - 1).allows(action):
        raise ValueError(holder_action_refused(action, attackers, names))
    return int(action)  # type: ignore[call-overload]


@functools.cache
def _action_count(attackers: int) -> int:
    return len(holder_action_names(attackers))


def holder_action_refused(action: object, attackers: int = 2,
                          names: tuple[str, ...] | None = None) -> str:
    """Why ``action`` is not a holder action, in the vocabulary's words."""
    names = holder_action_names(attackers) if names is None else names
    words = ", ".join(f"{k}={name}" for k, name in enumerate(names))
    return f"action must be {Integer(0, len(names) - 1).describe()} ({words}), got {action!r}"


# ------------------------------------------------------------------ the loop
def step_record(attackers: int) -> np.dtype:
    """One drill's holder step with ``attackers`` attackers: whether it runs, whether the
    holder's action still does (and for how many more cycles), who decided and what (the
    action, its skill and a pass's receiver), the cycle it began at, and which attackers
    the support behaviour drives this cycle."""
    return np.dtype([
        ("running", np.bool_),
        ("in_action", np.bool_),
        ("decider", np.int64),
        ("action", np.int64),
        ("left", np.int64),
        ("start", np.int64),
        ("supporting", np.int8, (attackers,)),
        ("skill", np.int64),
        ("receiver", np.int64),
        *([] if attackers == 2 else [(f"attackers_{attackers}", np.int8, (0,))]),
    ])


_HOLD, _PASS, _DRIBBLE = int(Skill.HOLD), int(Skill.PASS), int(Skill.DRIBBLE)  # as stored
_RUNNING, _TIMEOUT = int(Outcome.RUNNING), int(Outcome.TIMEOUT)  # an enum lookup costs ~1 us
STEP = step_record(2)
"""One drill's holder step in the 2v2 drill (:func:`step_record`)."""


def _get_decision_cycles(env: Any) -> int:
    return env.loop.decision_cycles


def _set_decision_cycles(env: Any, value: int) -> None:
    env.loop.decision_cycles = checked("decision_cycles", value, DECISION_CYCLES)


DECISION_CYCLES_OF_LOOP = property(
    _get_decision_cycles, _set_decision_cycles,
    doc="Cycles a HOLD or DRIBBLE lasts: the holder loop's; setting it (``set_attr`` too) "
        "changes the decisions that follow (a curriculum), checked as the argument is.")
"""An environment's ``decision_cycles``: its holder loop's, read and set."""


@compiled
def _begin(steps, state, drills, actions, decision_cycles):
    """The holders of ``drills`` take ``actions``: their drills run again. Action 0 is
    ``HOLD``, the last ``DRIBBLE``, each between a ``PASS`` to the teammate of its rank
    by distance now (1: the nearest)."""
    attackers = steps[0].supporting.shape[0]
    for r in range(drills.shape[0]):
        i = drills[r]
        h, s = steps[i], state[i]
        a = actions[r]
        h.decider = s.holder
        h.action = a
        h.receiver = -1
        if a == 0:
            h.skill = _HOLD
        elif a < attackers:
            h.skill = _PASS
            h.receiver = ranked_teammate(s.pos, s.holder, attackers, a - 1)
        else:
            h.skill = _DRIBBLE
        h.left = 1 if h.skill == _PASS else decision_cycles
        h.start = s.cycle
        h.in_action = True
        h.running = True


@compiled
def _holder_commands(steps, cycle):
    """A cycle's commands as the loop gives them: each drill's holder in action runs its
    action's skill at full speed (a pass to its receiver); the support behaviour drives
    the other attackers, or every attacker while the ball is loose in a running drill.
    Returns the number of drills with an attacker to support."""
    count = 0
    for i in range(steps.shape[0]):
        h = steps[i]
        acting, d = h.in_action, h.decider
        if acting:
            cycle[i].skill[d] = h.skill
            cycle[i].speed[d] = 1.0
            cycle[i].receiver[d] = h.receiver
        free = h.running and not acting
        any_supported = False
        for k in range(h.supporting.shape[0]):
            h.supporting[k] = (acting and d != k) or free
            if h.supporting[k]:
                any_supported = True
        if any_supported:
            count += 1
    return count


@compiled
def _cycle_commands(steps, state, cycle, supporting, support, size):
    """:func:`_holder_commands`, then the support behaviour's commands where an attacker
    is supported (:func:`~soccer_drill.rules.support.support_commands`, in the same call):
    -1, or the first drill whose support draws ran out (finish with
    :meth:`~soccer_drill.rules.support.SupportDraws.finish`)."""
    if _holder_commands(steps, cycle):
        return support_commands(state, cycle, supporting, support, 0, size)
    return -1


@compiled
def _after_cycle(steps, state):
    """After a cycle: a drill's action goes on while its holder keeps the ball, for the
    cycles left; the drill runs on until an outcome, or until an attacker holds the ball
    again once the action is over. Returns the number of drills still running."""
    running = 0
    attackers = steps[0].supporting.shape[0]
    for i in range(steps.shape[0]):
        h, s = steps[i], state[i]
        if h.in_action:
            h.left -= 1
        ended = s.outcome != Outcome.RUNNING
        h.in_action = h.in_action and not ended and s.holder == h.decider and h.left > 0
        h.running = h.running and not ended and (
            h.in_action or not (0 <= s.holder < attackers))
        if h.running:
            running += 1
    return running


class HolderLoop:
    """The ball holder's SMDP over the drills of a :class:`~soccer_drill.envs.core.BatchCore`:
    the one loop of :class:`HolderEnv` (one drill), :class:`~soccer_drill.vector.holder.HolderVectorEnv`
    and :func:`~soccer_drill.vector.holder.play_episodes`.

    A drill's step begins when its holder decides (:meth:`begin`): the holder runs its
    action's skill for ``decision_cycles`` cycles (HOLD, DRIBBLE) or one (PASS) while it
    keeps the ball, the other attacker driven by the support behaviour; then the drill
    cycles, both attackers supporting, until an attacker holds the ball again (the next
    decision) or the episode ends. :meth:`cycle` runs one cycle of every drill whose step
    runs; the others stand still.

    Attributes
    ----------
    core
        The drills, their generators, team and support players.
    running
        ``(n,)`` bool: the drills whose step runs (a view; read it, do not write it).
    decider
        ``(n,)`` the attacker whose decision a drill's step runs.
    action
        ``(n,)`` that decision (a holder action: an index of :attr:`action_names`).
    start
        ``(n,)`` the cycle at which a drill's step began (its episode's start after
        :meth:`start`).
    handed_to
        Who played these drills outside the environment that owns them (``None``: nobody
        since its last reset): that environment then asks for a reset.
    """

    def __init__(self, core: BatchCore, decision_cycles: int) -> None:
        self.core = core
        self.decision_cycles = checked("decision_cycles", decision_cycles, DECISION_CYCLES)
        cfg = core.config
        self.attackers = cfg.attackers
        rules = task_rules(cfg)
        self.action_names = rules.holder_actions(cfg.attackers)
        """The holder's actions, in index order (``HOLD, PASS, DRIBBLE`` in the 2v2 drill;
        keepaway's ``HOLD, PASS_1, PASS_2`` at 3v2)."""
        self.cycle_reward = cycle_reward(cfg)
        """What the attackers are paid per cycle of a step (0 in the drill; keepaway:
        ``cycle_seconds``, its reward being the time the keepers hold the ball)."""
        self.steps = np.zeros(core.n, dtype=step_record(cfg.attackers))
        if core.support is None:
            raise ValueError("the holder loop needs a core with support players (support=True)")
        self._field_size = cfg.field_size
        self._drill_support = isinstance(core.support, SupportDraws)
        self.handed_to: str | None = None
        self.observe = Observation(rules.holder_observation, cfg)
        """The holder's observation (its features: the 9 in the 2v2 drill; keepaway's
        state variables) of drills (``observe(state, rows, players)``)."""
        self._views()

    def _views(self) -> None:
        steps = self.steps
        self.running, self.decider, self.start = steps["running"], steps["decider"], steps["start"]
        self.action = steps["action"]
        self._supporting = steps["supporting"]
        self._bound: tuple | None = None  # the cycle's rules bound to the arrays (cycle())
        self._results_bound: tuple | None = None  # results() of every drill, bound
        self._begin_bound: tuple | None = None  # begin() of every drill, bound

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        for name in ("running", "decider", "start", "action", "_supporting", "_bound",
                     "_results_bound", "_begin_bound"):
            del state[name]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._views()

    def restart(self, drills: np.ndarray) -> None:
        """A new episode in each of ``drills`` (each drill's stream goes on); they then
        wait for their holder's decision, the step counted from their start."""
        self.core.reset(drills)
        steps = self.steps
        steps["running"][drills] = False
        steps["in_action"][drills] = False
        steps["start"][drills] = 0

    def begin(self, drills: np.ndarray, actions: np.ndarray) -> None:
        """The holders of ``drills`` (int64, ascending) take ``actions`` (int64, checked:
        indices of :attr:`action_names`): their drills' steps run."""
        if drills is not self.core.every:
            _begin(self.steps, self.core.batch.state, drills, actions, self.decision_cycles)
            return
        bound = self._begin_bound  # every drill: bound to one array of actions (bind)
        if bound is None or bound[0] != self.decision_cycles:
            chosen = np.empty(self.core.n, np.int64)
            bound = self._begin_bound = (self.decision_cycles, chosen, bind(
                _begin, self.steps, self.core.batch.state, drills, chosen,
                self.decision_cycles))
        bound[1][:] = actions
        bound[2]()

    def cycle(self, drills: np.ndarray | None = None) -> int:
        """One cycle of every drill whose step runs (``drills``: their indices, if the
        caller has them); returns how many still run."""
        core, steps = self.core, self.steps
        batch, support, size = core.batch, core.support, self._field_size
        bound = self._bound
        if bound is None:  # the arrays are the same every cycle (rules.compiled.bind)
            bound = self._bound = (
                bind(_cycle_commands, steps, batch.state, batch.commands, self._supporting,
                     support.records, size) if self._drill_support else None,
                bind(_after_cycle, steps, batch.state))
        if self._drill_support:  # the holder's and the support's commands in one call
            start = bound[0]()
            if start >= 0:
                support.finish(batch.state, batch.commands, self._supporting, size, start)
        elif _holder_commands(steps, batch.commands):  # another task's support behaviour
            support.commands(batch.state, batch.commands, self._supporting, size)
        core.advance(self.running, drills)
        return bound[1]()

    def check_action(self, action: object) -> int:
        """``action`` as an index of :attr:`action_names` (:func:`check_holder_action`)."""
        return check_holder_action(action, self.attackers, self.action_names)

    def results(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The steps of drills ``rows`` as they stand: the observations of their deciders
        (:meth:`observe`), ``ints``, ``(5, len(rows))`` int64 whose rows are
        :data:`RESULTS` (each a contiguous array), and the rewards, float64 (see
        :func:`_step_results`); new arrays every call."""
        b = self.core.batch
        if rows is not self.core.every:
            ints, rewards = np.empty((len(RESULTS), len(rows)), np.int64), np.empty(len(rows))
            _step_results(ints, rewards, self.steps, b.state, b.attacker_reward, rows,
                          self.cycle_reward)
            return self.observe(b.state, rows, ints[0]), ints, rewards
        bound = self._results_bound  # every drill: the same arrays each time (bind)
        if bound is None:
            ints, rewards = np.empty((len(RESULTS), b.n), np.int64), np.empty(b.n)
            bound = self._results_bound = (ints, rewards, ints[0], bind(
                _step_results, ints, rewards, self.steps, b.state, b.attacker_reward, rows,
                self.cycle_reward))
        ints, rewards, deciders, call = bound
        call()
        obs = self.observe.again(b.state, rows, deciders)  # the same arrays: bound too
        return obs.copy(), ints.copy(), rewards.copy()


RESULTS = ("decider", "duration", "cycles", "outcome", "holder")
"""The rows of :meth:`HolderLoop.results`' integers, in order."""


@compiled
def _step_results(ints, rewards, steps, state, attacker_reward, rows, cycle_reward):
    """For each drill ``rows[r]``, its step as it stands, into column ``r``: whose
    observation it returns (its holder, or at an end the attacker who decided last if
    the holder is not an attacker), the cycles the step lasted, the drill's cycle, its
    outcome code, its holder (-1 once the episode ended); and the step's reward, the
    attackers' where the episode ended plus the task's pay per cycle (keepaway's
    seconds; none in the drill, whose steps pay only at the end)."""
    attackers = steps[0].supporting.shape[0]
    for r in range(rows.shape[0]):
        i = rows[r]
        s, h = state[i], steps[i]
        holder, code = s.holder, s.outcome
        ints[0, r] = holder if 0 <= holder < attackers else h.decider
        duration = s.cycle - h.start
        ints[1, r] = duration
        ints[2, r] = s.cycle
        ints[3, r] = code
        ended = code != _RUNNING
        ints[4, r] = -1 if ended else holder
        reward = attacker_reward[i] if ended else 0.0
        if cycle_reward != 0.0:
            reward = reward + cycle_reward * duration
        rewards[r] = reward


@warms
def _compile_loop(config: DrillConfig | None) -> None:
    """The loop's compiled bookkeeping and the cycle's rules with the loop's own arrays
    (its ``running`` and ``supporting`` are fields of its records: strided, for more than
    one drill), one drill in its own space and two, before a team's bounded call."""
    cfg = config or DrillConfig()
    for n, physics in ((1, DrillSpace(cfg)), (2, None)):
        steps = np.zeros(n, step_record(cfg.attackers))
        drills = np.arange(n, dtype=np.int64)
        rngs = [np.random.default_rng(k) for k in range(n)]
        batch = BatchDrill(n, cfg, physics=physics)
        batch.reset(drills, rngs)
        support = SupportDraws(n)
        support.seed(drills, list(range(n)))
        every = drills.copy()
        every.flags.writeable = False  # the core's every drill, as the vector env passes it
        for chosen in (drills, every):
            _begin(steps, batch.state, chosen, np.zeros(n, dtype=np.int64), 4)
        _holder_commands(steps, batch.commands)
        support.commands(batch.state, batch.commands, steps["supporting"], cfg.field_size)
        _cycle_commands(steps, batch.state, batch.commands, steps["supporting"], support.records,
                        cfg.field_size)
        batch.step(steps["running"], rngs)
        _after_cycle(steps, batch.state)
        for chosen in (drills, every):  # a vector env's results (every drill, or some)
            _step_results(np.empty((len(RESULTS), n), np.int64), np.empty(n), steps,
                          batch.state, batch.attacker_reward, chosen, cycle_reward(cfg))


# ------------------------------------------------------------------ the environment
_ONE = np.zeros(1, dtype=np.int64)


class HolderEnv(HeaderTexts, Pickled, gym.Env):
    """The drill as seen by whichever attacker holds the ball: keepaway's SMDP.

    Only the ball holder decides; its teammate runs a fixed stochastic support
    behaviour (:mod:`soccer_drill.rules.support`) and the defenders are a scripted team.
    One :meth:`step` applies the holder's action -- for ``decision_cycles`` cycles (0.4 s
    by default) for HOLD and DRIBBLE, for one kick for PASS -- and then runs cycles until
    an attacker holds the ball again (the next decision) or the episode ends. Basic
    options of a few cycles, rather than keepaway's one cycle, make the drill learnable
    in hundreds of episodes rather than thousands (see ``docs/learning.md``). It is one
    drill of the holder loop (:class:`HolderLoop`) that the batched drill runs too.

    ## Action space

    ``Discrete(3)``: 0 ``HOLD`` (shield the ball), 1 ``PASS`` (to the teammate),
    2 ``DRIBBLE`` (toward the goal line) -- the paper's three basic options.

    With ``A`` attackers (``DrillConfig.attackers``): ``Discrete(A + 1)``, 0 ``HOLD``,
    ``1 .. A - 1`` a ``PASS`` to each teammate, nearest first at the decision
    (``PASS_1``, ``PASS_2``, ...), ``A`` ``DRIBBLE`` (keepaway's one pass per teammate;
    a lone attacker has ``HOLD`` and ``DRIBBLE``). :attr:`action_names` names them.

    Keepaway (``DrillConfig(task="keepaway")``, the scenarios ``keepaway_3v2`` and
    ``keepaway_4v3``): ``Discrete(A)``, ``HOLD`` and a pass to each other keeper, nearest
    first (keepaway has no dribble).

    ## Observation space

    ``Box(9,)`` float32: the 9 features of the holder (units and bounds in
    :mod:`soccer_drill.rules.features`). With ``A`` attackers and ``D`` defenders,
    ``Box(4 (A - 1) + D + 3,)``: keepaway's features (teammates and opponents ordered by
    distance, a passing-lane angle per teammate) and the goal line's (the module's table).
    Keepaway: keepaway's ``4 A + 2 D - 3`` state variables (13 at 3v2, 19 at 4v3:
    :mod:`soccer_drill.rules.keepaway`).

    ## Rewards

    Zero until the episode ends; then success pays 1.0 at the centre of the goal
    line falling linearly to 0.5 at its ends, and an interception, the ball
    leaving the region or a timeout pays -1 (configurable in ``DrillConfig``).
    Keepaway: every step pays the seconds it lasted (``duration * cycle_seconds``) and
    the end nothing more, so an episode's return is its length; it ends when a taker
    gains possession (interception) or the ball leaves the region (out), and is
    truncated at ``max_cycles``. The other keepers get open (keepaway's ``GetOpen``)
    instead of the drill's support behaviour.

    ## Episode end

    ``terminated`` on success, interception or out; ``truncated`` when
    ``max_cycles`` cycles have passed (timeout).

    ## Info

    | key | meaning |
    |-----|---------|
    | ``duration`` | cycles this step took (>= 1): the SMDP sojourn time |
    | ``cycles`` | cycles since reset |
    | ``outcome`` | ``None`` while running, else ``"success"``, ``"interception"``, ``"out"`` or ``"timeout"`` |
    | ``holder`` | name of the attacker whose decision is next (``None`` at the end) |

    ## Rendering

    | ``render_mode`` | ``render()`` returns |
    |-----------------|----------------------|
    | ``"rgb_array"`` | the current frame, ``(H, W, 3)`` uint8 |
    | ``"rgb_array_list"`` | every frame since the last ``render()`` (or ``reset``): one per cycle, so a video written at ``metadata["render_fps"]`` plays at true speed |
    | ``"human"`` | ``None``; a window shows every cycle at ``metadata["render_fps"]`` frames per second |

    A frame shows the team, :attr:`policy_name` and :attr:`caption` if set, the cycle and
    the time left, each player's role, the holder and the decision its step carries out,
    short trails, the goal line shaded by its reward, a legend and, at the end, the
    outcome and the reward (:attr:`scene` holds these facts; ``render_style``, a
    :class:`~soccer_drill.rendering.scene.FrameStyle`, turns each part off).
    ``metadata["render_fps"]`` is ``1 / cycle_seconds`` (10 by default): one frame per
    cycle is true speed. A step lasts several cycles, so Gymnasium's ``RecordVideo``,
    which keeps one frame per step (the last of a list), plays fast:
    :class:`soccer_drill.rendering.video.RecordVideo` takes the same arguments and keeps every
    frame (``render_mode="rgb_array_list"``), and ``gymnasium.utils.save_video.save_video(
    env.render(), "videos", fps=env.metadata["render_fps"])`` writes the frames of a
    list at true speed too (both need moviepy).

    ## Seeding

    ``reset(seed=s)`` makes the episode a function of ``s`` and the actions alone:
    observations, rewards and infos are bit-identical to those of a fresh
    environment's ``reset(seed=s)`` with the same actions, whatever episodes ran before
    (the physics space is rebuilt on every reset), for every team that
    draws only from the generator it is given (a team drawing from ``np.random`` or
    ``random`` makes its episodes depend on those too). ``reset()`` without a
    seed continues the generator. The team and the support player draw from their own
    generators, seeded from the drill's at each reset; rendering changes nothing.

    ## Copies

    ``copy.deepcopy``, ``copy.copy`` and ``pickle`` all give an independent environment
    continuing the episode, as those of :class:`soccer_drill.raw_env` do: the same
    actions give bit-identical steps in the copy and the original, and stepping one
    never moves the other. Windows and renderers are not copied. A pickle is for the
    code that made it: another version of ``soccer_drill`` refuses it, naming both.
    ``gym.make`` puts the environment inside Gymnasium's wrappers, which ``copy.copy``
    copies shallowly: that copy shares the environment with the original. There, use
    ``copy.deepcopy`` or ``pickle`` (the whole stack), or ``copy.copy(env.unwrapped)``
    (this environment alone).

    ## Threads

    One environment must be stepped by one thread at a time: a ``step`` or ``reset``
    that starts while another thread is inside one raises ``RuntimeError``. Separate
    environments in separate threads are fine.

    A ``step`` or ``reset`` stopped part-way (a Ctrl-C, a team's error) may leave the
    drill part-way through a cycle or a reset: every later ``step`` then raises
    ``RuntimeError`` naming that call and saying to call ``reset()``, which brings the
    drill back as in a new environment. A call refused while its arguments are checked
    changes nothing.

    ## Arguments

    | argument | default | meaning |
    |----------|---------|---------|
    | ``opponent`` | ``"chasers"`` | team id or a team instance (one another live environment plays already is copied, ``copy.deepcopy``: each environment plays its own) |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory (with a team id; refused with an instance) |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` (default 100) |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``render_mode`` | ``None`` | ``"human"``, ``"rgb_array"`` or ``"rgb_array_list"`` (see Rendering) |
    | ``render_style`` | ``None`` | what a frame draws, a ``FrameStyle`` (``None``: everything, 640 pixels wide) |
    | ``decision_cycles`` | ``4`` | cycles a ``HOLD`` or ``DRIBBLE`` lasts (an integer in [1, 50]; fewer if possession changes); ``PASS`` lasts until an attacker controls the ball |
    | ``team_timeout`` | ``1.0`` | seconds of CPU time each ``reset``/``act`` call of the team may take before it is stopped with ``TeamError`` naming it (time spent waiting, e.g. on a loaded machine, is not counted); ``None``: no bound (see ``soccer_drill.teams.driver.TeamDriver``) |
    """

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 10}
    decision_cycles = DECISION_CYCLES_OF_LOOP

    def __init__(
        self,
        opponent: str | Team = "chasers",
        opponent_params: Mapping[str, Any] | None = None,
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        decision_cycles: int = 4,
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        render_style: FrameStyle | None = None,
    ) -> None:
        decision_cycles = checked("decision_cycles", decision_cycles, DECISION_CYCLES)
        if opponent is None:
            raise ValueError("HolderEnv needs a scripted opponent team (a team id or Team)")
        self.config = make_config(config, max_cycles)
        # One frame per cycle: true speed at 1 / cycle_seconds frames per second.
        self.metadata = {**HolderEnv.metadata, "render_fps": frames_per_second(self.config)}
        self._screen = Screen(self.config, render_mode, self.metadata["render_fps"],
                              self._scene, render_style, self.config.player_names)
        self.render_mode = render_mode
        core = BatchCore(1, opponent, opponent_params, self.config, team_timeout, True, None)
        self.loop = HolderLoop(core, decision_cycles)
        self.action_names = self.loop.action_names
        """The names of the actions, in index order (``HOLD, PASS, DRIBBLE``: 2v2)."""
        self.observation_space = self.loop.observe.box
        self.action_space = spaces.Discrete(len(self.action_names))
        # Whose observation, for one drill (writable and contiguous, as the loop's results
        # give the batched env's deciders: the compiled observation's types).
        self._players = tuple(np.full(1, i, dtype=np.int64) for i in range(self.config.players))
        self._busy_init()
        self._has_reset = False

    def __copy__(self) -> HolderEnv:
        """An independent copy continuing the episode (see Copies)."""
        return copy.deepcopy(self)

    @property
    def scene(self) -> Scene:
        """What a frame shows besides the bodies: the team, the policy, the decision the
        step carries out or last carried out (and whose), the outcome and the reward once the episode ends."""
        if not self._has_reset:
            raise not_reset("scene")
        return self._screen.scene()

    def _scene(self) -> Scene:
        loop = self.loop
        batch = loop.core.batch
        code = int(batch.outcome[0])
        chooser, choice = -1, None
        if batch.cycle[0] > 0:  # the last decision, until the next one
            chooser, choice = int(loop.decider[0]), loop.action_names[int(loop.action[0])]
        return Scene(team=loop.core.team.name, chooser=chooser, choice=choice,
                     outcome=OUTCOME_NAMES[code],
                     reward=None if code == _RUNNING else float(batch.attacker_reward[0]))

    @property
    def drill_state(self):
        """The current :class:`~soccer_drill.state.DrillState`."""
        if not self._has_reset:
            raise not_reset("drill_state")
        return self.loop.core.batch.state_of(0)

    def record_frames(self, frames: list[np.ndarray] | None) -> None:
        """Append an ``rgb_array`` frame to ``frames`` after every cycle (``None`` stops)."""
        state = self.loop.core.batch.state_of(0) if self._has_reset else None
        self._screen.record(frames, state)

    def action_masks(self) -> np.ndarray:
        """Which actions are legal now: all of them, always (bool; for sb3-contrib's
        ``MaskablePPO``, which asks every environment for ``action_masks()``)."""
        return np.ones(len(self.action_names), dtype=bool)

    def get_keys_to_action(self) -> dict[tuple[str], int]:
        """The keys of ``soccer-drill-play`` (``H`` hold, ``P`` the pass to the nearest
        teammate, ``D`` dribble, digit ``i + 1`` action ``i``), for
        ``gymnasium.utils.play.play``, which asks an environment for them."""
        skills = attacker_action_skills(self.config.attackers)[:len(self.action_names)]
        return {(key,): action for key, action in action_letters(skills).items()}

    def reset(
        self, *, seed: int | None = None, options: dict | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; the observation is the 9 features of the attacker given the ball.
        ``seed``: ``None`` (continue the generator) or an integer >= 0, Python's or NumPy's,
        as every environment of the drill takes it. ``options``: ``None`` or an empty dict
        (it takes none)."""
        seed = checked("seed", seed, SEED)
        check_reset_options(options, (), "HolderEnv.reset")
        with self._claim("reset"):
            return self.loop.core.changing("HolderEnv.reset()", lambda: self._reset(seed),
                                           every_drill=True)

    def _reset(self, seed: int | None) -> tuple[np.ndarray, dict[str, Any]]:
        loop = self.loop
        super().reset(seed=seed)
        loop.core.seed(None if seed is None else [seed])
        loop.restart(_ONE)
        self._has_reset = True
        batch = loop.core.batch
        holder = int(batch.holder[0])
        if self._screen.each_cycle:
            self._screen.start(batch.state_of(0))
        return loop.observe(batch.state, _ONE, self._players[holder])[0], {
            "duration": 0, "cycles": 0, "outcome": None,
            "holder": self.config.player_names[holder],
        }

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the holder's action and run to its next decision or the end (see the class docstring)."""
        with self._claim("step"):
            return self._step(action)

    def _step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self._has_reset:
            raise not_reset("step")
        loop = self.loop
        batch = loop.core.batch
        loop.core.check_usable()  # a call stopped part-way, or the team's error
        if batch.outcome[0] != _RUNNING:
            raise RuntimeError("step() called after the episode ended; call reset()")
        chosen = np.array((loop.check_action(action),))
        return loop.core.changing("HolderEnv.step()", lambda: self._run(chosen))

    def _run(self, chosen: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The checked action ``chosen`` run to the holder's next decision or the end."""
        loop = self.loop
        batch = loop.core.batch
        loop.begin(_ONE, chosen)
        screen = self._screen
        while True:
            running = loop.cycle(_ONE)
            if screen.each_cycle:
                screen.after_cycle(batch.state_of(0))
            if not running:
                break
        code, cycle, holder = int(batch.outcome[0]), int(batch.cycle[0]), int(batch.holder[0])
        # the decider of HolderLoop.results, for one drill without array work
        decider = holder if 0 <= holder < loop.attackers else int(loop.decider[0])
        obs = loop.observe(batch.state, _ONE, self._players[decider])[0]
        info = {
            "duration": cycle - int(loop.start[0]),
            "cycles": cycle,
            "outcome": OUTCOME_NAMES[code],
            "holder": self.config.player_names[holder] if code == _RUNNING else None,
        }
        paid = loop.cycle_reward * info["duration"]  # keepaway's seconds; 0 in the drill
        if code == _RUNNING:
            return obs, paid, False, False, info
        truncated = code == _TIMEOUT
        reward = float(batch.attacker_reward[0])
        return obs, reward + paid if paid else reward, not truncated, truncated, info

    def render(self) -> np.ndarray | list[np.ndarray] | None:
        """The current frame, the frames since the last call, or ``None`` (see Rendering)."""
        if self.render_mode is None:
            return None
        if not self._has_reset:
            raise not_reset("render")
        return self._screen.render(self.loop.core.batch.state_of(0))

    def close(self) -> None:
        """Close any window opened by human rendering."""
        self._screen.close()
