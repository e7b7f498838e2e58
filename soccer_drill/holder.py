"""The ball holder's view of the drill as a Gymnasium environment (an SMDP)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from soccer_drill.config import DrillConfig
from soccer_drill.core import DrillCore, concurrent_use, make_config, not_reset
from soccer_drill.skills import HOLDER_ACTIONS, Command
from soccer_drill.state import PLAYER_NAMES
from soccer_drill.teams import DEFAULT_TEAM_TIMEOUT, Team

_HOLDER_COMMANDS = tuple(Command(skill) for skill in HOLDER_ACTIONS)


class HolderEnv(gym.Env):
    """The drill as seen by whichever attacker holds the ball: keepaway's SMDP.

    Only the ball holder decides; its teammate runs a fixed stochastic support
    behaviour (:class:`~soccer_drill.support.SupportPlayer`) and the defenders
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
    :mod:`soccer_drill.features`).

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
    | ``"rgb_array_list"`` | every frame since the last ``render()`` (or ``reset``): one per 0.1 s cycle, so a video written at ``metadata["render_fps"]`` (10) plays at true speed, e.g. ``gymnasium.utils.save_video.save_video(env.render(), "videos", fps=10)`` (needs moviepy) |
    | ``"human"`` | ``None``; a window shows every cycle at 10 frames per second |

    Gymnasium's ``RecordVideo`` keeps one frame per ``step`` (with a list it keeps the
    last one), and a step lasts several cycles, so its videos play faster than the drill
    ran; use ``"rgb_array_list"`` and ``save_video`` for true speed.

    ## Seeding

    ``reset(seed=s)`` makes the episode a function of ``s`` and the actions alone:
    observations, rewards and infos are bit-identical to those of a fresh
    environment's ``reset(seed=s)`` with the same actions, whatever episodes ran before
    (the physics space is rebuilt on every reset), for every team. ``reset()`` without a
    seed continues the generator. The team and the support player draw from their own
    generators, seeded from the drill's at each reset; rendering changes nothing; a
    ``pickle`` copy reseeded with ``s`` plays the same episode.

    ## Threads

    One environment must be stepped by one thread at a time: a ``step`` or ``reset``
    that starts while another thread is inside one raises ``RuntimeError``. Separate
    environments in separate threads are fine.

    ## Arguments

    | argument | default | meaning |
    |----------|---------|---------|
    | ``opponent`` | ``"chasers"`` | team id or a ``Team`` instance |
    | ``opponent_params`` | ``None`` | keyword parameters of the team factory |
    | ``max_cycles`` | ``None`` | overrides ``config.max_cycles`` (default 100) |
    | ``config`` | ``None`` | a ``DrillConfig`` or a dict of its fields |
    | ``render_mode`` | ``None`` | ``"human"``, ``"rgb_array"`` or ``"rgb_array_list"`` (see Rendering) |
    | ``decision_cycles`` | ``4`` | cycles a ``HOLD`` or ``DRIBBLE`` lasts (fewer if possession changes); ``PASS`` lasts until an attacker controls the ball |
    | ``team_timeout`` | ``1.0`` | seconds of CPU time each ``reset``/``act`` call of the team may take before it is stopped with ``TeamError`` naming it (time spent waiting, e.g. on a loaded machine, is not counted); ``None``: no bound (see ``soccer_drill.teams.TeamDriver``) |
    """

    metadata: ClassVar[dict] = {
        "render_modes": ["human", "rgb_array", "rgb_array_list"],
        "render_fps": 10,
    }

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
        if not isinstance(decision_cycles, int) or isinstance(decision_cycles, bool) or not (
            1 <= decision_cycles <= 50
        ):
            raise ValueError(f"decision_cycles must be an integer in 1..50, got {decision_cycles!r}")
        self.decision_cycles = decision_cycles
        if opponent is None:
            raise ValueError("HolderEnv needs a scripted opponent team (a team id or Team)")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.config = make_config(config, max_cycles)
        self._core = DrillCore(
            opponent, opponent_params, self.config, "features", scripted_attackers=(0, 1),
            team_timeout=team_timeout,
        )
        self.observation_space = self._core.obs_box
        self.action_space = spaces.Discrete(len(HOLDER_ACTIONS))
        self.render_mode = render_mode
        self.caption: str | None = None
        """Extra text drawn on rendered frames (e.g. the active option)."""
        self._renderers: dict = {}
        self._frames: list[np.ndarray] | None = None
        self._cycle_frames: list[np.ndarray] = []  # rgb_array_list: frames since render()

    @property
    def drill_state(self):
        """The current :class:`~soccer_drill.state.DrillState`."""
        if not self._core.has_reset:
            raise not_reset("drill_state")
        return self._core.drill.state

    def record_frames(self, frames: list[np.ndarray] | None) -> None:
        """Append an ``rgb_array`` frame to ``frames`` after every cycle (``None`` stops)."""
        self._frames = frames
        if frames is not None and self._core.has_reset:  # mid-episode: draw now
            frames.append(self._draw("rgb_array"))

    def reset(
        self, *, seed: int | None = None, options: dict | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; the observation is the 9 features of the attacker given the ball."""
        core = self._core
        with core.exclusive(self, "reset"):
            super().reset(seed=seed)
            core.seed(seed)
            core.reset()
            self._cycle_frames = []
            self._after_cycle()
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
        if isinstance(action, np.ndarray) and action.shape == ():
            action = action.item()
        if isinstance(action, bool) or not isinstance(action, int | np.integer) or not (
            0 <= action < len(HOLDER_ACTIONS)
        ):
            raise ValueError(
                f"action must be an integer in 0..{len(HOLDER_ACTIONS) - 1} "
                f"(0=HOLD, 1=PASS, 2=DRIBBLE), got {action!r}"
            )
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
        if self.render_mode == "human":
            self._draw("human")
        elif self.render_mode == "rgb_array_list":
            self._cycle_frames.append(self._draw("rgb_array"))
        if self._frames is not None:
            self._frames.append(self._draw("rgb_array"))

    def _draw(self, mode: str) -> np.ndarray | None:
        from soccer_drill.render import Renderer

        renderer = self._renderers.get(mode)
        if renderer is None:
            renderer = self._renderers[mode] = Renderer(
                self.config, mode, self.metadata["render_fps"]
            )
        drill = self._core.drill
        return renderer.draw(drill.state, drill.outcome, self.caption)

    def render(self) -> np.ndarray | list[np.ndarray] | None:
        """The current frame, the frames since the last call, or ``None`` (see Rendering)."""
        if self.render_mode is None:
            return None
        if not self._core.has_reset:
            raise not_reset("render")
        if self.render_mode == "rgb_array_list":
            frames, self._cycle_frames = self._cycle_frames, []
            return frames
        return self._draw(self.render_mode)

    def close(self) -> None:
        """Close any window opened by human rendering."""
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers = {}
