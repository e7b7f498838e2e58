"""What a team raises or returns is reported as the team's error, within its time bound:
``SystemExit`` and a ``KeyboardInterrupt`` it raises, a failing factory, hostile objects
that are slow to read, huge mappings and messages. A Ctrl-C still stops the program."""

from __future__ import annotations

import numbers
import os
import signal
import sys
import threading
import time

import numpy as np
import pytest

import soccer_drill
from soccer_drill import TeamError
from soccer_drill.commands import Command, Skill
from soccer_drill.rules.arrays import CYCLE
from soccer_drill.teams import BatchCommands
from soccer_drill.teams.driver import check_commands

UNIX_TIMER = hasattr(signal, "setitimer") and hasattr(signal, "SIGPROF")
KINDS = ["holder", "aec", "parallel"]
SPIN = 3.0  # CPU seconds a hostile object spins for: far past the tests' 0.2 s bound


def _spin(seconds: float = SPIN) -> None:
    end = time.thread_time() + seconds
    while time.thread_time() < end:
        pass


def _make(kind: str, team, **kwargs):
    if kind == "holder":
        return soccer_drill.HolderEnv(opponent=team, **kwargs)
    make = soccer_drill.env if kind == "aec" else soccer_drill.parallel_env
    return make(opponent=team, **kwargs)


def _cycle(env, kind: str) -> None:
    """One cycle (a holder decision) with legal actions."""
    if kind == "holder":
        env.step(0)
    elif kind == "parallel":
        env.step({a: int(np.flatnonzero(env.action_mask(a))[0]) for a in env.agents})
    else:
        for _ in env.possible_agents:
            env.step(int(np.flatnonzero(env.action_mask())[0]))


class _Acting:
    """A team whose ``act`` does ``behave()`` at cycle 1 (and plays INTERCEPT otherwise)."""

    def __init__(self, behave):
        self.behave = behave

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        if view.cycle == 1:
            return self.behave(self.players)
        return dict.fromkeys(self.players, Command(Skill.INTERCEPT))


def _exits(players):
    sys.exit(3)


def _raises_keyboard_interrupt(players):
    raise KeyboardInterrupt


def _waiting():
    yield


def _throws_keyboard_interrupt(players):
    waiting = _waiting()
    next(waiting)
    waiting.throw(KeyboardInterrupt)  # raised at the generator's yield, not at a raise


def _throws_keyboard_interrupt_into_a_new_generator(players):
    _waiting().throw(KeyboardInterrupt)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(("behave", "message"), [
    (_exits, r"team '_Acting' raised in act\(\) at cycle 1: it called sys\.exit\(3\) \(SystemExit\); "
             r"a team must not end the program"),
    *((raising, r"team '_Acting' raised in act\(\) at cycle 1: it raised KeyboardInterrupt "
                r"itself \(not a Ctrl-C")
      for raising in (_raises_keyboard_interrupt, _throws_keyboard_interrupt,
                      _throws_keyboard_interrupt_into_a_new_generator)),
])
def test_a_teams_system_exit_and_keyboard_interrupt_are_its_errors(kind, behave, message):
    env = _make(kind, _Acting(behave))
    env.reset(seed=0)
    with pytest.raises(TeamError, match=message) as err:
        for _ in range(3):
            _cycle(env, kind)
    assert isinstance(err.value.__cause__, SystemExit | KeyboardInterrupt)
    env.reset(seed=1)  # the environment stays usable


class _ExitsInReset(_Acting):
    def reset(self, view, rng):
        sys.exit("no")


def test_sys_exit_in_a_teams_reset_is_its_error():
    env = soccer_drill.HolderEnv(opponent=_ExitsInReset(None))
    with pytest.raises(TeamError, match=r"raised in reset\(\): it called sys\.exit\('no'\)"):
        env.reset(seed=0)


def _interrupt_soon(signum: int = signal.SIGINT) -> threading.Timer:
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signum))
    timer.start()
    return timer


def _busy_until_interrupted(players):
    _spin(20.0)
    return dict.fromkeys(players, Command(Skill.INTERCEPT))


def _catches_and_reraises(players):
    try:
        _spin(20.0)
    except KeyboardInterrupt:
        raise
    return dict.fromkeys(players, Command(Skill.INTERCEPT))


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signals")
@pytest.mark.parametrize("behave", [_busy_until_interrupted, _catches_and_reraises])
@pytest.mark.parametrize("team_timeout", [None, 60.0])
def test_ctrl_c_while_a_team_computes_still_stops_the_program(behave, team_timeout):
    env = soccer_drill.HolderEnv(opponent=_Acting(behave), team_timeout=team_timeout)
    env.reset(seed=0)
    timer = _interrupt_soon()
    try:
        with pytest.raises(KeyboardInterrupt):
            for _ in range(3):
                env.step(0)
    finally:
        timer.cancel()


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="SIGUSR1 (Unix)")
def test_sys_exit_from_the_programs_signal_handler_is_not_the_teams():
    def stop(signum, frame):
        sys.exit(7)

    previous = signal.signal(signal.SIGUSR1, stop)
    try:
        env = soccer_drill.HolderEnv(opponent=_Acting(_busy_until_interrupted), team_timeout=None)
        env.reset(seed=0)
        timer = _interrupt_soon(signal.SIGUSR1)
        try:
            with pytest.raises(SystemExit) as err:
                for _ in range(3):
                    env.step(0)
        finally:
            timer.cancel()
        assert err.value.code == 7
    finally:
        signal.signal(signal.SIGUSR1, previous)


# ---------------------------------------------------------------- factories
class _DividesByZero:
    def __init__(self):
        1 / 0  # noqa: B018


class _TypeErrorInside:
    def __init__(self, speed: float = 1.0):
        self.speed = speed + "fast"


class _ExitsWhenBuilt:
    def __init__(self):
        sys.exit(2)


@pytest.mark.parametrize(("factory", "params", "error", "message"), [
    (_DividesByZero, {}, TeamError,
     r"team 'factory' failed while being built with parameters \{\}: ZeroDivisionError\("),
    (_TypeErrorInside, {}, TeamError,
     r"team 'factory' failed while being built with parameters \{\}: TypeError\("),
    (_ExitsWhenBuilt, {}, TeamError,
     r"team 'factory' failed while being built .*it called sys\.exit\(2\) \(SystemExit\)"),
    (_TypeErrorInside, {"colour": "red"}, ValueError,
     r"bad parameters \{'colour': 'red'\} for team 'factory': got an unexpected keyword "
     r"argument 'colour'; it takes \(speed: .*= 1\.0\)"),
])
def test_a_failing_factory_is_named_with_what_happened(team_registry, factory, params, error,
                                                       message):
    soccer_drill.register("factory", factory)
    with pytest.raises(error, match=message) as err:
        soccer_drill.HolderEnv(opponent="factory", opponent_params=params)
    if error is TeamError:
        assert err.value.__cause__ is not None
    assert "bad parameters {}" not in str(err.value)


# ------------------------------------------------- the bound covers the checks
class _SpinningMapping(dict):
    """A dict (not one to the fast path: a subclass) whose ``__iter__`` spins."""

    def __iter__(self):
        _spin()
        return super().__iter__()


class _SpinningSpeed:
    def __float__(self):
        _spin()
        return 0.5


numbers.Real.register(_SpinningSpeed)


class _SpinningRepr(Exception):
    def __repr__(self):
        _spin()
        return "slow"


def _returns_spinning_mapping(players):
    return _SpinningMapping(dict.fromkeys(players, Command(Skill.INTERCEPT)))


def _returns_spinning_speed(players):
    return dict.fromkeys(players, Command(Skill.INTERCEPT, None, _SpinningSpeed()))


def _raises_spinning_repr(players):
    raise _SpinningRepr


@pytest.mark.skipif(not UNIX_TIMER, reason="interrupting a call needs setitimer (Unix)")
@pytest.mark.parametrize("behave", [_returns_spinning_mapping, _returns_spinning_speed,
                                    _raises_spinning_repr])
def test_reading_what_a_team_returned_or_raised_is_inside_its_time_bound(behave):
    env = soccer_drill.HolderEnv(opponent=_Acting(behave), team_timeout=0.2)
    env.reset(seed=0)
    start = time.thread_time()
    with pytest.raises(TeamError, match=r"team '_Acting' exceeded its time bound of 0\.2 s of "
                       r"CPU time in act\(\) at cycle 1"):
        for _ in range(3):
            env.step(0)
    assert time.thread_time() - start < SPIN  # stopped, not spun to the end


def _returns_two_million_keys(players):
    commands = dict.fromkeys(range(2_000_000), Command(Skill.INTERCEPT))
    commands.update(dict.fromkeys(players, Command(Skill.INTERCEPT)))
    return commands


def _raises_a_huge_message(players):
    raise ValueError("x" * 17_000_000)


def _returns_a_huge_command(players):
    return dict.fromkeys(players, ["move"] * 1_000_000)


@pytest.mark.parametrize(("behave", "message"), [
    (_returns_two_million_keys, r"must return a mapping with exactly the players it drives "
                                r"\['defender_0', 'defender_1'\], got 2,000,002 keys, the first 6"),
    (_raises_a_huge_message, r"raised in act\(\) at cycle 1: ValueError\('xxx"),
    (_returns_a_huge_command, r"player 'defender_0', cycle 1: expected a Command, got \['move'"),
])
def test_huge_answers_give_short_messages(behave, message):
    env = soccer_drill.HolderEnv(opponent=_Acting(behave))
    env.reset(seed=0)
    with pytest.raises(TeamError, match=message) as err:
        for _ in range(3):
            env.step(0)
    assert len(str(err.value)) < 1000


def test_check_commands_checks_every_row_then_writes_what_it_checked():
    players = ("defender_0", "defender_1")
    cycle, drills, cycles = np.zeros(3, CYCLE), np.array([0, 2]), np.array([5, 9, 6])
    moving = BatchCommands(np.full((2, 2), int(Skill.MOVE_TO), dtype=np.int32),
                           np.full((2, 2, 2), 1.5, dtype=np.float32), np.ones((2, 2)))
    check_commands(moving, cycle, drills, cycles, "t", players)
    assert cycle["skill"][:, 2:].tolist() == [[8, 8], [0, 0], [8, 8]]  # drill 1 not acting
    assert cycle["target"][2, 3].tolist() == [1.5, 1.5] and cycle["skill"][:, :2].max() == 0
    too_fast = BatchCommands(np.full((2, 2), int(Skill.MARK)), np.zeros((2, 2, 2)),
                             np.array([[1.0, 1.0], [1.0, 2.0]]))
    with pytest.raises(TeamError, match=r"^team 't', drill 2, player 'defender_1', cycle 6: "
                                        r"speed must be in \(0, 1\], got 2\.0$"):
        check_commands(too_fast, cycle, drills, cycles, "t", players)
    assert cycle["skill"][:, 2:].tolist() == [[8, 8], [0, 0], [8, 8]]  # nothing written
    with pytest.raises(TeamError, match=r"^team 't', player 'defender_1', cycle 6: speed"):
        check_commands(too_fast, cycle, drills, cycles, "t", players, named=False)
    with pytest.raises(TeamError, match=r"act\(\) must return BatchCommands\(skill, target, "
                                        r"speed\), got NoneType"):
        check_commands(None, cycle, drills, cycles, "t", players)


def _returns_none(players):
    return None


def test_a_team_of_one_drill_returning_no_mapping_is_told_so():
    env = soccer_drill.HolderEnv(opponent=_Acting(_returns_none))
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"^team '_Acting' must return a mapping with exactly the "
                                        r"players it drives .* got NoneType at cycle 1$"):
        for _ in range(3):
            env.step(0)


# ------------------------------------------------------------- re-entrancy
class _StepsItsEnvironment(_Acting):
    env = None

    def __init__(self):
        super().__init__(self._step_the_env)

    def _step_the_env(self, players):
        self.env.step(0)


@pytest.mark.parametrize("kind", KINDS)
def test_a_team_stepping_its_own_environment_is_told_so_not_about_threads(kind):
    team = _StepsItsEnvironment()
    env = team.env = _make(kind, team)
    env.reset(seed=0)
    with pytest.raises(TeamError, match=r"raised in act\(\) at cycle 1: RuntimeError\(.*"
                       r"step\(\) called from inside its own step\(\) or reset\(\) "
                       r"\(re-entrant") as err:
        for _ in range(3):
            _cycle(env, kind)
    assert "another thread" not in str(err.value)


def _raises(players):
    raise ArithmeticError("a team's bug")


def test_after_a_team_error_a_refused_aec_step_changes_nothing():
    # before, the refused step had already written the action's report into infos
    env = _make("aec", _Acting(_raises))
    env.reset(seed=0)
    _cycle(env, "aec")  # cycle 0
    with pytest.raises(TeamError, match="a team's bug"):
        _cycle(env, "aec")  # the team fails when cycle 1 is played
    agent = env.agent_selection
    infos, rewards = {a: dict(i) for a, i in env.infos.items()}, dict(env.rewards)
    masked = int(np.flatnonzero(env.action_mask() == 0)[0])  # would be replaced and reported
    with pytest.raises(TeamError, match="call reset"):
        env.step(masked)
    assert env.infos == infos and env.rewards == rewards and env.agent_selection == agent
    env.reset(seed=0)
    _cycle(env, "aec")


class _Locked:
    """A team holding a lock: neither copy.deepcopy nor pickle can copy it."""

    def __init__(self):
        self.lock = threading.Lock()

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        return dict.fromkeys(self.players, Command(Skill.INTERCEPT))


def test_an_environment_whose_team_cannot_be_copied_names_the_team(team_registry):
    # before, copy.deepcopy of the environment raised copy's bare TypeError about the lock
    import copy

    team_registry.register("locked", _Locked)
    env = soccer_drill.HolderEnv(opponent="locked")
    env.reset(seed=0)
    with pytest.raises(TypeError, match=r"team 'locked' cannot be copied, so neither can the "
                                        r"environment it plays in: TypeError\("):
        copy.deepcopy(env)
    env.step(0)  # the environment itself plays on


def test_pickling_an_environment_whose_team_cannot_be_pickled_names_the_team():
    # before, pickle's bare "cannot pickle '_thread.lock' object"
    import pickle

    from soccer_drill.vector import HolderVectorEnv

    for env in (soccer_drill.HolderEnv(opponent=_Locked()), HolderVectorEnv(1, opponent=_Locked())):
        env.reset(seed=0)
        with pytest.raises(TypeError, match=r"team '_Locked' cannot be pickled, so neither "
                                            r"can the environment it plays in"):
            pickle.dumps(env)
