"""The kit of a team's author: a team written once, in batched form, plays one drill as it
plays many; the example of ``docs/plugins.md`` runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

import soccer_drill
from soccer_drill.policies import HOLDER_POLICIES
from soccer_drill.vector import HolderVectorEnv

PAGE = Path(__file__).resolve().parents[1] / "docs" / "plugins.md"


def _example() -> dict:
    (block,) = [b for b in re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)
                if "class Hesitant" in b]
    namespace: dict = {}
    exec(block, namespace)
    return namespace


def test_the_pages_batched_example_runs_in_one_drill_and_in_many():
    example = _example()
    assert not hasattr(example["Hesitant"], "act")  # written once, in batched form
    one, many = example["one"], example["many"]
    obs, _ = one.reset(seed=0)
    assert obs in one.observation_space
    batch_obs, _ = many.reset(seed=0)
    np.testing.assert_array_equal(batch_obs[0], obs)  # drill 0 starts as the single drill
    _, _, term, trunc, _ = many.step(np.full(64, 2))
    assert term.shape == (64,)


def test_the_batched_team_plays_the_single_environments_episodes():
    """One drill of a batch plays what the single environment plays, decision by
    decision, the team's draws included."""
    hesitant = _example()["Hesitant"]
    policy = HOLDER_POLICIES["late_pass"]
    for seed in (1, 4):
        env = soccer_drill.HolderEnv(opponent=hesitant(wait=0.5))
        venv = HolderVectorEnv(num_envs=1, opponent=hesitant(wait=0.5))
        single, _ = env.reset(seed=seed)
        batched, _ = venv.reset(seed=seed)
        done = False
        while not done:
            np.testing.assert_array_equal(batched[0], single)
            action = policy(single, None)
            single, reward, term, trunc, info = env.step(action)
            batched, rewards, *_ = venv.step(np.array([action]))
            assert rewards[0] == reward
            done = term or trunc


def test_the_team_draws_from_each_drills_own_stream():
    """A drill's episode does not depend on how many drills run beside it."""
    hesitant = _example()["Hesitant"]
    lone = HolderVectorEnv(num_envs=1, opponent=hesitant(), drills_per_space=1)
    crowd = HolderVectorEnv(num_envs=5, opponent=hesitant(), drills_per_space=1)
    first, _ = lone.reset(seed=[7])
    others, _ = crowd.reset(seed=[3, 7, 9, 11, 13])
    np.testing.assert_array_equal(first[0], others[1])
    for _ in range(6):
        first, *_ = lone.step(np.array([2]))
        others, *_ = crowd.step(np.full(5, 2))
        np.testing.assert_array_equal(first[0], others[1])


def test_every_name_the_kit_lists_is_importable_from_the_kit():
    """``docs/plugins.md``: everything a team needs from the drill is in the kit."""
    kit = soccer_drill.teams

    table = kit.__doc__.split("| need | names |")[1].split("\n\n")[0]
    listed = []
    for row in table.splitlines()[2:]:
        names = row.split("|")[2]
        while re.search(r"\([^()]*\)", names):  # what a parenthesis says is not a name of the kit
            names = re.sub(r"\([^()]*\)", "", names)
        listed += re.findall(r"``([A-Za-z_]\w*)``", names)
    assert {"Command", "Skill", "DrillView", "TeamError", "register", "BatchCommands"} <= set(listed)
    missing = [name for name in listed if not hasattr(kit, name)]
    assert missing == [], f"the kit lists {missing} but does not export them"
    # Declared once: the kit's own names in its __all__, soccer_drill's in soccer_drill's.
    assert all(name in kit.__all__ or name in soccer_drill.__all__ for name in listed)
