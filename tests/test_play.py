"""``soccer-drill-play``: a window under SDL's dummy video driver, keys pressed by script."""

from __future__ import annotations

import itertools

import numpy as np
import pygame
import pytest

import soccer_drill
from soccer_drill import scenarios
from soccer_drill.commands import attacker_action_names
from soccer_drill.rendering import play
from soccer_drill.rules.features import holder_feature_indices


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


# ------------------------------------------------------------ --control attacker
def _recording(monkeypatch, player: str) -> list[tuple[tuple[int, ...], int, dict[str, int]]]:
    """Each step of the PettingZoo drill: ``player``'s action mask and the holder before
    it, and the actions it was given."""
    steps = []
    step = soccer_drill.parallel_env.step

    def recorded(env, actions):
        steps.append((tuple(env.action_mask(player).tolist()), env.drill_state.holder,
                      dict(actions)))
        return step(env, actions)

    monkeypatch.setattr(soccer_drill.parallel_env, "step", recorded)
    return steps


_ACTION_OF = {pygame.K_h: 0, pygame.K_p: 1, pygame.K_d: 2, pygame.K_g: 3, pygame.K_b: 4,
              pygame.K_1: 0, pygame.K_5: 4}


def _attacker(team="goal_guards", player=None, attack=None, decision_cycles=4):
    return play.PlaySetup(team=team, control="attacker", player=player, attack=attack,
                          decision_cycles=decision_cycles)


def test_the_attacker_takes_the_legal_keys_and_the_score_counts_the_episode(window,
                                                                           monkeypatch):
    steps = _recording(monkeypatch, "attacker_1")
    script = [pygame.K_g, pygame.K_d, pygame.K_p, pygame.K_b, pygame.K_h, pygame.K_1,
              pygame.K_5, pygame.K_d] * 40
    lines = []
    score = play.play(_attacker(player="attacker_1", attack="keepaway", decision_cycles=1),
                      episodes=1, seed=4, keys=script, out=lines.append)
    assert score.episodes == 1 and steps
    # One decision a cycle: each step takes the next key whose action is legal then;
    # the keys of masked actions before it were refused, each said once.
    keys, refused = iter(script), 0
    for mask, _, actions in steps:
        action = _ACTION_OF[next(keys)]
        while not mask[action]:
            refused += 1
            action = _ACTION_OF[next(keys)]
        assert actions["attacker_1"] == action
    assert {mask for mask, _, _ in steps} == {(1, 1, 1, 0, 0), (0, 0, 0, 1, 1)}
    assert refused > 0
    assert sum(line.startswith("refused: ") for line in lines) == refused
    assert all("legal: " in line for line in lines if line.startswith("refused: "))
    # The episode counted is the one these actions give without a window.
    monkeypatch.undo()
    env = soccer_drill.parallel_env(opponent="goal_guards")
    env.reset(seed=4)
    for _, _, actions in steps:
        _, rewards, _, _, infos = env.step(actions)
    assert not env.agents
    assert score.won == (infos["attacker_1"]["outcome"] == "success")
    assert score.reward == pytest.approx(rewards["attacker_1"])
    assert lines[-1].startswith(f"episode 1: {infos['attacker_1']['outcome']},")


@pytest.mark.parametrize(("attack", "action"), [("hold", 0), ("dribble", 2)])
def test_the_other_attacker_plays_the_scripted_attack(window, monkeypatch, attack, action):
    steps = _recording(monkeypatch, "attacker_0")
    play.play(_attacker(attack=attack), episodes=1, seed=2, keys=itertools.repeat(pygame.K_g),
              out=lambda _: None)
    holding = [actions["attacker_1"] for _, holder, actions in steps if holder == 1]
    assert holding and set(holding) == {action}
    assert {actions["attacker_0"] for _, _, actions in steps} == {3}  # G: GET_OPEN


def test_a_session_is_a_function_of_its_seed_and_keys(window, monkeypatch):
    steps = _recording(monkeypatch, "attacker_0")

    def session(seed):
        steps.clear()
        lines = []
        keys = itertools.cycle([pygame.K_b, pygame.K_d, pygame.K_g, pygame.K_p, pygame.K_SPACE])
        play.play(_attacker(attack="mixed_rules"), episodes=2, seed=seed, keys=keys,
                  out=lines.append)
        return list(steps), lines

    first = session(7)
    assert session(7) == first
    assert session(8) != first


def test_the_window_names_whom_you_play_and_the_keys(window, monkeypatch):
    titles = []
    set_caption = pygame.display.set_caption
    monkeypatch.setattr(pygame.display, "set_caption",
                        lambda text, *rest: (titles.append(text), set_caption(text, *rest)))
    play.play(_attacker(player="attacker_1"), keys=[pygame.K_ESCAPE], out=lambda _: None)
    title = titles[-1]
    assert "A2 (attacker_1)" in title and "goal_guards" in title
    assert all(word in title for word in ("H hold", "P pass", "D dribble", "G get open",
                                          "B go to ball"))


@pytest.mark.parametrize(("argv", "named"), [
    (["--control", "attacker", "--player", "defender_0"], ["'attacker_0'", "'attacker_1'"]),
    (["--control", "attacker", "--player", "attacker_9"], ["'attacker_0'", "'attacker_1'"]),
    (["--player", "attacker_1"], ["control 'attacker' only"]),
])
def test_a_bad_player_is_refused_naming_the_allowed(capsys, argv, named):
    assert play.main(argv) == 1
    err = capsys.readouterr().err
    assert argv[-1] in err and all(name in err for name in named)


@pytest.mark.parametrize(("argv", "named"), [
    (["--control", "attacker", "--attack", "no_such_rule"], ["late_pass", "mixed_rules"]),
    (["--control", "attacker", "--team", "no_such_team"], ["goal_guards", "chasers"]),
    (["--control", "striker"], ["holder", "attacker"]),
    (["--scenario", "drill_9v9"], ["drill_2v2", "drill_3v2"]),
])
def test_an_unknown_attack_team_or_control_is_refused_by_the_command(capsys, argv, named):
    with pytest.raises(SystemExit) as exc:
        play.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert argv[-1] in err and all(name in err for name in named)


@pytest.mark.parametrize(("field", "value", "named"), [
    ("attack", "no_such_rule", "late_pass"),
    ("team", "no_such_team", "goal_guards"),
    ("control", "striker", "'attacker'"),
    ("decision_cycles", 0, "[1, 50]"),
    ("scenario", "drill_9v9", "'drill_3v3'"),
])
def test_a_bad_setup_is_refused_naming_the_allowed(field, value, named):
    with pytest.raises(ValueError, match=rf"PlaySetup\.{field}") as exc:
        play.PlaySetup(**{field: value})
    assert named in str(exc.value)


# ------------------------------------------------------------ other sizes
def _played_in(name: str, team: str, action: int, seed: int) -> tuple[str, float]:
    """The outcome and reward of always taking ``action`` in scenario ``name``."""
    env = scenarios.holder_env(name, opponent=team)
    env.reset(seed=seed)
    done = False
    while not done:
        _, reward, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    return info["outcome"], reward


@pytest.mark.parametrize(("key", "action"), [
    (pygame.K_p, 1), (pygame.K_2, 1), (pygame.K_3, 2), (pygame.K_d, 3), (pygame.K_4, 3)])
def test_each_key_takes_its_decision_in_a_three_attacker_drill(window, key, action):
    # HOLD, PASS_1 (nearest teammate, also P), PASS_2, DRIBBLE (also D).
    setup = play.PlaySetup(team="chasers", scenario="drill_3v2")
    score = play.play(setup, episodes=1, seed=3, keys=itertools.repeat(key), out=lambda _: None)
    outcome, reward = _played_in("drill_3v2", "chasers", action, 3)
    assert (score.won, score.reward) == (outcome == "success", pytest.approx(reward))


def test_the_window_lists_every_pass_of_a_larger_drill(window, monkeypatch):
    titles = []
    set_caption = pygame.display.set_caption
    monkeypatch.setattr(pygame.display, "set_caption",
                        lambda text, *rest: (titles.append(text), set_caption(text, *rest)))
    setup = play.PlaySetup(team="chasers", scenario="drill_3v3", control="attacker",
                           player="attacker_2")
    play.play(setup, keys=[pygame.K_ESCAPE], out=lambda _: None)
    assert "A3 (attacker_2)" in titles[-1]
    assert ("H hold, P pass 1, 3 pass 2, D dribble, G get open, B go to ball"
            in titles[-1])


# 1v2 and 2v1: the holder's or the players' features are the paper's 9 and the other's
# not, where the lookup by name failed
@pytest.mark.parametrize("size", [(3, 2), (2, 3), (1, 1), (4, 2), (1, 2), (2, 1)])
def test_the_scripted_mates_decide_on_the_holders_features_at_any_size(size):
    # What a mate hands its attack is what the holder's SMDP would observe.
    config = soccer_drill.DrillConfig(attackers=size[0], defenders=size[1])
    agents = soccer_drill.parallel_env(opponent="chasers", config=config)
    holder = soccer_drill.HolderEnv(opponent="chasers", config=config)
    observations, _ = agents.reset(seed=11)
    view, _ = holder.reset(seed=11)
    assert agents.drill_state.pos == holder.unwrapped.drill_state.pos
    index = agents.drill_state.holder
    assert 0 <= index < agents.config.attackers
    mine = observations[agents.config.player_names[index]]
    mine = mine["observation"] if isinstance(mine, dict) else mine
    picked = np.asarray(mine)[holder_feature_indices(agents.config)]
    np.testing.assert_array_equal(picked, view)


@pytest.mark.parametrize(("attack", "skill"), [("hold", "HOLD"), ("dribble", "DRIBBLE")])
def test_the_other_attackers_play_the_scripted_attack_in_a_larger_drill(window, monkeypatch,
                                                                        attack, skill):
    steps = _recording(monkeypatch, "attacker_0")
    setup = play.PlaySetup(team="chasers", scenario="drill_3v2", control="attacker",
                           attack=attack)
    # Seed 1 starts with attacker_2 on the ball; you get open, or hold when you have it.
    play.play(setup, episodes=1, seed=1, keys=itertools.cycle([pygame.K_g, pygame.K_h]),
              out=lambda _: None)
    names = attacker_action_names(3)
    holding = [actions[f"attacker_{h}"] for _, h, actions in steps if h in (1, 2)]
    assert holding and {names[a] for a in holding} == {skill}
    assert {names[actions["attacker_0"]] for _, _, actions in steps} <= {"GET_OPEN", "HOLD"}



def test_gymnasiums_play_finds_the_keys_of_soccer_drill_play(window):
    import gymnasium as gym
    from gymnasium.utils.play import PlayableGame

    from soccer_drill.rendering.controls import HolderControl, PlaySetup

    env = gym.make("soccer_drill/Holder3v2-v0", render_mode="rgb_array")
    env.reset(seed=0)
    game = PlayableGame(env)  # MissingKeysToAction when the environment has no keys
    assert game.relevant_keys == set("hpd1234")  # play() takes their code points
    keys = env.get_wrapper_attr("get_keys_to_action")()
    assert [keys[(key,)] for key in "hpd"] == [0, 1, 3]  # HOLD, PASS_1, DRIBBLE
    control = HolderControl(PlaySetup(team="chasers", scenario="drill_3v2"))
    assert {ord(key): action for (key,), action in keys.items()} == control.keys
    env.close()
