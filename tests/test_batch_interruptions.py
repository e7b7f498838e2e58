"""A Ctrl-C part-way through a batched environment's ``reset``, ``step``, ``send`` or
``recv`` (or ``play_episodes``): the environment either goes on as if the call had not
been made, or refuses every later call with an error saying to call ``reset()``, after
which every drill plays as in a new environment. No drill is lost, and no call half made
passes for one made or not made.

Interruptions are injected two ways: a team that raises ``SIGINT`` in this process at
its k-th call (the user's Ctrl-C arriving while the team computes, for several k), and a
trace hook delivering a ``SIGINT`` at the k-th Python function call inside one call of
the environment (where the interpreter runs signal handlers: a function's entry), at
points spread over the whole call. A Ctrl-C while pymunk builds or frees a space never
crashes the process, in the single drill either.
"""

from __future__ import annotations

import copy
import re
import signal
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

import soccer_drill
from soccer_drill import Command, Skill
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.teams.kit import BatchCommands
from soccer_drill.vector import HolderVectorEnv, play_episodes
from soccer_drill.vector.agents import ParallelVectorEnv

pytestmark = pytest.mark.skipif(sys.platform == "win32",
                                reason="raise_signal(SIGINT) ends the process")

N = 4
RESET = r"call reset\(\)|before reset\(\) or async_reset\(\); call one first"


# ------------------------------------------------------------------ teams
class _CtrlC:
    """Counts the calls of every team below down; at zero, the user's Ctrl-C arrives
    (``SIGINT`` raised in this process) while the team computes."""

    left = -1

    @classmethod
    def tick(cls) -> None:
        cls.left -= 1
        if cls.left == 0:
            signal.raise_signal(signal.SIGINT)


class Copies:
    """A team without a batched form: one copy per drill."""

    def reset(self, view, rng):
        _CtrlC.tick()
        self.players = view.players

    def act(self, view):
        _CtrlC.tick()
        return {p: Command(Skill.INTERCEPT) for p in self.players}


class _Batch:
    def reset(self, view, drills, rng):
        _CtrlC.tick()

    def act(self, view, drills):
        _CtrlC.tick()
        m = len(drills)
        return BatchCommands(np.full((m, 2), int(Skill.INTERCEPT)), np.zeros((m, 2, 2)),
                             np.ones((m, 2)))


class Batched(Copies):
    """A team with a batched form: one call for every drill."""

    def batch(self, n):
        return _Batch()


# ------------------------------------------------------------ what is played
def _digest(value):
    """What a call returned, comparable with ``==`` bit for bit."""
    if isinstance(value, dict):
        return {k: _digest(v) for k, v in value.items()}
    if isinstance(value, tuple | list):
        return [_digest(v) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype == object:
            return [_digest(v) for v in value.tolist()]
        return (value.dtype.str, value.shape, value.tobytes())
    return value


@dataclass
class Mode:
    """How a batched environment is made, reset and played, and the calls that must
    refuse after an interruption that asks for a reset."""

    make: Callable
    reset: Callable
    round: Callable  # one step (or recv then send) with actions from rng
    calls: Callable  # env -> the calls that must then refuse

    def play(self, env, seed: int, rounds: int) -> list:
        rng = np.random.default_rng(seed)
        out = [_digest(self.reset(env, seed))]
        out += [_digest(self.round(env, rng)) for _ in range(rounds)]
        return out


def _async_round(env, rng):
    obs, rewards, terminated, truncated, infos = env.recv()
    env.send(rng.integers(3, size=len(obs)), infos["env_id"])
    return obs, rewards, terminated, truncated, infos


MODES = {
    "holder step": Mode(
        make=lambda team: HolderVectorEnv(N, opponent=team, drills_per_space=2),
        reset=lambda env, seed: env.reset(seed=seed),
        round=lambda env, rng: env.step(rng.integers(3, size=N)),
        calls=lambda env: [lambda: env.step(np.zeros(N, dtype=int))],
    ),
    "holder send/recv": Mode(
        make=lambda team: HolderVectorEnv(N, opponent=team, batch_size=2),
        reset=lambda env, seed: env.async_reset(seed=seed),
        round=_async_round,
        calls=lambda env: [env.recv, lambda: env.send(np.zeros(N, dtype=int))],
    ),
    "parallel step": Mode(
        make=lambda team: ParallelVectorEnv(N, opponent=team),
        reset=lambda env, seed: env.reset(seed=seed),
        round=lambda env, rng: env.step({a: rng.integers(5, size=N) for a in env.agents}),
        calls=lambda env: [lambda: env.step({a: np.zeros(N, dtype=int) for a in env.agents})],
    ),
}


def _refuses_until_reset_then_plays_as_new(mode: Mode, env, team) -> None:
    """Every call refuses, saying to call reset(); a reset then brings every drill back
    as in a new environment."""
    for call in mode.calls(env):
        with pytest.raises(RuntimeError, match=RESET):
            call()
    assert mode.play(env, 5, 8) == mode.play(mode.make(team()), 5, 8)


# --------------------------------------------- a Ctrl-C while the team computes
def _holder_round(env, rng):
    out = env.step(int(rng.integers(3)))
    return (out, env.reset(seed=int(rng.integers(1 << 30)))) if out[2] or out[3] else out


def _parallel_round(env, rng):
    out = env.step({a: int(rng.choice(np.flatnonzero(env.action_mask(a)))) for a in env.agents})
    return out if env.agents else (out, env.reset(seed=int(rng.integers(1 << 30))))


def _aec_round(env, rng):
    """Every agent's turn once (a cycle), or the turns left in the episode."""
    seen = []
    for _ in env.possible_agents:
        seen.append(env.last())
        done = seen[-1][2] or seen[-1][3]
        env.step(None if done else int(rng.choice(np.flatnonzero(env.action_mask()))))
        if not env.agents:
            env.reset(seed=int(rng.integers(1 << 30)))
            break
    return seen


SINGLE = {
    "HolderEnv": Mode(
        make=lambda team: soccer_drill.HolderEnv(opponent=team),
        reset=lambda env, seed: env.reset(seed=seed), round=_holder_round,
        calls=lambda env: [lambda: env.step(0)]),
    "parallel_env": Mode(
        make=lambda team: soccer_drill.parallel_env(opponent=team),
        reset=lambda env, seed: env.reset(seed=seed), round=_parallel_round,
        calls=lambda env: [lambda: env.step(dict.fromkeys(env.possible_agents, 0))]),
    "raw_env": Mode(
        make=lambda team: soccer_drill.env(opponent=team),
        reset=lambda env, seed: env.reset(seed=seed), round=_aec_round,
        calls=lambda env: [lambda: env.step(0)]),
}


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5, 9, 17, 30])
@pytest.mark.parametrize("team", [Copies, Batched])
@pytest.mark.parametrize("mode", [*MODES, *SINGLE])
def test_a_ctrl_c_while_the_team_computes_asks_for_a_reset_which_brings_every_drill_back(
    mode, team, k
):
    """In the batched environments and the single ones (before, the next step of a single
    one carried on from a drill half reset, the new start with the old episode's cycle, or
    from a cycle half run)."""
    mode = {**MODES, **SINGLE}[mode]
    env = mode.make(team())
    _CtrlC.left = k
    try:
        with pytest.raises(KeyboardInterrupt):
            mode.play(env, 0, 40)
    finally:
        _CtrlC.left = -1
    _refuses_until_reset_then_plays_as_new(mode, env, team)


def test_a_ctrl_c_in_play_episodes_asks_for_a_reset():
    env = HolderVectorEnv(N, opponent=Copies())
    env.reset(seed=0)
    _CtrlC.left = 9
    try:
        with pytest.raises(KeyboardInterrupt):
            play_episodes(env, HOLDER_POLICIES["hold"], range(8))
    finally:
        _CtrlC.left = -1
    _refuses_until_reset_then_plays_as_new(MODES["holder step"], env, Copies)


def _interrupted(step: Callable, k: int) -> None:
    """Steps until the user's Ctrl-C, which arrives at the team's ``k``-th call."""
    _CtrlC.left = k
    try:
        with pytest.raises(KeyboardInterrupt):
            for _ in range(5):
                step()
    finally:
        _CtrlC.left = -1


def test_a_reset_of_some_drills_does_not_clear_an_interruption():
    env = HolderVectorEnv(N, opponent=Copies())
    env.reset(seed=0)
    _interrupted(lambda: env.step(np.zeros(N, dtype=int)), 6)
    env.reset(options={"reset_mask": np.array([True, False, True, False])})
    with pytest.raises(RuntimeError, match=r"without reset_mask.*" + RESET + "|" + RESET):
        env.step(np.zeros(N, dtype=int))
    env.reset(seed=1)
    env.step(np.zeros(N, dtype=int))


# ------------------------------------------- a Ctrl-C at any call inside a call
class _CtrlCAtCall:
    """A trace hook delivering a ``SIGINT`` at the ``k``-th Python function call: it runs
    the handler installed then, as the interpreter would (Python's own raises
    ``KeyboardInterrupt`` there)."""

    def __init__(self, k: int) -> None:
        self.k, self.seen, self.fired = k, 0, False

    def __call__(self, frame, event, arg):
        if event == "call":
            self.seen += 1
            if self.seen == self.k:
                sys.settrace(None)
                self.fired = True
                handler = signal.getsignal(signal.SIGINT)
                if callable(handler):
                    handler(signal.SIGINT, frame)
        return None


_MISSING = object()


def _traced(op: Callable, env, k: int) -> tuple[object, _CtrlCAtCall]:
    """``op(env)`` with a Ctrl-C at its ``k``-th function call (``_MISSING``: it came)."""
    hook = _CtrlCAtCall(k)
    sys.settrace(hook)
    try:
        out = op(env)
    except KeyboardInterrupt:
        out = _MISSING
    finally:
        sys.settrace(None)
    return out, hook


def _waiting_ids(env) -> np.ndarray:
    """Start the asynchronous loop; the drills of the last recv(), waiting for actions."""
    env.async_reset(seed=0)
    _async_round(env, np.random.default_rng(1))
    return env.recv()[4]["env_id"]


def _before_reset(env):
    env.reset(seed=0)
    env.step(np.full(N, 2))
    return lambda e: e.reset(seed=3), lambda e: e.step(np.array([0, 1, 2, 1]))


def _before_step(env):
    env.reset(seed=0)
    env.step(np.full(N, 2))
    return lambda e: e.step(np.array([0, 1, 2, 1]))


def _before_send(env):
    ids = _waiting_ids(env)
    return lambda e: e.send(np.array([1, 2]), ids)


def _before_recv(env):
    env.send(np.array([2, 0]), _waiting_ids(env))
    return lambda e: e.recv()


def _before_parallel_step(env):
    env.reset(seed=0)
    env.step({a: np.zeros(N, dtype=int) for a in env.agents})
    return lambda e: e.step({a: np.ones(N, dtype=int) for a in e.agents})


# Each case: its mode, and what brings a new environment to the call, returning the call
# (and the call made next: the same call again, unless it is given).
CASES = {
    "holder reset": ("holder step", _before_reset),
    "holder step": ("holder step", _before_step),
    "holder send": ("holder send/recv", _before_send),
    "holder recv": ("holder send/recv", _before_recv),
    "parallel step": ("parallel step", _before_parallel_step),
}


def _prepared(case: str, team):
    mode_name, prepare = CASES[case]
    mode = MODES[mode_name]
    env = mode.make(team)
    calls = prepare(env)
    op, following = calls if isinstance(calls, tuple) else (calls, calls)
    return mode, env, op, following


@pytest.mark.parametrize("team", ["chasers", Copies])
@pytest.mark.parametrize("case", list(CASES))
def test_a_ctrl_c_at_any_point_of_a_call_leaves_it_undone_or_asks_for_a_reset(case, team):
    make_team = (lambda: team) if isinstance(team, str) else team
    mode, env, op, following = _prepared(case, make_team())
    total = _traced(op, copy.deepcopy(env), 10**9)[1].seen  # the calls op makes
    assert total > 20
    points = sorted(set(np.random.default_rng(0).integers(1, total + 1, size=24).tolist()))
    outcomes = {"unchanged": 0, "reset": 0}
    for k in points:
        mode, env, op, following = _prepared(case, make_team())
        before = copy.deepcopy(env)
        out, hook = _traced(op, env, k)
        if not hook.fired:  # this run made fewer calls
            continue
        if out is not _MISSING:  # the interruption was swallowed on the way (a finaliser)
            assert _digest(out) == _digest(op(before)), k
            continue
        try:
            again = following(env)
        except RuntimeError as exc:
            assert re.search(RESET, str(exc)), (k, str(exc))
            outcomes["reset"] += 1
            _refuses_until_reset_then_plays_as_new(mode, env, make_team)
            continue
        # Nothing was done: the next call does what it would have done without the
        # interrupted one, and every drill plays on as in the copy taken before it.
        assert _digest(again) == _digest(following(before)), k
        rng = np.random.default_rng(k)
        state = rng.bit_generator.state
        played = [_digest(mode.round(env, rng)) for _ in range(6)]
        rng.bit_generator.state = state
        assert played == [_digest(mode.round(before, rng)) for _ in range(6)], k
        outcomes["unchanged"] += 1
    assert outcomes["reset"] > 0, outcomes  # the injections reached the drills' work


_RESETS_CUT_SHORT = """
import gc, signal, sys
import numpy as np
import soccer_drill
from soccer_drill.vector import HolderVectorEnv

class At:
    def __init__(self, k):
        self.k, self.seen = k, 0
    def __call__(self, frame, event, arg):
        if event == "call":
            self.seen += 1
            if self.seen == self.k:
                sys.settrace(None)
                handler = signal.getsignal(signal.SIGINT)
                if callable(handler):
                    handler(signal.SIGINT, frame)

makers = [(lambda: soccer_drill.HolderEnv(opponent="chasers"), 0),
          (lambda: HolderVectorEnv(2, opponent="chasers", drills_per_space=1), np.zeros(2, int))]
for make, action in makers:
    env = make()
    env.reset(seed=0)
    env.step(action)
    count = At(10**9)
    sys.settrace(count)
    env.reset(seed=1)
    sys.settrace(None)
    for k in range(1, count.seen + 1):
        hook = At(k)
        sys.settrace(hook)
        try:
            env.reset(seed=1)
        except KeyboardInterrupt:
            pass
        finally:
            sys.settrace(None)
        env.reset(seed=2)
        env.step(action)
    del env
    gc.collect()
print("survived")
"""


def test_a_ctrl_c_while_a_space_is_built_or_freed_never_crashes_the_process():
    """pymunk frees a space in a finaliser whose callbacks ignore exceptions: a Ctrl-C
    there left shapes in the freed space, and a later garbage collection aborted the
    process. A Ctrl-C at every function call of a reset, single and batched: the process
    goes on."""
    done = subprocess.run([sys.executable, "-c", _RESETS_CUT_SHORT], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0 and "survived" in done.stdout, done.stderr[-2000:]


@pytest.mark.parametrize("n", [1, N])
def test_the_error_after_an_interruption_says_a_reset_each_environment_takes(n):
    # before, every environment's error asked for a reset "of every drill: no
    # reset_mask", also the single drill's and ParallelVectorEnv's, which take no mask
    env = ParallelVectorEnv(n, opponent=Copies())
    env.reset(seed=0)
    _interrupted(lambda: env.step({a: np.zeros(n, dtype=int) for a in env.agents}), 3)
    with pytest.raises(RuntimeError) as refused:
        env.step({a: np.zeros(n, dtype=int) for a in env.agents})
    said = str(refused.value)
    assert "reset_mask" not in said
    assert ("call reset() to start it again" in said) == (n == 1)
    assert ("call reset() of every drill" in said) == (n > 1)
