"""docs/integrations.md tells the truth: every recipe runs as written and prints the output
shown under it, line for line (the recipes are seeded; only rates measured in the run may
differ), and what the page says about clients that do not fit holds.

Recipes are the page's ``python`` blocks whose first line is ``# recipe: NAME``, each
followed by an ``Output`` block. Those that need torch (or moviepy) are marked
``integrations``: they run with ``pip install -e ".[integrations]"`` and
``pytest -m integrations``, and are deselected by default (``pyproject.toml``).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import soccer_drill

PAGE = Path(__file__).resolve().parent.parent / "docs" / "integrations.md"
TEXT = PAGE.read_text(encoding="utf-8")
FENCE = re.compile(r"^```python\n# recipe: (\w+)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
OUTPUT = re.compile(r"\s*Output[^\n]*:\n\n```\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
RECIPES = {m.group(1): m.group(2) for m in FENCE.finditer(TEXT)}
OUTPUTS = {m.group(1): o.group(1) if (o := OUTPUT.match(TEXT, m.end())) else None
           for m in FENCE.finditer(TEXT)}
# Rates measured in the run: the only numbers that may differ from the page.
RATE = re.compile(r"[\d.]+(?= (?:turns per second|cycles per second|decisions/s))")
# TorchRL's logger writes to the stdout it found when first imported: not the recipe's.
LOG = re.compile(r"\[torchrl\]\[INFO\]")
NEEDS_TORCH_OR_MOVIEPY = {
    "sb3_holder", "sb3_batched", "maskable_ppo_aec", "maskable_ppo_holder", "supersuit_sb3", "torchrl",
    "tianshou", "rllib_holder", "rllib_roles", "video",
}
# Recipes whose run follows Python's string hashes (RLlib keeps the agents of a step in a
# set): the page gives their output under PYTHONHASHSEED=0, so they run in a process of
# their own with it.
NEEDS_FIXED_HASH_SEED = {"rllib_roles"}


def _lines(text: str) -> list[str]:
    return [RATE.sub("<rate>", line.rstrip()) for line in text.strip().splitlines()
            if not LOG.search(line)]


def test_every_recipe_has_its_output_and_a_tier():
    assert RECIPES and all(OUTPUTS[name] for name in RECIPES), [n for n in RECIPES if not OUTPUTS[n]]
    assert NEEDS_TORCH_OR_MOVIEPY | NEEDS_FIXED_HASH_SEED <= set(RECIPES)
    for name in NEEDS_FIXED_HASH_SEED:  # the page says how its output was made
        assert f"PYTHONHASHSEED=0 python {name}.py" in TEXT, name


def _params():
    for name in RECIPES:
        marks = [pytest.mark.integrations] if name in NEEDS_TORCH_OR_MOVIEPY else []
        yield pytest.param(name, marks=marks, id=name)


@pytest.mark.parametrize("name", list(_params()))
def test_recipe_runs_and_prints_what_the_page_says(name, tmp_path, monkeypatch, team_registry):
    monkeypatch.chdir(tmp_path)
    if name in NEEDS_FIXED_HASH_SEED:
        (tmp_path / f"{name}.py").write_text(RECIPES[name], encoding="utf-8")
        run = subprocess.run([sys.executable, f"{name}.py"], capture_output=True, text=True,
                             env={**os.environ, "PYTHONHASHSEED": "0"}, check=False)
        assert run.returncode == 0, run.stderr[-4000:]
        printed = run.stdout
    else:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(RECIPES[name], f"{PAGE.name}:{name}", "exec"), {"__name__": "__recipe__"})
        printed = out.getvalue()
    assert _lines(printed) == _lines(OUTPUTS[name]), printed
    if name == "video":  # each video lasts as long as its episode (one frame per 0.1 s cycle)
        seconds = dict(re.findall(r"^(\w+)-episode-0\.mp4: ([\d.]+) s", printed, re.MULTILINE))
        cycles = {which.lower(): n for which, n in re.findall(r"(\w+) episode: (\d+) cycles", printed)}
        for which in ("holder", "aec"):  # moviepy may drop the last frame (see test_video.py)
            assert abs(float(seconds[which]) - (int(cycles[which]) + 1) / 10) <= 0.1 + 1e-6


def test_black_death_does_not_fit_the_drill_as_the_page_says():
    """SuperSuit's black_death_v3 needs Box observations and never reports an episode end
    that sets termination or truncation alone: the paragraph of the page."""
    import supersuit as ss

    with pytest.raises(AssertionError, match="must be Box spaces"):
        ss.black_death_v3(soccer_drill.parallel_env()).reset(seed=0)
    env = ss.black_death_v3(soccer_drill.parallel_env(obs_format="flat"))
    _, infos = env.reset(seed=0)
    drill = env.unwrapped
    while drill.agents:
        actions = {a: int(np.flatnonzero(infos[a]["action_mask"])[0]) for a in env.agents}
        _, _, terms, truncs, infos = env.step(actions)
    assert drill.outcome is not None  # the drill's episode ended ...
    assert env.agents and not any(terms.values()) and not any(truncs.values())  # ... unreported
    with pytest.raises(RuntimeError, match="step\\(\\) called after the episode ended"):
        env.step(dict.fromkeys(env.agents, 0))


@pytest.mark.integrations
def test_tianshou_reads_the_mask_from_the_dict_observation_only():
    from tianshou.env import PettingZooEnv

    obs, _ = PettingZooEnv(soccer_drill.env(opponent="chasers")).reset(seed=0)
    assert obs["mask"] in ([True, True, True, False, False], [False, False, False, True, True])
    flat, _ = PettingZooEnv(soccer_drill.env(opponent="chasers", obs_format="flat")).reset(seed=0)
    assert flat["mask"] == [True] * 5  # the page's reason to keep the default
