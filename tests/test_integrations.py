"""docs/integrations.md tells the truth: every recipe runs as written and prints what it says.

Recipes are the page's ``python`` blocks whose first line is ``# recipe: NAME``. Those
that need torch (or moviepy) are marked ``integrations``: they run with
``pip install -e ".[integrations]"`` and ``pytest -m integrations``, and are deselected by
default (``pyproject.toml``).
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

import soccer_drill.teams as teams

PAGE = Path(__file__).resolve().parent.parent / "docs" / "integrations.md"
FENCE = re.compile(r"^```python\n# recipe: (\w+)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
RECIPES = {m.group(1): m.group(2) for m in FENCE.finditer(PAGE.read_text(encoding="utf-8"))}

# What each recipe must print (a regular expression searched in its output).
EXPECTED = {
    "pettingzoo_tests": r"Passed API test[\s\S]*cycles per second",
    "gymnasium_vector": r"sync: obs \(4, 9\) float32, \d+ episodes[\s\S]*async: obs \(4, 9\) float32, [1-9]\d* episodes",
    "batched_vector": r"buffer \(32, 64, 9\), [1-9]\d* episodes, mean return [-+][\d.]+[\s\S]*agents \['attacker_0', 'attacker_1'\]: obs \(64, 9\), masks \(64, 5\)",
    "wrappers": r"20 episodes, [\d.]+ decisions each[\s\S]*aec_to_parallel: [1-9]\d* identical cycles; parallel_to_aec agents \['attacker_0', 'attacker_1', 'defender_0', 'defender_1'\]",
    "supersuit": r"opponent: 4 agent slots, obs \(4, 9\), [1-9]\d* agent-episodes ended, [1-9]\d* masked actions replaced[\s\S]*self-play: 8 agent slots, obs \(8, 10\), [1-9]\d* agent-episodes ended, [1-9]\d* masked[\s\S]*refused: ",
    "sb3_holder": r"PPO: mean reward over 50 episodes [-+][\d.]+[\s\S]*DQN: mean reward[\s\S]*random holder: mean reward",
    "maskable_ppo_aec": r"MaskablePPO: 20 episodes, mean attacker reward [-+][\d.]+, no masked action",
    "supersuit_sb3": r"opponent chasers: PPO trained \d+ agent steps on 4 agent slots[\s\S]*self-play: PPO trained \d+ agent steps on 8 agent slots",
    "torchrl": r"groups \['attacker'\], rollout \d+ cycles, state \(\d+, 29\)[\s\S]*groups \['attacker', 'defender'\]",
    "tianshou": r"opponent chasers: 10 episodes[\s\S]*self-play: 10 episodes",
    "video": r"(\d+) frames for (\d+) cycles",
}
NEEDS_TORCH_OR_MOVIEPY = {"sb3_holder", "maskable_ppo_aec", "supersuit_sb3", "torchrl", "tianshou",
                          "video"}


def test_every_recipe_is_checked():
    assert set(RECIPES) == set(EXPECTED)


def _params():
    for name in EXPECTED:
        marks = [pytest.mark.integrations] if name in NEEDS_TORCH_OR_MOVIEPY else []
        yield pytest.param(name, marks=marks, id=name)


@pytest.mark.parametrize("name", list(_params()))
def test_recipe_runs_and_prints_what_the_page_says(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    teams.team_ids()  # discover first, so that the copy below holds every installed team
    monkeypatch.setattr(teams, "_registry", dict(teams._registry))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(RECIPES[name], f"{PAGE.name}:{name}", "exec"), {"__name__": "__recipe__"})
    printed = out.getvalue()
    match = re.search(EXPECTED[name], printed)
    assert match, printed
    if name == "video":  # one frame per cycle, plus the reset's
        frames, cycles = map(int, match.groups())
        assert frames == cycles + 1
