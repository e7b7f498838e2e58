"""Play the drill yourself: you decide for the ball holder, a registered team defends.

Command line::

    soccer-drill-play --team goal_guards [--episodes N] [--seed 0]

A window shows the drill at true speed (``HolderEnv`` with ``render_mode="human"``).
Whenever an attacker of yours holds the ball the drill waits for your decision:

| key | decision |
|---|---|
| ``H`` or ``1`` | HOLD: shield the ball for 0.4 s |
| ``P`` or ``2`` | PASS to the other attacker |
| ``D`` or ``3`` | DRIBBLE toward the goal line for 0.4 s |
| ``Space`` or ``Enter`` | after an episode: the next one |
| ``Esc``, ``Q`` or closing the window | stop |

The score (episodes won, their number, the total reward) is kept over the episodes, shown
in the header and printed after each episode. Episode ``k`` is played on seed ``seed + k``,
so a session can be replayed against the same starts.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

from soccer_drill.constraints import Integer, NoneOr, checked
from soccer_drill.envs.holder import HolderEnv
from soccer_drill.teams.registry import TeamError, team_ids

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pygame  # after the prompt is hidden

DECISION_KEYS = {pygame.K_h: 0, pygame.K_1: 0, pygame.K_p: 1, pygame.K_2: 1,
                 pygame.K_d: 2, pygame.K_3: 2}
"""The keys of the holder's three decisions (0 HOLD, 1 PASS, 2 DRIBBLE)."""
NEXT_KEYS = frozenset({pygame.K_SPACE, pygame.K_RETURN})
QUIT_KEYS = frozenset({pygame.K_ESCAPE, pygame.K_q})
PROMPT = "your move: H hold, P pass, D dribble"
NEXT = "Space: next episode, Esc: stop"
EPISODES = NoneOr(Integer(1))


@dataclass
class Score:
    """A session's score: episodes played, won (``"success"``) and their total reward."""

    episodes: int = 0
    won: int = 0
    reward: float = 0.0

    def add(self, outcome: str, reward: float) -> None:
        self.episodes += 1
        self.won += outcome == "success"
        self.reward += reward

    def __str__(self) -> str:
        return f"score {self.won} won of {self.episodes}, reward {self.reward:+.2f}"


class Quit(Exception):
    """The player stopped (a quit key, or the window closed)."""


def _key(allowed: Iterable[int], script: Iterator[int] | None) -> int:
    """Wait for one of ``allowed`` keys; with a ``script``, its next key is pressed first
    (a scripted session, run without anyone at the keyboard)."""
    allowed = frozenset(allowed)
    while True:
        if script is not None:
            key = next(script, pygame.K_ESCAPE)
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, mod=0, unicode=""))
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN
                                             and event.key in QUIT_KEYS):
                raise Quit
            if event.type == pygame.KEYDOWN and event.key in allowed:
                return event.key
        pygame.time.wait(15)


def play(team: str = "goal_guards", episodes: int | None = None, seed: int = 0,
         keys: Iterable[int] | None = None, out=print) -> Score:
    """Play episodes against ``team`` in a window until ``episodes`` are over (``None``:
    until you stop); return the score. ``keys``: pygame key codes pressed in turn
    whenever the session waits for one (a scripted session, e.g. headless under SDL's
    dummy video driver), ``Esc`` once they run out."""
    episodes = checked("episodes", episodes, EPISODES)
    script = None if keys is None else iter(keys)
    env = HolderEnv(opponent=team, render_mode="human")
    env.policy_name = "you (keyboard)"
    score = Score()
    try:
        while episodes is None or score.episodes < episodes:
            env.score_text = str(score)
            env.caption = PROMPT
            env.reset(seed=seed + score.episodes)
            done, reward, info = False, 0.0, {}
            while not done:
                env.caption = PROMPT
                env.render()
                action = DECISION_KEYS[_key(DECISION_KEYS, script)]
                env.caption = None
                _, reward, terminated, truncated, info = env.step(action)
                done = terminated or truncated
            score.add(info["outcome"], reward)
            env.score_text = str(score)
            out(f"episode {score.episodes}: {info['outcome']}, reward {reward:+.2f}; {score}")
            if episodes is None or score.episodes < episodes:
                env.caption = NEXT
                env.render()
                _key(NEXT_KEYS, script)
    except Quit:
        pass
    finally:
        env.close()
    return score


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-play``."""
    parser = argparse.ArgumentParser(prog="soccer-drill-play",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--team", default="goal_guards", choices=team_ids(), metavar="TEAM",
                        help="the defending team (soccer-drill-teams lists them)")
    parser.add_argument("--episodes", type=int, default=None,
                        help="stop after this many episodes (default: until Esc)")
    parser.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    args = parser.parse_args(argv)
    try:
        score = play(args.team, args.episodes, args.seed)
    except (TeamError, ValueError, pygame.error) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    print(f"final {score}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
