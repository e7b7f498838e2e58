"""``soccer-drill-play``: a window under SDL's dummy video driver, keys pressed by script."""

from __future__ import annotations

import itertools

import pygame
import pytest

import soccer_drill
from soccer_drill.rendering import play


class _NoWait:
    """A clock that does not sleep: the window's frames at full speed."""

    def tick(self, fps: float = 0) -> int:
        return 0


@pytest.fixture
def window(monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    monkeypatch.setattr(pygame.time, "Clock", _NoWait)
    flips = []
    flip = pygame.display.flip
    monkeypatch.setattr(pygame.display, "flip", lambda: (flips.append(1), flip())[1])
    yield flips
    pygame.display.quit()


def _played(team: str, action: int, seeds) -> list[tuple[str, float]]:
    """The outcomes and rewards of always taking ``action``, without a window."""
    env = soccer_drill.HolderEnv(opponent=team)
    results = []
    for seed in seeds:
        env.reset(seed=seed)
        done = False
        while not done:
            _, reward, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        results.append((info["outcome"], reward))
    return results


def test_a_scripted_session_keeps_the_score_over_episodes(window):
    lines = []
    keys = itertools.cycle([pygame.K_d, pygame.K_SPACE])  # dribble; then the next episode
    score = play.play("goal_guards", episodes=2, seed=5, keys=keys, out=lines.append)
    expected = _played("goal_guards", 2, [5, 6])
    assert score.episodes == 2
    assert score.won == sum(outcome == "success" for outcome, _ in expected)
    assert score.reward == pytest.approx(sum(reward for _, reward in expected))
    assert [line.split(":")[1].split(",")[0].strip() for line in lines] == [
        outcome for outcome, _ in expected]
    assert window  # frames were shown in the window


def test_each_key_takes_its_decision(window):
    for key, action in ((pygame.K_h, 0), (pygame.K_2, 1), (pygame.K_3, 2)):
        score = play.play("chasers", episodes=1, seed=3, keys=itertools.repeat(key),
                          out=lambda _: None)
        (outcome, reward), = _played("chasers", action, [3])
        assert (score.won, score.reward) == (outcome == "success", pytest.approx(reward))


def test_escape_stops_the_session(window):
    score = play.play("chasers", keys=[pygame.K_h, pygame.K_ESCAPE], out=lambda _: None)
    assert score.episodes == 0


def test_an_unknown_team_is_refused_by_the_command(capsys):
    with pytest.raises(SystemExit) as exc:
        play.main(["--team", "no_such_team"])
    assert exc.value.code == 2
    assert "no_such_team" in capsys.readouterr().err
