"""One environment used from two threads at once fails clearly; one per thread is fine."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
import traceback

import numpy as np
import pytest

import soccer_drill

# Run in a child process: without the guard, two threads inside pymunk's Space.step
# crash the interpreter (a segmentation fault) or hang it.
_TWO_THREADS_ONE_ENV = textwrap.dedent(
    """
    import sys, threading
    import numpy as np
    import soccer_drill

    sys.setswitchinterval(1e-6)  # switch threads as often as possible
    kind = sys.argv[1]
    env = {"holder": lambda: soccer_drill.HolderEnv(),
           "aec": lambda: soccer_drill.env(opponent="chasers"),
           "parallel": lambda: soccer_drill.parallel_env(opponent="chasers")}[kind]()
    env.reset(seed=0)
    clashes, others = [], []

    def one_step():
        if kind == "holder":
            _, _, term, trunc, _ = env.step(0)
            return term or trunc
        if kind == "aec":
            agent = env.agent_selection
            done = env.terminations[agent] or env.truncations[agent]
            env.step(None if done else 0)
            return not env.agents
        env.step({a: 0 for a in env.agents})
        return not env.agents

    start = threading.Barrier(2)

    def run():
        start.wait()  # both threads in the loop together, even on a loaded machine
        for _ in range(30000):
            if clashes:  # seen (by either thread): enough
                break
            try:
                if one_step():
                    env.reset()
            except RuntimeError as exc:
                if "from two threads at once" in str(exc):
                    clashes.append(str(exc))
                else:  # e.g. the other thread ended the episode first
                    others.append(type(exc).__name__)
                    try:
                        env.reset()
                    except RuntimeError as again:
                        if "from two threads at once" in str(again):
                            clashes.append(str(again))
            except (ValueError, KeyError) as exc:  # an action for an agent already gone
                others.append(type(exc).__name__)

    threads = [threading.Thread(target=run, name=f"worker-{k}") for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    print(len(clashes))
    print(clashes[0] if clashes else "")
    """
)


@pytest.mark.parametrize("kind", ["holder", "aec", "parallel"])
def test_one_environment_stepped_from_two_threads_raises_a_clear_error(kind):
    try:
        done = subprocess.run(
            [sys.executable, "-c", _TWO_THREADS_ONE_ENV, kind],
            capture_output=True, text=True, timeout=120,
        )
    except subprocess.TimeoutExpired:
        pytest.fail("two threads on one environment hung the process")
    assert done.returncode == 0, f"the process died ({done.returncode}): {done.stderr[-2000:]}"
    count, message = done.stdout.strip().splitlines()
    assert int(count) > 0, "concurrent use was never detected"
    assert "called from thread 'worker-" in message
    assert "give each thread its own environment" in message


def _holder_episodes(seed: int, episodes: int = 6) -> list:
    env = soccer_drill.HolderEnv(opponent="chasers")
    rng = np.random.default_rng(seed)
    out = []
    for e in range(episodes):
        obs, _ = env.reset(seed=seed * 100 + e)
        done = False
        while not done:
            obs, reward, term, trunc, info = env.step(int(rng.integers(3)))
            out.append((obs.tobytes(), reward, info["duration"]))
            done = term or trunc
    return out


def test_separate_environments_in_separate_threads_are_fine():
    expected = {seed: _holder_episodes(seed) for seed in range(4)}
    results: dict[int, list] = {}
    errors: list[BaseException] = []

    def run(seed: int) -> None:
        try:
            results[seed] = _holder_episodes(seed)
        except BaseException:  # reported below, with where it was raised
            errors.append(f"seed {seed}: {traceback.format_exc()}")

    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=run, args=(seed,)) for seed in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(switch)
    assert not errors, "\n".join(errors)
    for seed, steps in expected.items():
        got = results[seed]
        first = next((i for i, (a, b) in enumerate(zip(got, steps, strict=False))
                      if a != b), None)
        assert got == steps, (
            f"seed {seed}: {len(got)} steps against {len(steps)} alone; first differing step "
            f"{first}: {got[first] if first is not None else None} against "
            f"{steps[first] if first is not None else None}"
        )


def test_an_environment_can_move_to_another_thread():
    """The guard is a lock, not an owner: a thread may take over an idle environment."""
    env = soccer_drill.parallel_env(opponent="chasers")
    env.reset(seed=1)
    out: list = []
    worker = threading.Thread(target=lambda: out.append(env.step({a: 3 for a in env.agents})))
    worker.start()
    worker.join()
    assert len(out) == 1
    env.step({a: 3 for a in env.agents})  # back on the main thread


# Each thread builds its first team at once, in a fresh interpreter: the registry's first
# reading of the entry points and the team's first import happen in both threads together.
_TWO_THREADS_FIRST_TEAM = textwrap.dedent(
    """
    import sys, threading
    sys.setswitchinterval(1e-6)
    import soccer_drill

    start = threading.Barrier(2)
    built, errors = [], []

    def run():
        start.wait()
        try:
            built.append(type(soccer_drill.make_team("chasers")).__name__)
        except BaseException as exc:
            errors.append(repr(exc)[:300])

    threads = [threading.Thread(target=run) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    print(built, errors)
    """
)


@pytest.mark.parametrize("run", range(3))
def test_two_threads_building_their_first_team_at_once_both_get_it(run):
    done = subprocess.run([sys.executable, "-c", _TWO_THREADS_FIRST_TEAM],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "['Chasers', 'Chasers'] []"


_INSIDE, _GO = threading.Event(), threading.Event()


class _Waiting:
    """A team whose ``act`` waits, in the thread stepping, until it is let go (its
    copies, one per drill, share the two events)."""

    inside, go = _INSIDE, _GO

    def reset(self, view, rng):
        self.players = view.players

    def act(self, view):
        self.inside.set()
        self.go.wait(10)
        return {p: soccer_drill.Command(soccer_drill.Skill.INTERCEPT) for p in self.players}


@pytest.mark.parametrize("kind", ["holder", "parallel"])
def test_a_batched_environment_refuses_a_second_thread_while_one_steps_it(kind):
    """Before, the batched environments took no lock: a second thread's reset() ran in the
    middle of the first thread's step, which then finished its cycle on drills just reset."""
    from soccer_drill.vector import HolderVectorEnv
    from soccer_drill.vector.agents import ParallelVectorEnv

    team = _Waiting()
    if kind == "holder":
        env = HolderVectorEnv(num_envs=2, opponent=team)
        calls = {"reset": lambda: env.reset(seed=1), "step": lambda: env.step(np.zeros(2, int)),
                 "send": lambda: env.send(np.zeros(2, int)), "recv": env.recv,
                 "async_reset": lambda: env.async_reset(seed=1)}
        step = calls["step"]
    else:
        env = ParallelVectorEnv(num_envs=2, opponent=team)
        step = lambda: env.step({a: np.zeros(2, int) for a in env.agents})  # noqa: E731
        calls = {"reset": lambda: env.reset(seed=1), "step": step}
    env.reset(seed=0)
    team.go.set()
    step()
    before = env.state() if kind == "parallel" else env.loop.core.batch.pos.copy()
    team.go.clear()
    team.inside.clear()
    stepping = threading.Thread(target=step)
    stepping.start()
    assert team.inside.wait(10)
    try:
        for name, call in calls.items():
            with pytest.raises(RuntimeError, match=rf"\.{name}\(\) called from thread .* two "
                                                   "threads at once"):
                call()
    finally:
        team.go.set()
        stepping.join(10)
    after = env.state() if kind == "parallel" else env.loop.core.batch.pos
    assert not np.array_equal(before, after)  # the first thread's step ran on
    step()  # and the environment is usable
