"""Play the drill yourself: you decide for the ball holder, or play one attacker, against a
registered team.

Command line::

    soccer-drill-play --team goal_guards [--episodes N] [--seed 0]
    soccer-drill-play --team goal_guards --control attacker [--player attacker_0] [--attack late_pass]
    soccer-drill-play --scenario drill_3v2 --team chasers [--control attacker]

A window shows the drill at true speed (``render_mode="human"``). ``--control`` says what
you decide for (:mod:`soccer_drill.rendering.controls`):

| ``--control`` | environment | you decide |
|---|---|---|
| ``holder`` (default) | ``HolderEnv``, the holder's SMDP | for whichever attacker holds the ball |
| ``attacker`` | the PettingZoo drill (``soccer_drill.scenarios.parallel_env``) | for one attacker agent (``--player``, default ``attacker_0``), on the ball and off it; a scripted attack (``--attack``, an id of ``soccer_drill.attacks``, default ``late_pass``) decides for the other attackers when they hold the ball |

``--scenario`` picks the drill's size, a named scenario of :mod:`soccer_drill.scenarios`
(``drill_2v2``, the paper's drill, by default; ``drill_1v1``, ``drill_3v2``,
``drill_3v3``); the team must play its number of defenders.

Whenever you must decide the drill waits for a key:

| key | action |
|---|---|
| ``H`` or ``1`` | HOLD: shield the ball (holding it) |
| ``P`` or ``2`` | PASS to the other attacker (holding it); with more attackers, to the nearest teammate, and ``3`` ... to the next nearest |
| ``D`` or the digit after the passes (``3`` in the 2v2 drill) | DRIBBLE toward the goal line (holding it) |
| ``G`` or the next digit (``4``) | GET_OPEN: run to a support spot (``attacker`` control, off the ball) |
| ``B`` or the next digit (``5``) | GO_TO_BALL: run to the ball (``attacker`` control, off the ball) |
| ``Space`` or ``Enter`` | after an episode: the next one |
| ``Esc``, ``Q`` or closing the window | stop |

A decision lasts ``--decision-cycles`` cycles (4, 0.4 s; a PASS one kick), cut short when
your player gains or loses the ball. A key whose action is not legal now (the agent's
action mask: a ball action off the ball, an off-ball action holding it) is refused with a
message naming the legal keys, and the drill goes on waiting. The window's title names whom
you play and the keys; its header, the legal keys now.

The command needs a display: with none (on Linux neither ``DISPLAY`` nor ``WAYLAND_DISPLAY``
set, or SDL's video driver ``dummy`` or ``offscreen``, which show no window) it says so and
exits with status 1 instead of waiting for keys no one can press. Ctrl-C stops it with one
line and status 130.

The score (episodes won, their number, the total reward) is kept over the episodes, shown
in the header and printed after each episode. Episode ``k`` is played on seed ``seed + k``,
so a session can be replayed against the same starts: the same seed and the same keys give
the same episodes.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

from soccer_drill.constraints import Integer, NoneOr, checked
from soccer_drill.teams.registry import TeamError, team_ids

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import pygame  # after the prompt is hidden

from soccer_drill.rendering.controls import CONTROLS, DEFAULT_ATTACK, Control, PlaySetup
from soccer_drill.scenarios import SCENARIOS
from soccer_drill.vector.attack import ATTACKS

NEXT_KEYS = frozenset({pygame.K_SPACE, pygame.K_RETURN})
QUIT_KEYS = frozenset({pygame.K_ESCAPE, pygame.K_q})
NEXT = "Space: next episode, Esc: stop"
EPISODES = NoneOr(Integer(1))
HEADLESS_DRIVERS = frozenset({"dummy", "offscreen"})
"""SDL video drivers that show no window: keys cannot be pressed in one."""


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


def _decision(control: Control, script: Iterator[int] | None, out) -> int:
    """Wait for the key of an action ``control`` allows now; a key of an action not
    allowed now is refused, said in the window and through ``out``."""
    while True:
        action = control.keys[_key(control.keys, script)]
        refused = control.refusal(action)
        if refused is None:
            return action
        out(f"refused: {refused}")
        control.env.caption = refused
        control.env.render()


def play(setup: PlaySetup | str = "goal_guards", episodes: int | None = None, seed: int = 0,
         keys: Iterable[int] | None = None, out=print) -> Score:
    """Play episodes of ``setup`` (a team id alone: the holder control against that team)
    in a window until ``episodes`` are over (``None``: until you stop); return the score.
    ``keys``: pygame key codes pressed in turn whenever the session waits for one (a
    scripted session, e.g. headless under SDL's dummy video driver), ``Esc`` once they
    run out. Without ``keys``, ``ValueError`` if no window can be shown here (no display,
    or a driver that shows none): the session would wait for keys no one can press."""
    if isinstance(setup, str):
        setup = PlaySetup(team=setup)
    episodes = checked("episodes", episodes, EPISODES)
    script = None if keys is None else iter(keys)
    control = CONTROLS[setup.control](setup)
    env = control.env
    if script is None:  # someone must press the keys, in a window they can see
        try:
            _check_display()
        except ValueError:
            env.close()
            raise
    score = Score()
    try:
        while episodes is None or score.episodes < episodes:
            env.score_text = str(score)
            env.caption = None
            control.start(seed + score.episodes)
            if pygame.display.get_init():  # the window opened at the reset
                pygame.display.set_caption(control.title)
            ended = None
            while ended is None:
                env.caption = control.prompt()
                env.render()
                action = _decision(control, script, out)
                env.caption = None
                ended = control.act(action)
            score.add(ended.outcome, ended.reward)
            env.score_text = str(score)
            out(f"episode {score.episodes}: {ended.outcome}, reward {ended.reward:+.2f}; "
                f"{score}")
            if episodes is None or score.episodes < episodes:
                env.caption = NEXT
                env.render()
                _key(NEXT_KEYS, script)
    except Quit:
        pass
    finally:
        env.close()
    return score


def no_display() -> str | None:
    """Why no window can be shown here, or ``None``: SDL's video driver set to one that
    shows none, or on Linux with SDL's driver left to choose, no X11 or Wayland display
    (SDL would fall back to its ``offscreen`` driver)."""
    driver = os.environ.get("SDL_VIDEODRIVER", "").strip().lower()
    if driver in HEADLESS_DRIVERS:
        return f"SDL_VIDEODRIVER={driver} shows no window"
    if not driver and sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display: neither DISPLAY nor WAYLAND_DISPLAY is set"
    return None


def _check_display() -> None:
    """``ValueError`` if no window can be shown (:func:`no_display`, or SDL's driver once
    started is one that shows none): the drill would wait for keys no one can press."""
    why = no_display()
    if why is None:
        pygame.display.init()
        driver = pygame.display.get_driver()
        if driver in HEADLESS_DRIVERS:
            pygame.display.quit()
            why = f"SDL found no display and chose its {driver} driver, which shows no window"
    if why is not None:
        raise ValueError(f"{why}; soccer-drill-play needs a display to show the drill and "
                         "read your keys (run it in a desktop session, or with ssh -X)")


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point ``soccer-drill-play``."""
    parser = argparse.ArgumentParser(
        prog="soccer-drill-play", description=__doc__.split("\n\n")[0].replace("\n", " "),
        epilog="keys (the 2v2 drill): H/1 hold, P/2 pass, D/3 dribble (holding the ball); "
               "G/4 get open, B/5 go to ball (--control attacker, off the ball); with more "
               "attackers P passes to the nearest teammate and the digits follow the actions "
               "(the window's title lists them); a key whose action is masked now is "
               "refused. Space/Enter: next episode; Esc/Q: stop.")
    parser.add_argument("--team", default="goal_guards", choices=team_ids(), metavar="TEAM",
                        help="the defending team (soccer-drill-teams lists them)")
    parser.add_argument("--scenario", default="drill_2v2", choices=tuple(SCENARIOS),
                        help="the drill's size: a named scenario (default: drill_2v2, the "
                             "paper's drill)")
    parser.add_argument("--control", default="holder", choices=tuple(CONTROLS),
                        help="holder (default): decide for whichever attacker holds the ball "
                             "(the holder SMDP); attacker: play one attacker of the "
                             "PettingZoo drill, on and off the ball")
    parser.add_argument("--player", default=None, metavar="AGENT",
                        help="--control attacker: the attacker agent you play (default: "
                             "attacker_0; one of the drill's possible_agents)")
    parser.add_argument("--attack", default=None, choices=ATTACKS.names(), metavar="ATTACK",
                        help="--control attacker: the scripted attack deciding for the other "
                             f"attackers when they hold the ball (default: {DEFAULT_ATTACK}; "
                             f"one of {', '.join(ATTACKS.names())})")
    parser.add_argument("--decision-cycles", type=int, default=4, metavar="N",
                        help="the cycles a decision lasts at most (default 4, 0.4 s)")
    parser.add_argument("--episodes", type=int, default=None,
                        help="stop after this many episodes (default: until Esc)")
    parser.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    args = parser.parse_args(argv)
    try:
        setup = PlaySetup(team=args.team, control=args.control, scenario=args.scenario,
                          player=args.player,
                          attack=args.attack, decision_cycles=args.decision_cycles)
        checked("--episodes", args.episodes, EPISODES)
        score = play(setup, args.episodes, args.seed)
    except (TeamError, ValueError, pygame.error) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # one line and the shell's status for SIGINT
        print(f"{parser.prog}: stopped by Ctrl-C (SIGINT); the finished episodes' results "
              "are printed above", file=sys.stderr)
        return 130
    print(f"final {score}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
