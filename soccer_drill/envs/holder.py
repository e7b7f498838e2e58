"""The ball holder's view of the drill as a Gymnasium environment (an SMDP)."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked, is_int
from soccer_drill.envs.core import DrillCore, concurrent_use, make_config, not_reset
from soccer_drill.rendering.screen import RENDER_MODES, Screen, frames_per_second
from soccer_drill.skills import HOLDER_ACTIONS, Command
from soccer_drill.state import PLAYER_NAMES
from soccer_drill.teams import DEFAULT_TEAM_TIMEOUT, Team

_HOLDER_COMMANDS = tuple(Command(skill) for skill in HOLDER_ACTIONS)


DECISION_CYCLES_RANGE = (1, 50)
"""The cycles a HOLD or DRIBBLE may last (``decision_cycles``)."""
DECISION_CYCLES = Integer(*DECISION_CYCLES_RANGE)
"""What ``decision_cycles`` may be: an integer in :data:`DECISION_CYCLES_RANGE`."""


def check_decision_cycles(decision_cycles: object) -> int:
    """``decision_cycles`` as an int (a Python or NumPy integer, not a bool) in
    :data:`DECISION_CYCLES_RANGE`, else ``ValueError`` saying what is allowed."""
    return checked("decision_cycles", decision_cycles, DECISION_CYCLES)



def check_holder_action(action: object) -> int:
    """``action`` as an int in 0..2, as ``HolderEnv.step`` takes it: an int, a NumPy
    integer or a 0-d integer array; bools, floats and values out of range are refused."""
    if isinstance(action, np.ndarray) and action.shape == ():
        action = action.item()
    if not is_int(action) or not 0 <= action < len(HOLDER_ACTIONS):  # type: ignore[operator]
        raise ValueError(
            f"action must be an integer in 0..{len(HOLDER_ACTIONS) - 1} "
            f"(0=HOLD, 1=PASS, 2=DRIBBLE), got {action!r}"
        )
    return int(action)

class HolderEnv(gym.Env):
    """The drill as seen by whichever attacker holds the ball: keepaway's SMDP.

    Only the ball holder decides; its teammate runs a fixed stochastic support
    behaviour (:class:`~soccer_drill.rules.support.SupportPlayer`) and the defenders
    are a scripted team. One :meth:`step` applies the holder's action -- for
    ``decision_cycles`` cycles (0.4 s by default) for HOLD and DRIBBLE, for one kick
    for PASS -- and then runs cycles until an attacker holds the ball again (the
    next decision) or the episode ends. Basic options of a few cycles, rather than
    keepaway's one cycle, make the drill learnable in hundreds of episodes rather
    than thousands (see ``docs/learning.md``).

    ## Action space

    ``Discrete(3)``: 0 ``HOLD`` (shield the ball), 1 ``PASS`` (to the teammate),
    2 ``DRIBBLE`` (toward the goal line) -- the paper's three basic options.

    ## Observation space

    ``Box(9,)`` float32: the 9 features of the holder (units and bounds in
    :mod:`soccer_drill.rules.features`).

    ## Rewards

    Zero until the episode ends; then success pays 1.0 at the centre of the goal
    line falling linearly to 0.5 at its ends, and an interception, the ball
    leaving the region or a timeout pays -1 (configurable in ``DrillConfig``).

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
    (the physics space is rebuilt on every reset), for every team. ``reset()`` without a
    seed continues the generator. The team and the support player draw from their own
    generators, seeded from the drill's at each reset; rendering changes nothing.

    ## Copies

    ``copy.deepcopy``, ``copy.copy`` and ``pickle`` all give an independent environment
    continuing the episode, as those of :class:`soccer_drill.raw_env` do: the same
    actions give bit-identical steps in the copy and the original, and stepping one
    never moves the other. Windows and renderers are not copied. ``gym.make`` puts the
    environment inside Gymnasium's wrappers, which ``copy.copy`` copies shallowly: that
    copy shares the environment with the original. There, use ``copy.deepcopy`` or
    ``pickle`` (the whole stack), or ``copy.copy(env.unwrapped)`` (this environment alone).

    ## Threads

    One environment must be stepped by one thread at a time: a ``step`` or ``reset``
    that starts while another thread is inside one raises ``RuntimeError``. Separate
    environments in separate threads are fine.

    ## Arguments

    | argument | default | meaning |
    |----------|---------|---------|
    | ``opponent`` | ``"chasers"`` | team id or a ``Team`` instance |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory (with a team id; refused with an instance) |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` (default 100) |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``render_mode`` | ``None`` | ``"human"``, ``"rgb_array"`` or ``"rgb_array_list"`` (see Rendering) |
    | ``decision_cycles`` | ``4`` | cycles a ``HOLD`` or ``DRIBBLE`` lasts (an integer in [1, 50]; fewer if possession changes); ``PASS`` lasts until an attacker controls the ball |
    | ``team_timeout`` | ``1.0`` | seconds of CPU time each ``reset``/``act`` call of the team may take before it is stopped with ``TeamError`` naming it (time spent waiting, e.g. on a loaded machine, is not counted); ``None``: no bound (see ``soccer_drill.teams.TeamDriver``) |
    """

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 10}

    def __init__(
        self,
        opponent: str | Team = "chasers",
        opponent_params: Mapping[str, Any] | None = None,
        max_cycles: int | None = None,
        config: DrillConfig | Mapping[str, Any] | None = None,
        render_mode: str | None = None,
        decision_cycles: int = 4,
        team_timeout: float | None = DEFAULT_TEAM_TIMEOUT,
    ) -> None:
        self.decision_cycles = check_decision_cycles(decision_cycles)
        if opponent is None:
            raise ValueError("HolderEnv needs a scripted opponent team (a team id or Team)")
        self.config = make_config(config, max_cycles)
        # One frame per cycle: true speed at 1 / cycle_seconds frames per second.
        self.metadata = {**HolderEnv.metadata, "render_fps": frames_per_second(self.config)}
        self._screen = Screen(self.config, render_mode, self.metadata["render_fps"])
        self.render_mode = render_mode
        self._core = DrillCore(
            opponent, opponent_params, self.config, "features", scripted_attackers=(0, 1),
            team_timeout=team_timeout,
        )
        self.observation_space = self._core.obs_box
        self.action_space = spaces.Discrete(len(HOLDER_ACTIONS))

    def __copy__(self) -> HolderEnv:
        """An independent copy continuing the episode (see Copies)."""
        return copy.deepcopy(self)

    @property
    def caption(self) -> str | None:
        """Extra text drawn on rendered frames (e.g. the active option)."""
        return self._screen.caption

    @caption.setter
    def caption(self, text: str | None) -> None:
        self._screen.caption = text

    @property
    def drill_state(self):
        """The current :class:`~soccer_drill.state.DrillState`."""
        if not self._core.has_reset:
            raise not_reset("drill_state")
        return self._core.drill.state

    def record_frames(self, frames: list[np.ndarray] | None) -> None:
        """Append an ``rgb_array`` frame to ``frames`` after every cycle (``None`` stops)."""
        core = self._core
        state = core.drill.state if core.has_reset else None  # mid-episode: draw now
        self._screen.record(frames, state, core.drill.outcome)

    def action_masks(self) -> np.ndarray:
        """Which actions are legal now: all three, always (bool; for sb3-contrib's
        ``MaskablePPO``, which asks every environment for ``action_masks()``)."""
        return np.ones(len(HOLDER_ACTIONS), dtype=bool)

    def reset(
        self, *, seed: int | None = None, options: dict | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; the observation is the 9 features of the attacker given the ball."""
        core = self._core
        with core.exclusive(self, "reset"):
            super().reset(seed=seed)
            core.seed(seed)
            core.reset()
            self._screen.start(core.drill.state, None)
            holder = core.drill.state.holder
            return core.observe(holder), {
                "duration": 0, "cycles": 0, "outcome": None, "holder": PLAYER_NAMES[holder],
            }

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the holder's action and run to its next decision or the end (see the class docstring)."""
        busy = self._core.busy
        if not busy.acquire(False):
            raise concurrent_use(self, "step")
        try:
            return self._step(action)
        finally:
            busy.release()

    def _step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self._core.has_reset:
            raise not_reset("step")
        drill = self._core.drill
        if drill.outcome is not None:
            raise RuntimeError("step() called after the episode ended; call reset()")
        action = check_holder_action(action)
        holder = drill.state.holder
        command = _HOLDER_COMMANDS[int(action)]
        start = drill.state.cycle
        # HOLD and DRIBBLE last up to `decision_cycles` cycles while the holder keeps the ball.
        repeats = 1 if int(action) == 1 else self.decision_cycles
        for _ in range(repeats):
            commands: list = [None] * 4
            commands[holder] = command
            self._core.advance(commands)
            self._after_cycle()
            if drill.outcome is not None or drill.state.holder != holder:
                break
        while drill.outcome is None and drill.state.holder not in (0, 1):
            self._core.advance([None] * 4)
            self._after_cycle()
        s = drill.state
        info = {
            "duration": s.cycle - start,
            "cycles": s.cycle,
            "outcome": drill.outcome,
            "holder": PLAYER_NAMES[s.holder] if drill.outcome is None else None,
        }
        if drill.outcome is None:
            return self._core.observe(s.holder), 0.0, False, False, info
        # At the end, observe from the attacker who last had the ball (or attacker_0).
        last = holder if s.holder not in (0, 1) else s.holder
        obs = self._core.observe(last)
        truncated = drill.outcome == "timeout"
        return obs, float(drill.attacker_reward), not truncated, truncated, info

    def _after_cycle(self) -> None:
        screen = self._screen
        if screen.each_cycle:
            drill = self._core.drill
            screen.after_cycle(drill.state, drill.outcome)

    def render(self) -> np.ndarray | list[np.ndarray] | None:
        """The current frame, the frames since the last call, or ``None`` (see Rendering)."""
        if self.render_mode is None:
            return None
        if not self._core.has_reset:
            raise not_reset("render")
        drill = self._core.drill
        return self._screen.render(drill.state, drill.outcome)

    def close(self) -> None:
        """Close any window opened by human rendering."""
        self._screen.close()
