"""Many ball-holder drills as one Gymnasium ``VectorEnv``: ``soccer_drill/Holder-v0`` batched,
over the holder loop of :class:`~soccer_drill.envs.holder.HolderEnv`; and
:func:`play_episodes`, fixed holder rules with no drill waiting."""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import (
    Integer,
    ListOf,
    NoneOr,
    OneOf,
    check,
    checked,
    is_int,
)
from soccer_drill.drill.spaces import DRILLS_PER_SPACE
from soccer_drill.envs.core import BatchCore, check_reset_options, check_seed, make_config
from soccer_drill.envs.holder import (
    DECISION_CYCLES,
    DECISION_CYCLES_OF_LOOP,
    HolderLoop,
    holder_action_refused,
)
from soccer_drill.envs.pickling import Pickled, claimed
from soccer_drill.interruptions import short_repr
from soccer_drill.rendering.batch import BatchRenderer, check_render_mode
from soccer_drill.rendering.screen import frames_per_second
from soccer_drill.rules.arrays import OUTCOME_NAMES, Outcome
from soccer_drill.teams.registry import DEFAULT_TEAM_TIMEOUT, Team
from soccer_drill.vector.memory import check_frames_fit, check_frames_memory, check_num_envs

_OUTCOMES = np.array(OUTCOME_NAMES, dtype=object)
_RUNNING, _TIMEOUT = int(Outcome.RUNNING), int(Outcome.TIMEOUT)  # an enum lookup costs ~1 us
_AUTORESET_MODES = OneOf((AutoresetMode.NEXT_STEP.value, AutoresetMode.SAME_STEP.value))
RESET_OPTIONS = ("reset_mask",)
"""The keys ``HolderVectorEnv.reset``'s ``options`` may hold."""

ROW_PER_DRILL = frozenset({"action_masks", "render"})
"""Methods of ``HolderVectorEnv`` that return one row per drill (``render``: a frame, or
``None`` for every drill): ``call`` gives each drill its own."""

EVERY_DRILL = frozenset({
    "reset", "close", "step", "step_async", "step_wait", "async_reset", "send", "recv",
    "close_extras",
})
"""Methods of ``HolderVectorEnv`` that act on every drill at once, never called once per
drill (``call`` refuses them: call them directly)."""

FIXED_ATTRIBUTES = frozenset({"autoreset_mode", "batch_size", "num_envs"})
"""Attributes set when the environment is made, which ``set_attr`` refuses."""

_AS_ONE_DRILL = {"observation_space": "single_observation_space",
                 "action_space": "single_action_space"}
"""Attributes whose one drill's value is another attribute here (as ``call`` reads them)."""


def check_drill_indices(indices: object, n: int) -> list[int]:
    """Drill indices as SB3's ``VecEnv._get_indices`` reads them, checked: ``None`` (every
    drill), an int or a sequence of ints (Python or NumPy, not bools), each in ``0..n-1``.
    Returns them as a list of ints; anything else is refused, saying what is allowed."""
    if indices is None:
        return list(range(n))
    chosen = [indices] if is_int(indices) else indices
    check("indices", chosen, ListOf(Integer(0, n - 1), kinds=(list, tuple, range, np.ndarray)))
    return [int(i) for i in chosen]  # type: ignore[union-attr]


def _first_non_integer(actions: np.ndarray) -> int:
    """The index of the first entry of ``actions`` that is not an integer (0 if every entry
    is one: then the dtype itself is wrong, e.g. an object array of ints)."""
    return next((i for i, x in enumerate(actions.tolist()) if not is_int(x)), 0)


def _only(infos: dict[str, Any], drills: np.ndarray, n: int) -> dict[str, Any]:
    """``infos`` (of every drill) kept for ``drills`` only, as Gymnasium batches the infos
    of some sub-environments: ``_key`` true for them, the others' values 0 or ``None``."""
    chosen = np.zeros(n, dtype=bool)
    chosen[drills] = True
    out: dict[str, Any] = {}
    for key, values in infos.items():
        if key.startswith("_"):
            out[key] = chosen.copy()
        elif values.dtype.kind in "biuf":
            out[key] = np.where(chosen, values, np.zeros_like(values))
        else:
            out[key] = np.where(chosen, values, None).astype(object)
    return out


class HolderVectorEnv(Pickled, VectorEnv):
    """``num_envs`` ball-holder drills stepped together: :class:`~soccer_drill.envs.holder.HolderEnv` batched.

    Made by ``gymnasium.make_vec("soccer_drill/Holder-v0", num_envs=N,
    vectorization_mode="vector_entry_point", opponent=...)``. Each drill is a
    ``HolderEnv``: the same actions, observations, rewards, episode end and infos (see
    its docstring), with a leading batch axis. Drill ``i``'s step runs, as
    ``HolderEnv.step`` does, from its holder's decision to the next one or to the end;
    the drills whose step is over stand still until every drill's step is, then all
    return together (so a step costs the cycles of its longest drill, and the cost per
    drill-cycle falls as ``N`` grows: ``docs/benchmarks.md``), or, with ``batch_size``,
    ``batch_size`` at a time as they finish (Asynchronous use).

    ## Spaces

    | space | value |
    |---|---|
    | ``single_action_space`` | ``HolderEnv``'s (:attr:`action_names`): ``Discrete(3)``, 0 HOLD, 1 PASS, 2 DRIBBLE in the 2v2 drill; ``Discrete(A + 1)`` with ``A`` attackers; keepaway's ``Discrete(A)`` |
    | ``action_space`` | ``MultiDiscrete([n] * N)``, ``n`` the single space's actions: one action per drill |
    | ``single_observation_space`` | ``HolderEnv``'s: ``Box(9,)`` float32, the holder's 9 features in the 2v2 drill; ``Box(4 (A - 1) + D + 3,)`` with ``A`` attackers and ``D`` defenders; keepaway's ``Box(4 A + 2 D - 3,)`` |
    | ``observation_space`` | ``Box((N, m))`` float32, ``m`` the single space's length |

    ## Rewards and episode end

    As ``HolderEnv``, per drill: in the drill zero until the episode ends, then the
    attackers' reward; in keepaway the seconds each step lasted (``duration *
    cycle_seconds``), nothing more at the end; ``terminated`` on success, interception or out, ``truncated`` on timeout.
    With ``max_episode_steps`` a drill's episode is also truncated at its
    ``max_episode_steps``-th step, as Gymnasium's ``TimeLimit`` truncates ``HolderEnv``'s
    (``gym.make(id, max_episode_steps=n)``; ``gym.make_vec`` passes it here; ``truncated``
    also where that step ended the episode): the info's outcome of a drill cut short stays
    ``None`` (the drill did not end), and it autoresets as any ended episode.

    ## Autoreset

    ``autoreset_mode`` as Gymnasium's vector envs (``metadata["autoreset_mode"]``):

    | mode | a drill whose episode ended at step ``t`` |
    |---|---|
    | ``NEXT_STEP`` (default, as ``SyncVectorEnv``) | returns its final observation at ``t``; at ``t + 1`` it is reset (its action ignored) and returns the first observation, reward 0, ``terminated = truncated = False`` and the reset's info |
    | ``SAME_STEP`` | is reset within step ``t``: the observation is the new episode's first, ``infos["final_obs"]`` (an object array, ``infos["_final_obs"]`` its mask) holds the final one and ``infos["final_info"]`` the final step's info |

    ## Asynchronous use

    With ``batch_size`` below ``num_envs`` the drills need not wait for one another, as
    in EnvPool's asynchronous mode: ``recv()`` runs the drills until ``batch_size`` of
    them are done and returns theirs (the same five values as ``step``, with
    ``batch_size`` rows and ``infos["env_id"]``, the drills' indices, ascending), and
    ``send(actions, env_id)`` gives those drills their next actions while the others
    run on::

        env = gym.make_vec("soccer_drill/Holder-v0", num_envs=64, batch_size=16,
                           vectorization_mode="vector_entry_point", opponent="interceptors_cover")
        env.async_reset(seed=0)
        while learning:
            obs, rewards, terminated, truncated, infos = env.recv()
            env.send(policy(obs), infos["env_id"])

    | call | what it does |
    |---|---|
    | ``async_reset(seed=..., options=...)`` | resets as ``reset`` does; the first observations come from the next ``recv()`` calls, lowest ``env_id`` first, with reward 0 and ``duration`` 0 |
    | ``recv()`` | the ``batch_size`` drills that have waited longest (in one cycle, the lowest ``env_id`` first); an error if fewer can ever be done (nothing sent) |
    | ``send(actions, env_id)`` | one action per drill of ``env_id`` (``None``: every drill), each waiting for it; an ended drill is reset instead (``NEXT_STEP``), or was reset in ``recv`` (``SAME_STEP``) |
    | ``step(actions)`` | ``send`` to every drill then ``recv``; only with ``batch_size == num_envs`` |

    With ``step`` a batch costs the cycles of its longest step, so at ``N = 64`` about a
    third of the drills are at work in a cycle; with ``batch_size = N / 4`` about
    86% (``batch_cycles`` counts the batch's cycles; ``docs/benchmarks.md``). Which
    drills come back together depends only on the seeds and the actions, so a run is
    as reproducible as with ``step``.

    ## Info

    The ``HolderEnv`` keys, batched as Gymnasium's vector envs batch infos: per key an
    array over drills (``"duration"``, ``"cycles"``: int; ``"outcome"``, ``"holder"``:
    object, ``None`` or a name) and a boolean mask ``"_<key>"`` of the drills that have it
    (all of them here).

    ## Attributes by drill

    ``call``, ``get_attr`` and ``set_attr`` take what ``SyncVectorEnv``'s take and give
    one value per drill, so a client written for ``vectorization_mode="sync"`` runs on
    this environment: ``set_attr("decision_cycles", 2)`` (a curriculum), ``get_attr``
    of an attribute (every drill's, ``observation_space`` a single drill's),
    ``call("action_masks")`` (each drill's row). The drills are one environment, so
    ``set_attr`` takes one value, or equal values per drill; attributes set when the
    environment is made (``num_envs``, ``batch_size``, ``autoreset_mode``) are refused,
    and ``call`` refuses the methods that act on every drill at once (``step``,
    ``reset``, ...: call them).

    ## Seeding

    | call | drill ``i`` |
    |---|---|
    | ``reset(seed=s)`` (an int) | its episode starts from the generator of a single ``HolderEnv``'s ``reset(seed=s + i)`` (as ``SyncVectorEnv`` seeds its ``i``-th env) |
    | ``reset(seed=[s_0, ..., s_N-1])`` | seed ``s_i`` (``None``: keep its stream) |
    | ``reset()`` | every stream goes on (fresh entropy the first time) |
    | ``reset(seed=..., options={"reset_mask": m})`` | only the drills where ``m`` (``(N,)`` bool) is true are reset, each seeded as a full reset would seed it: ``s + i`` for an int ``s``; a list still has ``N`` entries, one per drill, those of the drills not reset ignored; the other drills go on untouched; any other key, or options that are not a dict: ``ValueError``/``TypeError`` naming it |
    | any reset of every drill of a space (a full ``reset``, or drills that all end together) | that space is built anew: no contact of an earlier episode is carried over, as in ``HolderEnv.reset`` |
    | an autoreset | its own stream goes on |

    A seed is ``None``, or a Python or NumPy integer ``>= 0`` (not a bool); a list (or
    tuple, or 1-D array) has exactly ``N`` of them. Anything else raises ``ValueError``
    before any drill is reset, in ``reset`` and ``async_reset`` alike.

    So ``reset(seed=s)`` with the same actions gives the same observations, rewards and
    infos, whatever ran before. Drill ``i`` starts exactly where ``HolderEnv`` started
    with ``reset(seed=s + i)`` does, and its cycle is the single drill's own
    (:class:`~soccer_drill.drill.BatchDrill`, of which the single drill is one): the same
    compiled rules (skills, support player, team, possession, outcome), the ball moved on
    arrays as pymunk moves it, the random draws in the same order from the same streams.
    A batch of one drill (``num_envs=1``) is in the single drill's own space, so it plays
    ``HolderEnv``'s episodes bit for bit. In a batch of more, what differs is the physics
    of the players: the single drill's space holds its ball
    as a body too (shapes that meet nothing still shape the spatial index, hence the
    order in which simultaneous contacts are solved), the batch writes each player's
    position and velocity into pymunk every cycle (the single drill its velocity only),
    and with shared spaces (the default, which costs less) contacts are solved in an
    order that depends on the other drills, drills standing still while others move are
    still stepped (their contact caches change), a reset keeps the space while other
    drills in it go on, and the drills' positions are shifted into their own regions of
    the space (rounding). With ``drills_per_space=1`` a drill's episodes follow the single
    environment's decision by decision until the first such contact
    (``tests/test_vector_async.py`` checks the first decisions; ``tests/test_vector.py``
    whole episodes of one drill); ``python -m ilpss.experiments.agreement`` (a ``slow`` test runs a
    small version) checks that success rates agree within 95% intervals.

    ## Copies

    ``copy.deepcopy``, ``copy.copy`` and ``pickle`` give an independent environment
    continuing every drill's episode. With ``num_envs=1`` (the single drill's space) the
    same actions give bit-identical steps in the copy and the original, as in
    ``HolderEnv`` (the copy replays its space's cycles). With more drills the shared
    spaces are pymunk's copies: their bodies, shapes and contacts, with a spatial index
    built anew from where the shapes stand, so contacts that happen at once may be
    solved in another order than in the original's space: the copy's steps are the
    original's bit for bit until such a contact, then differ in the floats of the
    players' positions and, in time, in outcomes (the same drills in distribution, as
    the batch is the single drill's). Replaying a shared space would mean keeping every
    cycle of every drill since the space was built, without bound. A pickle is
    for the code that made it: another version of ``soccer_drill`` refuses it, naming both. So does
    ``copy.copy`` of ``HolderSB3VecEnv``. Gymnasium's vector wrappers
    (``RecordEpisodeStatistics``, ...) are copied shallowly by ``copy.copy``, as its
    single-environment wrappers are (``HolderEnv``'s Copies): that copy shares this
    environment; there, use ``copy.deepcopy`` or ``pickle``, or ``copy.copy(env.unwrapped)``.

    ## Errors

    An action out of range, or actions not of an integer dtype (floats, bools,
    objects: as ``HolderEnv.step`` and ``MultiDiscrete`` take integers only), raise
    ``ValueError`` naming the drill (``drill 17: action must be an integer in [0, 2]
    ...``) before any drill moves, so the others are not changed. A team's failure
    raises ``TeamError`` naming the team; then call ``reset()``.

    A call stopped part-way -- a Ctrl-C, a team's error, anything raised once its
    arguments were checked -- may leave drills part-way through a cycle or a reset: every
    later ``step``, ``send`` and ``recv`` then raises ``RuntimeError`` naming that call
    and saying to call ``reset()``, and a reset of every drill (no ``reset_mask``) brings
    every drill back as in a new environment. A call stopped before its work began (its
    arguments being checked) changed nothing. A Ctrl-C while pymunk builds or frees a
    space waits for its end (it could crash the process at a later garbage collection).
    One environment is used by one thread at a time: a ``reset``, ``step``, ``send``,
    ``recv`` or ``async_reset`` that starts while another thread is inside one raises
    ``RuntimeError`` (as ``ParallelVectorEnv``'s ``reset`` and ``step`` do).

    ## Arguments

    | argument | default | meaning |
    |---|---|---|
    | ``num_envs`` | ``1`` | number of drills (a Python or NumPy integer, as are ``drills_per_space`` and ``batch_size``) |
    | ``opponent`` | ``"chasers"`` | team id or a ``Team`` instance (copied per drill if it has no batched ``act``) |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory (with a team id; refused with an instance) |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``max_episode_steps`` | ``None`` | ``None`` or an integer >= 1: each episode truncated at that step (Rewards and episode end); :func:`play_episodes`, which plays whole episodes, refuses such an environment |
    | ``decision_cycles`` | ``4`` | cycles a HOLD or DRIBBLE lasts (an integer in [1, 50]) |
    | ``team_timeout`` | ``1.0`` | CPU seconds one batched team call may take (a team without a batched ``act``: each drill's copy, each call) |
    | ``autoreset_mode`` | ``NEXT_STEP`` | see Autoreset |
    | ``drills_per_space`` | ``64`` | drills sharing one pymunk space |
    | ``batch_size`` | ``None`` | drills per ``recv()`` (see Asynchronous use); ``None``: ``num_envs`` |
    | ``render_mode`` | ``None`` | ``None`` or ``"rgb_array"``: ``render()`` returns a tuple of ``num_envs`` frames ``(H, W, 3)`` uint8, one per drill, as ``SyncVectorEnv.render`` does (a window or a video of every cycle: a single ``HolderEnv``); ``metadata["render_fps"]`` is ``HolderEnv``'s, ``1 / cycle_seconds`` |
    """

    decision_cycles = DECISION_CYCLES_OF_LOOP
    metadata: ClassVar[dict] = {
        "render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        opponent: str | Team = "chasers",
        opponent_params: Mapping[str, Any] | None = None,
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        decision_cycles: int = 4,
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        drills_per_space: int = DRILLS_PER_SPACE,
        render_mode: str | None = None,
        batch_size: int | None = None,
        max_episode_steps: int | None = None,
    ) -> None:
        n = check_num_envs(num_envs)
        self.max_episode_steps = checked("max_episode_steps", max_episode_steps,
                                         NoneOr(Integer(1)))
        # None: every drill at once; the number of drills is only known here.
        batch_size = checked("batch_size", batch_size, NoneOr(Integer(1, n))) or n
        drills_per_space = checked("drills_per_space", drills_per_space, Integer(1))
        decision_cycles = checked("decision_cycles", decision_cycles, DECISION_CYCLES)
        if opponent is None:
            raise ValueError("HolderVectorEnv needs a scripted opponent team (a team id or Team)")
        self.render_mode = check_render_mode(render_mode, type(self).__name__)
        mode = autoreset_mode.value if isinstance(autoreset_mode, AutoresetMode) else autoreset_mode
        self.autoreset_mode = AutoresetMode(checked("autoreset_mode", mode, _AUTORESET_MODES))
        self._same_step = self.autoreset_mode == AutoresetMode.SAME_STEP
        self.num_envs = n
        self.batch_size = int(batch_size)
        self.config = make_config(config, max_cycles)
        # HolderEnv's frame rate, which Gymnasium's vector HumanRendering and RecordVideo read
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode,
                         "render_fps": frames_per_second(self.config)}
        if self.render_mode is not None:  # before any drill is built
            check_frames_fit(n, self.config)
        core = BatchCore(n, opponent, opponent_params, self.config, team_timeout, True,
                         drills_per_space)
        self.loop = HolderLoop(core, decision_cycles)
        """The holder loop of these drills (:class:`~soccer_drill.envs.holder.HolderLoop`)."""
        self.single_observation_space = self.loop.observe.box
        self.action_names = self.loop.action_names
        """The names of the holder's actions, in index order (``HOLD, PASS, DRIBBLE``: 2v2)."""
        self.single_action_space = spaces.Discrete(len(self.action_names))
        self._names = np.array([*self.config.player_names, None], dtype=object)  # -1: None
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self._all = core.every
        self._has_reset = False
        self._autoreset = np.zeros(n, dtype=bool)
        self._episode_steps = np.zeros(n, dtype=np.int64)  # each drill's steps this episode
        self._ready = np.zeros(n, dtype=bool)  # its step is over, its result not yet received
        self._ready_at = np.zeros(n, dtype=np.int64)  # since when (recv's cycles)
        self._recv_cycles = 0
        team = self._core.team
        self._renderer = (BatchRenderer(self.config, check_frames_memory,
                                        None if team is None else team.name)
                          if self.render_mode else None)
        self._busy_init()

    @property
    def _core(self) -> BatchCore:
        return self.loop.core

    def __copy__(self) -> HolderVectorEnv:
        """An independent copy continuing every drill's episode, as ``copy.deepcopy``
        and ``pickle`` give (the single environments' ``copy.copy`` does the same)."""
        return copy.deepcopy(self)

    # ------------------------------------------------------------------ reset
    @claimed
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every drill (or those of ``options["reset_mask"]``); see Seeding."""
        seeds, drills = self._check_reset(seed, options)

        def reset() -> tuple[np.ndarray, dict[str, Any]]:
            self._reset(seeds, drills, seed)
            self._ready[drills] = False
            obs, _, infos = self._results(self._all)
            if len(drills) < self.num_envs:  # infos of the drills reset only
                infos = _only(infos, drills, self.num_envs)
            return obs, infos

        return self._core.changing("HolderVectorEnv.reset()", reset, len(drills) == self.num_envs)

    def _check_reset(self, seed: int | Sequence[int | None] | None,
                     options: dict[str, Any] | None) -> tuple[list[int | None] | None, np.ndarray]:
        """The seeds and the drills ``reset`` names (see Seeding), checked; nothing changes."""
        seeds = check_seed(seed, self.num_envs)
        mask = check_reset_options(options, RESET_OPTIONS, "HolderVectorEnv.reset").get(
            "reset_mask")
        if mask is None:
            return seeds, self._all
        mask = np.asarray(mask)
        if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
            raise ValueError(
                f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) "
                "with at least one True"
            )
        if not self._has_reset or self.loop.handed_to is not None:
            raise RuntimeError("reset() with a reset_mask before the first full reset()"
                               + ("" if self.loop.handed_to is None else
                                  f" after {self.loop.handed_to} played the drills"))
        return seeds, np.flatnonzero(mask)

    def _reset(self, seeds: list[int | None] | None, drills: np.ndarray,
               seed: object = None) -> None:
        """Reset ``drills`` (every drill if they are ``self._all``) with ``seeds`` (one per
        drill of the batch, those of other drills ignored); they then wait for an action.
        An integer ``seed`` (what ``reset`` was given) also seeds :attr:`np_random`, as
        Gymnasium's ``VectorEnv.reset`` does."""
        if is_int(seed):
            self._np_random, self._np_random_seed = seeding.np_random(int(seed))
        core = self._core
        if seeds is not None:  # one entry per drill: those of drills not reset are ignored
            chosen = np.zeros(self.num_envs, dtype=bool)
            chosen[drills] = True
            core.seed([s if chosen[i] else None for i, s in enumerate(seeds)])
        self._restart(drills)
        if drills is self._all:
            self.loop.handed_to = None
        self._has_reset = True

    def _restart(self, drills: np.ndarray) -> None:
        """A new episode in each of ``drills``, its step counted from there."""
        self.loop.restart(drills)
        self._autoreset[drills] = False
        self._episode_steps[drills] = 0

    # ------------------------------------------------------------------- step
    def _check_actions(self, actions: object, drills: np.ndarray) -> np.ndarray:
        """``actions`` as int64, one per drill of ``drills``; errors name the drill."""
        a = np.asarray(actions)
        k = len(drills)
        if a.shape != (k,):
            raise ValueError(
                f"actions must be an array of shape ({k},): one action per drill"
                f"{'' if k == self.num_envs else ' of env_id'}, got shape {a.shape}"
            )
        if a.dtype.kind not in "iu":  # as HolderEnv.step, which refuses 2.0 and True
            bad = _first_non_integer(a)
            raise ValueError(
                f"drill {int(drills[bad])}: {holder_action_refused(a[bad], self.loop.attackers, self.action_names)} (actions of dtype "
                f"{a.dtype}; an integer dtype is needed)"
            )
        ints = a.astype(np.int64)
        bad = ints.view(np.uint64) >= len(self.action_names)  # a negative one is huge so
        bad_rows = np.flatnonzero(bad) if np.count_nonzero(bad) else ()
        if len(bad_rows):
            bad_rows = bad_rows[~self._autoreset[drills[bad_rows]]]  # ignored: drills being reset
        if len(bad_rows):
            i = int(bad_rows[0])
            raise ValueError(
                f"drill {int(drills[i])}: {holder_action_refused(a[i], self.loop.attackers, self.action_names)}"
                + (f" ({len(bad_rows)} drills had bad actions)" if len(bad_rows) > 1 else "")
            )
        return ints

    def _check_usable(self, call: str) -> None:
        """The drills' errors, or ``RuntimeError`` before a reset (or after
        :func:`play_episodes` took the drills)."""
        if not self._has_reset:
            raise RuntimeError(f"{call}() called before reset(); call reset() first")
        if self.loop.handed_to is not None:
            raise RuntimeError(f"{call}() called after {self.loop.handed_to} played the "
                               "drills; call reset() first")
        self._core.check_usable()

    @claimed
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Each drill's holder acts and its drill runs to the next decision or the end."""
        if self.batch_size != self.num_envs:
            raise RuntimeError(
                f"step() needs every drill's result, but batch_size is {self.batch_size} of "
                f"{self.num_envs} drills: use send(actions, env_id) and recv() (see Asynchronous use)"
            )
        self._check_usable("step")
        self._check_waiting(self._all, "step()")  # not after a send() without its recv()
        a = self._check_actions(actions, self._all)

        def step() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
            self._send(a, self._all)
            obs, rewards, terminated, truncated, infos = self._recv()
            del infos["_rows"]  # every drill, in order
            return obs, rewards, terminated, truncated, infos

        return self._core.changing("HolderVectorEnv.step()", step)

    # ---------------------------------------------------------- asynchronous
    @claimed
    def async_reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> None:
        """Reset as ``reset`` does, without returning: the reset drills' first
        observations are what the next ``recv()`` calls return (``batch_size`` at a time,
        the lowest ``env_id`` first), with reward 0 and ``duration`` 0."""
        seeds, drills = self._check_reset(seed, options)

        def reset() -> None:
            self._reset(seeds, drills, seed)
            self._make_ready(drills)

        self._core.changing("HolderVectorEnv.async_reset()", reset,
                            len(drills) == self.num_envs)

    @claimed
    def send(self, actions: Any, env_id: Any = None) -> None:
        """The holders of drills ``env_id`` (all drills if ``None``) take ``actions`` (one
        per drill of ``env_id``, in its order); their drills run when ``recv()`` is called.

        Each drill of ``env_id`` must be waiting for an action: its last result was
        returned by ``recv()`` (or ``reset()``) and not yet answered. A drill whose episode
        ended is reset instead (its action ignored, as in ``step``'s ``NEXT_STEP`` mode).
        Nothing is sent if any of it is wrong: the error names the first bad drill.
        """
        if not self._has_reset:
            raise RuntimeError("send() called before reset() or async_reset(); call one first")
        self._check_usable("send")
        drills = self._check_env_id(env_id)
        a = self._check_actions(actions, drills)
        order = np.argsort(drills, kind="stable")
        self._core.changing("HolderVectorEnv.send()", lambda: self._send(a[order], drills[order]))

    @claimed
    def recv(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The results of the first ``batch_size`` drills whose step is over.

        Runs the drills that were sent actions until ``batch_size`` results are waiting,
        then returns those that waited longest (among drills done in the same cycle, the
        lowest ``env_id`` first), in the order of ``infos["env_id"]`` (ascending): what
        ``step`` returns, for those drills only (``batch_size`` rows).
        """
        if not self._has_reset:
            raise RuntimeError("recv() called before reset() or async_reset(); call one first")
        self._check_usable("recv")
        self._check_recv()

        def recv() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
            obs, rewards, terminated, truncated, infos = self._recv()
            rows = infos.pop("_rows")
            if rows is self._all:  # the core's own array: the caller gets a copy
                rows = rows.copy()
            infos["env_id"], infos["_env_id"] = rows, np.ones(len(rows), dtype=bool)
            return obs, rewards, terminated, truncated, infos

        return self._core.changing("HolderVectorEnv.recv()", recv)

    # ------------------------------------------------- attributes by drill
    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """What ``SyncVectorEnv.call`` gives: one value per drill, of attribute ``name``
        (called with ``args`` if a method). The drills are one environment: a method of
        :data:`ROW_PER_DRILL` gives each drill its row, another attribute is every
        drill's (``observation_space`` and ``action_space`` a single drill's); a method of
        :data:`EVERY_DRILL` is refused (it acts on every drill at once: call it)."""
        if name in EVERY_DRILL:
            raise ValueError(f"call({name!r}): {name}() acts on every drill at once, so it is "
                             f"not called once per drill; call env.{name}() itself")
        value = getattr(self, _AS_ONE_DRILL.get(name, name))
        if callable(value):
            value = value(*args, **kwargs)
        if name in ROW_PER_DRILL:
            return (None,) * self.num_envs if value is None else tuple(value)
        return (value,) * self.num_envs

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of each drill (:meth:`call`, as ``SyncVectorEnv.get_attr``)."""
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set attribute ``name`` of the drills, as ``SyncVectorEnv.set_attr``: one value,
        or a list or tuple of ``num_envs`` values, which must be equal since the drills
        share it (``decision_cycles`` for a curriculum, for instance); those of
        :data:`FIXED_ATTRIBUTES` are refused."""
        if name in FIXED_ATTRIBUTES:
            raise ValueError(f"set_attr({name!r}): set when the environment is made; make "
                             f"another to change it (attributes refused: "
                             f"{sorted(FIXED_ATTRIBUTES)})")
        if isinstance(values, list | tuple):
            if len(values) != self.num_envs:
                raise ValueError(f"set_attr({name!r}): {len(values)} values for "
                                 f"{self.num_envs} drills; give one value, or one per drill")
            if any(not _same(v, values[0]) for v in values[1:]):
                raise ValueError(f"set_attr({name!r}): the drills share one environment, so "
                                 f"they take one value, got {short_repr(list(values))}")
            values = values[0]
        setattr(self, name, values)

    @property
    def batch_cycles(self) -> int:
        """The cycles the batch has run for ``step`` and ``recv`` (each moves every drill
        that is running): the drill-cycles played over it is how many drills were at work
        on average."""
        return self._recv_cycles

    def _check_env_id(self, env_id: Any) -> np.ndarray:
        n = self.num_envs
        drills = self._all if env_id is None else np.asarray(env_id)
        if drills.ndim != 1 or drills.dtype.kind not in "iu" or len(drills) == 0:
            raise ValueError(
                f"env_id must be a non-empty 1-D array of drill indices in 0..{n - 1} (as "
                f"recv() returns in infos['env_id']), got {env_id!r}"
            )
        out_of_range = drills[(drills < 0) | (drills >= n)]
        if len(out_of_range):
            raise ValueError(f"env_id: drill {int(out_of_range[0])} is not in 0..{n - 1}")
        unique, counts = np.unique(drills, return_counts=True)
        if np.any(counts > 1):
            raise ValueError(f"env_id: drill {int(unique[counts > 1][0])} is given twice")
        self._check_waiting(drills, "env_id")
        return drills.astype(np.int64)

    def _check_waiting(self, drills: np.ndarray, what: str) -> None:
        """Every drill of ``drills`` waits for an action; else ``ValueError`` naming one."""
        running, ready = self.loop.running, self._ready
        if drills is self._all:  # every drill, in order: no gathering
            if not (np.count_nonzero(running) or np.count_nonzero(ready)):
                return
            busy = np.flatnonzero(running | ready)
        else:
            busy = drills[running[drills] | ready[drills]]
        if len(busy):
            i = int(busy[0])
            state = "running its step" if running[i] else "done, its result not yet received by recv()"
            raise ValueError(f"{what}: drill {i} is not waiting for an action ({state})")

    def _send(self, actions: np.ndarray, drills: np.ndarray) -> None:
        """``actions[k]`` for drill ``drills[k]`` (ascending): reset the ended drills,
        start the others' steps."""
        autoreset = self._autoreset
        resetting = drills[autoreset[drills]] if np.count_nonzero(autoreset) else ()
        if len(resetting):
            self._restart(resetting)
            self._make_ready(resetting)
            stepping = ~np.isin(drills, resetting)
            drills, actions = drills[stepping], actions[stepping]
        if drills is self._all:  # every drill, in order: no gathering
            self._episode_steps += 1
        else:
            self._episode_steps[drills] += 1
        self.loop.begin(drills, actions)

    def _make_ready(self, drills: np.ndarray) -> None:
        self._ready[drills] = True
        self._ready_at[drills] = self._recv_cycles

    def _check_recv(self) -> None:
        """``RuntimeError`` if fewer than ``batch_size`` drills have or will have results
        (those running now are all that will): before anything runs."""
        done, running = np.count_nonzero(self._ready), np.count_nonzero(self.loop.running)
        if done + running < self.batch_size:
            raise RuntimeError(
                f"recv(): {done} drills have results and "
                + ("none is running" if not running else f"only {running} more are running")
                + f", so {self.batch_size} (batch_size) never will: send() actions to the "
                "drills of the last recv() first"
            )

    def _recv(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Cycle until ``batch_size`` drills are done; their results (rows ascending,
        ``infos["_rows"]``), after the autoreset mode's handling of ended episodes."""
        loop, want = self.loop, self.batch_size
        running, ready = loop.running, self._ready
        if want == self.num_envs:  # every drill's result: the drills run until none does
            rows = self._all
            self._run_all(running)
        else:
            while np.count_nonzero(ready) < want:
                if not np.count_nonzero(running):  # the checks before prevent it: never forever
                    raise RuntimeError(f"recv(): {np.count_nonzero(ready)} drills have results "
                                       f"and none is running, so {want} (batch_size) never will")
                was_running = running.copy()
                loop.cycle()
                self._recv_cycles += 1
                self._make_ready(np.flatnonzero(was_running & ~running))
            rows = np.flatnonzero(ready)
            if len(rows) > want:  # those that waited longest, then the lowest index
                rows = np.sort(rows[np.argsort(self._ready_at[rows], kind="stable")[:want]])
        if rows is self._all:
            ready.fill(False)
        else:
            ready[rows] = False
        obs, (rewards, outcome), infos = self._results(rows)
        ended = outcome != _RUNNING
        truncated = outcome == _TIMEOUT  # ended too
        terminated = ended & ~truncated
        if self.max_episode_steps is not None:  # as TimeLimit: truncated at the limit,
            truncated |= self._episode_steps[rows] >= self.max_episode_steps  # ended or not
            ended = ended | truncated
        if self._same_step and np.count_nonzero(ended):
            done = np.flatnonzero(ended)
            final_obs = np.full(len(rows), None, dtype=object)
            for k in done.tolist():
                final_obs[k] = obs[k].copy()
            final_info = {k: v.copy() for k, v in infos.items()}
            for k in [k for k in final_info if k.startswith("_")]:
                final_info[k] = ended.copy()
            self._restart(rows[done])
            obs[done], _, reset_infos = self._results(rows[done])
            for k, v in reset_infos.items():
                if not k.startswith("_"):
                    infos[k][done] = v
            infos["final_obs"], infos["_final_obs"] = final_obs, ended.copy()
            infos["final_info"], infos["_final_info"] = final_info, ended.copy()
        else:
            self._autoreset[rows] = ended
        infos["_rows"] = rows
        return obs, rewards, terminated, truncated, infos

    def _run_all(self, running: np.ndarray) -> None:
        """Cycles until no drill runs, every drill then done (``batch_size`` is every
        drill, which ``step`` and ``recv``'s checks have made sure are each running or
        done): no drill's result waits for another's, so when each is done does not
        matter. Every drill's indices are handed on while all run."""
        loop, n = self.loop, self.num_envs
        left = np.count_nonzero(running)
        while left:
            left = loop.cycle(self._all if left == n else None)
            self._recv_cycles += 1

    # ------------------------------------------------------------- results
    def _results(self, rows: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray],
                                                  dict[str, Any]]:
        """Drills ``rows``' observations (of the holder, or at an end of the attacker who
        decided last), their steps' rewards and outcome codes, and their infos, as they
        stand (the holder loop's :meth:`~soccer_drill.envs.holder.HolderLoop.results`)."""
        obs, (_, durations, cycles, outcome, holders), rewards = self.loop.results(rows)
        everyone = np.ones((4, len(rows)), dtype=bool)  # each key's mask a row of its own
        infos = {
            "duration": durations, "_duration": everyone[0],
            "cycles": cycles, "_cycles": everyone[1],
            "outcome": _OUTCOMES[outcome], "_outcome": everyone[2],
            "holder": self._names[holders], "_holder": everyone[3],
        }
        return obs, (rewards, outcome), infos

    def action_masks(self) -> np.ndarray:
        """Which actions are legal in each drill now: all three, always (``(num_envs, 3)``
        bool; ``HolderEnv.action_masks`` per drill, for masking learners)."""
        return np.ones((self.num_envs, len(self.action_names)), dtype=bool)

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One frame per drill with ``render_mode="rgb_array"`` (else ``None``)."""
        if self._renderer is None:
            return None
        return self._renderer.frames(self._core.batch, self._has_reset)

    def close_extras(self, **kwargs: Any) -> None:
        """Let go of the renderer, if any (no window, no worker)."""
        if self._renderer is not None:
            self._renderer.close()


def _same(a: Any, b: Any) -> bool:
    """Whether two values given for the drills are one value (arrays element by element)."""
    if a is b:
        return True
    try:
        return bool(np.all(a == b))
    except (TypeError, ValueError):  # values that do not compare
        return False


HolderRule = Callable[[np.ndarray, np.random.Generator], int]


def _check_whole_episodes(env: HolderVectorEnv) -> None:
    """``ValueError`` if ``env`` cuts episodes short (``max_episode_steps``)."""
    if env.max_episode_steps is not None:
        raise ValueError(f"play_episodes plays whole episodes, and this environment truncates "
                         f"them at max_episode_steps={env.max_episode_steps}: give it one "
                         "made without max_episode_steps")


def play_episodes(
    env: HolderVectorEnv, policy: HolderRule | Sequence[HolderRule], seeds: Sequence[int],
) -> list[tuple[float, str]]:
    """Play one episode per seed with a fixed holder ``policy``, no drill ever waiting.

    Episode ``k`` is a ``HolderEnv`` episode from ``reset(seed=seeds[k])`` (up to the
    batch's physics, see the class docstring); ``policy(obs, rng)`` (a rule of
    :mod:`soccer_drill.policies`), or ``policy[k]`` if a sequence of one rule per seed is
    given, decides each time the holder may, with ``rng`` a generator of that episode
    (``np.random.default_rng(seeds[k])``). As soon as a drill's holder reaches a decision
    it gets its action and runs on, and a drill whose episode ends starts the next seed,
    so the batch stays full: what a Gymnasium ``step`` cannot do (each of its drills
    waits for the others' decisions). Several rules in one call keep a batch full for
    longer than one rule's episodes would (calibration plays every rule against a team
    at once). Returns ``(total reward, outcome)`` per seed, in the order of ``seeds`` (in
keepaway the total reward is the episode's length in seconds).
    A rule's action is checked as ``HolderEnv.step`` checks it, and the seeds as
    ``HolderEnv.reset`` takes them (integers >= 0): anything else is a ``ValueError``
    naming the drill and the seed. It plays the environment's holder loop
    (:attr:`HolderVectorEnv.loop`), which the environment then asks to ``reset()``
    before its next step.
    """
    seeds = list(seeds)
    for k, s in enumerate(seeds):
        check(f"seeds[{k}] (a seed of HolderEnv.reset)", s, Integer(0))
    seeds = [int(s) for s in seeds]
    policies = [policy] * len(seeds) if callable(policy) else list(policy)
    if len(policies) != len(seeds) or not all(callable(p) for p in policies):
        raise ValueError(
            f"policy must be a holder rule or a sequence of {len(seeds)} rules (one per seed)"
        )
    _check_whole_episodes(env)
    loop = env.loop
    loop.handed_to = "play_episodes()"
    core, b, n = loop.core, loop.core.batch, env.num_envs
    results: list[tuple[float, str] | None] = [None] * len(seeds)
    episode = np.full(n, -1)  # the seed index each drill plays, -1: none left
    rngs: list[np.random.Generator | None] = [None] * n
    following = 0

    def start(drills: np.ndarray) -> None:
        nonlocal following
        take = drills[: max(0, len(seeds) - following)]
        chosen: list[int | None] = [None] * n
        for i in take.tolist():
            chosen[i] = seeds[following]
            rngs[i] = np.random.default_rng(seeds[following])
            episode[i] = following
            following += 1
        episode[drills[len(take):]] = -1
        core.seed(chosen)
        loop.restart(take)

    start(np.arange(n))
    while np.count_nonzero(episode >= 0):
        deciding = np.flatnonzero((episode >= 0) & ~loop.running)
        if len(deciding):  # the features of the deciding holders only
            obs = loop.observe(b.state, deciding, b.holder[deciding])
            actions = np.zeros(len(deciding), dtype=np.int64)
            for k, (i, e) in enumerate(zip(deciding.tolist(), episode[deciding].tolist(),
                                           strict=True)):
                action = policies[e](obs[k], rngs[i])  # type: ignore[arg-type]
                try:
                    actions[k] = loop.check_action(action)
                except ValueError as error:
                    raise ValueError(
                        f"drill {i} (seed {seeds[e]}): the rule returned {action!r}; {error}"
                    ) from None
            loop.begin(deciding, actions)
        loop.cycle()
        ended = np.flatnonzero((episode >= 0) & (b.outcome != Outcome.RUNNING))
        if len(ended):
            for i in ended.tolist():
                total = float(b.attacker_reward[i])
                if loop.cycle_reward:  # keepaway's seconds; nothing in the drill
                    total += loop.cycle_reward * int(b.cycle[i])
                results[episode[i]] = (total, OUTCOME_NAMES[b.outcome[i]])
            start(ended)
    return results  # type: ignore[return-value]
