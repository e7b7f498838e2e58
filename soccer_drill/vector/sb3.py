"""The batched holder as a Stable-Baselines3 ``VecEnv``: many drills in one process for SB3.

Needs ``stable-baselines3`` (and so torch), which ``soccer_drill`` does not depend on:
import this module only where SB3 is installed (``pip install 'soccer-drill-ilpss[integrations]'``).

SB3's ``VecEnv`` predates Gymnasium 1.x's vector API, so SB3 cannot take
:class:`~soccer_drill.vector.HolderVectorEnv` as it is. :class:`HolderSB3VecEnv` runs one
``HolderVectorEnv`` (its ``SAME_STEP`` autoreset) behind SB3's conventions, and gives
what SB3's ``DummyVecEnv`` of ``num_envs`` ``HolderEnv`` gives, episode for episode
(up to the batch's physics, see ``HolderVectorEnv``'s docstring):

| SB3 | here |
|---|---|
| ``reset()`` | every drill starts an episode, seeded by the last ``seed(s)`` (drill ``i``: ``s + i``) or, without one, each going on with its own stream; options of the last ``set_options`` (one dict for all drills); ``reset_infos`` holds each drill's reset info |
| ``step_async(actions)`` / ``step_wait()`` | one action per drill (``(num_envs,)`` integers); returns observations ``(num_envs, 9)`` float32, rewards float32, ``dones`` (terminated or truncated) and one info dict per drill |
| an episode's end | the drill is reset within the step: its observation is the next episode's first; ``infos[i]["terminal_observation"]`` is the final one, ``infos[i]["TimeLimit.truncated"]`` whether it was a timeout, and ``reset_infos[i]`` the new episode's reset info |
| ``get_attr``, ``env_method`` | the batched env's attribute or method, once per index asked (the drills share it; no index: nothing is called); ``env_method("action_masks")`` gives each drill its row of ``HolderVectorEnv.action_masks()`` (all three actions, as ``HolderEnv.action_masks``: sb3-contrib's ``MaskablePPO`` runs on it); a method that acts on every drill at once (``reset``, ``close``, ...) for only some of them: ``ValueError`` |
| ``set_attr`` | on the batched env, for every drill at once (other indices: ``ValueError``); ``autoreset_mode``, ``batch_size`` and ``num_envs``, which this class sets itself, are refused |
| ``indices`` | ``None`` (every drill), an int or a sequence of ints in ``0..num_envs-1``, as SB3's ``_get_indices`` reads them; anything else (out of range, strings, floats, bools): ``TypeError``/``ValueError`` |
| ``env_is_wrapped`` | ``False`` for each drill (no Gymnasium wrapper is inside) |
| ``get_images()`` | one frame per drill with ``render_mode="rgb_array"`` |
| ``copy.copy``, ``copy.deepcopy``, ``pickle`` | an independent copy continuing every drill's episode |

SB3's own vector wrappers (``VecMonitor``, ``VecNormalize``, ``VecFrameStack``) take it
as any ``VecEnv``; ``Monitor`` wraps a single env, so episode statistics come from
``VecMonitor`` here.

Arguments: ``num_envs``, ``timeout_terminal`` and every other keyword argument of
``HolderVectorEnv`` (``opponent``, ``opponent_params``, ``config``, ``drills_per_space``,
...), except ``autoreset_mode`` and ``batch_size`` (SB3 steps every drill and resets
within the step).

**The drill's timeout.** The drill ends an episode at its timeout paying -1 (a failure, as
an interception is) and reports it as a truncation, as Gymnasium's ``HolderEnv`` does; SB3
then adds the value of the last state to that -1 (a bootstrap, right for an episode cut
short, not for one that ended), and PPO against ``chasers`` learnt nothing in 3 of 3 seeds
so (``docs/reference_rl.md``). ``timeout_terminal=True`` reports the timeout as the end
it is (``TimeLimit.truncated`` false: no bootstrap); a cut by ``max_episode_steps`` stays
a truncation. The default, ``False``, gives what ``DummyVecEnv`` of ``HolderEnv`` gives.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv

from soccer_drill.constraints import Bool, checked
from soccer_drill.vector.holder import (
    EVERY_DRILL,
    FIXED_ATTRIBUTES,
    ROW_PER_DRILL,
    HolderVectorEnv,
    check_drill_indices,
)

__all__ = ["HolderSB3VecEnv"]

class HolderSB3VecEnv(VecEnv):
    """``num_envs`` holder drills in one ``HolderVectorEnv``, as an SB3 ``VecEnv`` (see the
    module docstring)."""

    def __init__(self, num_envs: int = 1, *, timeout_terminal: bool = False,
                 **kwargs: Any) -> None:
        self.timeout_terminal = checked("timeout_terminal", timeout_terminal, Bool())
        fixed = sorted({"autoreset_mode", "batch_size"} & set(kwargs))
        if fixed:
            raise ValueError(
                f"HolderSB3VecEnv sets {', '.join(fixed)} itself (SB3 steps every drill and "
                "resets a drill within the step that ends its episode); leave it out"
            )
        self.venv = HolderVectorEnv(num_envs=num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        super().__init__(
            self.venv.num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )
        self._actions: np.ndarray | None = None

    def __copy__(self) -> HolderSB3VecEnv:
        """An independent copy continuing every drill's episode, as ``copy.deepcopy`` and
        ``pickle`` give (a shallow copy would share the batched env, and its steps move
        the original's drills)."""
        return copy.deepcopy(self)

    # -------------------------------------------------------------- stepping
    def reset(self) -> np.ndarray:
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        obs, infos = self.venv.reset(seed=seeds, options=self._shared_options())
        self.reset_infos = _per_drill(infos, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async(actions)")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, infos = self.venv.step(actions)
        dones = terminated | truncated
        out = _per_drill(infos, self.num_envs)
        if np.count_nonzero(dones):
            final = _per_drill(infos["final_info"], self.num_envs)
            for i in np.flatnonzero(dones).tolist():
                self.reset_infos[i] = out[i]  # the new episode's, as DummyVecEnv keeps it
                out[i] = final[i]
                out[i]["terminal_observation"] = infos["final_obs"][i]
        for i, info in enumerate(out):
            cut = truncated[i] and not terminated[i]
            if cut and self.timeout_terminal and info.get("outcome") == "timeout":
                cut = False  # the drill's timeout, which pays -1, as the end it is
            info["TimeLimit.truncated"] = bool(cut)
        return obs, rewards.astype(np.float32), dones, out

    def _shared_options(self) -> dict[str, Any] | None:
        """The options of the next reset: one dict for every drill (the batch resets them
        together), or ``None``."""
        first = self._options[0]
        if any(o != first for o in self._options):
            raise ValueError(
                "HolderSB3VecEnv resets its drills together, so they take one options dict; "
                f"set_options() was given different ones: {self._options!r}"
            )
        if first and "reset_mask" in first:  # SB3's reset() starts every drill
            raise ValueError(
                "HolderSB3VecEnv's reset() starts every drill, as SB3's VecEnv.reset does, "
                "so its options take no reset_mask (set_options was given one); the batch "
                "resets a drill on its own when its episode ends")
        return dict(first) or None

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        frames = self.venv.render()
        return [None] * self.num_envs if frames is None else list(frames)

    # ---------------------------------------------------------- attributes
    def _get_indices(self, indices: Any) -> list[int]:
        """SB3's indices, checked (see ``soccer_drill.vector.check_drill_indices``)."""
        return check_drill_indices(indices, self.num_envs)

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        if attr_name in FIXED_ATTRIBUTES:
            raise ValueError(
                f"set_attr({attr_name!r}): HolderSB3VecEnv sets it itself (SB3 steps every drill "
                f"and resets a drill within its step); attributes it refuses: {sorted(FIXED_ATTRIBUTES)}"
            )
        if sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(
                f"set_attr({attr_name!r}): the drills share one environment, so an attribute is "
                "set for every drill (indices=None) or for none"
            )
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None,
                   **method_kwargs: Any) -> list[Any]:
        chosen = self._get_indices(indices)
        if not chosen:
            return []  # no drill: nothing is called, as DummyVecEnv
        if method_name in EVERY_DRILL and sorted(set(chosen)) != list(range(self.num_envs)):
            raise ValueError(
                f"env_method({method_name!r}) acts on every drill of the shared batch at once: "
                f"call it for every drill (indices=None), not for {chosen}"
            )
        if method_name in ROW_PER_DRILL:  # each drill its row (a frame, or None)
            rows = self.venv.call(method_name, *method_args, **method_kwargs)
            return [rows[i] for i in chosen]
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in chosen]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def _per_drill(infos: dict[str, Any], n: int) -> list[dict[str, Any]]:
    """A Gymnasium vector env's infos (arrays, with ``_key`` masks) as one dict per drill
    (NumPy scalars as Python ones, as ``HolderEnv`` gives them)."""
    out: list[dict[str, Any]] = [{} for _ in range(n)]
    for key, values in infos.items():
        if key.startswith("_") or key in ("final_obs", "final_info"):
            continue
        mask = infos.get(f"_{key}")
        for i in range(n) if mask is None else np.flatnonzero(mask).tolist():
            value = values[i]
            out[i][key] = value.item() if isinstance(value, np.generic) else value
    return out
