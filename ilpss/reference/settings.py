"""The settings of the reference runs, written down: frozen dataclasses, passed whole.

Every job's kept record holds its settings (``dataclasses.asdict``), so that a changed
setting is a new job and never takes another's results. This module imports no torch:
the command's parser and its checks run without it.

Why these values (the holder: in a first trial SB3's defaults learned in 2 of 7 training
seeds, and unnormalised features in none):

- ``normalize_obs=True``: the holder's features go up to 180 (angles in degrees); SB3's
  ``VecNormalize`` (observations only: the rewards are already in [-1, 1]).
- ``gamma=1.0``: an episode pays one reward at its end, -1 for an interception and for a
  timeout alike. Under a discount a later -1 is worth more than an early one, so holding
  the ball until the timeout looks better than trying; the holder's episodes are a few
  dozen decisions, so no discount is needed to keep returns bounded.
- ``timeout_terminal=True``: no value bootstrap at the timeout (see
  :class:`HolderSetting`). In a check against ``chasers`` at 200,000 decisions, SB3's
  bootstrap left 3 of 3 seeds at 0% greedy success, where the terminal timeout reached
  85-95% (``docs/reference_rl.md``).
- ``ent_coef=0.01``, ``net_arch=(64, 64)``, ``n_envs=16``, ``n_steps=256``: SB3's
  usual small-MLP settings, with more drills per rollout than the default for a steadier
  gradient on a sparse reward.

The multi-agent settings (:class:`MarlSetting`), chosen on development seeds from 1000
(the search: ``docs/reference_rl.md``):

- ``obs_type="full"``: against ``interceptors_press`` at 1,000,000 steps, greedy success
  54% with the paper's 9 features and 96% with the full observation; against
  ``goal_guards`` at 1,000,000 steps, 57.5-60% with ``"kinematic"`` and 65.5% with
  ``"full"``.
- ``shaping=1.0``: without it, no episode against ``goal_guards`` ever succeeded in
  2,000,000 steps (random attackers never beat that team, so nothing is learnt); with
  it, training success reached 70% within 300,000 steps.
- ``steps=2_000_000``: at 1,000,000 the greedy policy against ``goal_guards`` still
  dribbled where the sampled one passed (greedy 65.5%, sampled 83%); at 2,000,000
  they agreed (87%, 88%).

:class:`RewardOption` (the holder's) and ``MarlSetting.shaping`` are the changes to the
drill's reward this command can make, recorded in every result; evaluations and curves
are always the drill's reward.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from soccer_drill.constraints import (
    Bool,
    Integer,
    ListOf,
    Name,
    NoneOr,
    OneOf,
    Real,
    check_fields,
)

__all__ = ["SETTINGS", "HolderSetting", "PPOConfig"]

ALGOS = ("ppo", "maskable_ppo")
"""The Stable-Baselines3 learners of the holder: SB3's ``PPO``, sb3-contrib's
``MaskablePPO``."""


@dataclass(frozen=True)
class RewardOption:
    """A change to the holder's reward, made by a wrapper of this command (off by default:
    the drill's reward as the paper defines it).

    Parameters
    ----------
    timeout_reward : float or None, default None
        The reward of an episode that ends by the timeout (the drill pays -1, as for an
        interception); ``None`` keeps the drill's.
    """

    timeout_reward: float | None = None

    def __post_init__(self) -> None:
        check_fields("RewardOption", self, {"timeout_reward": NoneOr(Real(-10.0, 1.0))})

    @property
    def active(self) -> bool:
        """Whether the reward differs from the drill's."""
        return self.timeout_reward is not None


PPO_CONSTRAINTS = {
    **dict.fromkeys(("steps", "n_envs", "n_steps", "batch_size", "n_epochs"), Integer(1)),
    **dict.fromkeys(("learning_rate", "gamma", "gae_lambda", "clip_range", "ent_coef"),
                    Real(0.0, 1.0)),
    "vf_coef": Real(0.0, 10.0),
    "max_grad_norm": Real(0.0, 100.0),
    "net_arch": ListOf(Integer(1), min_len=1),  # the layer widths
}
"""What each field of :class:`PPOConfig` allows."""


@dataclass(frozen=True)
class PPOConfig:
    """PPO's hyperparameters (names as SB3's ``PPO`` arguments).

    ``steps`` is the budget in environment steps: the holder's decisions, or the
    parallel drill's cycles times drills (each step of every drill counted once, however
    many agents act in it).
    """

    steps: int = 300_000
    n_envs: int = 16
    n_steps: int = 256
    batch_size: int = 512
    n_epochs: int = 10
    learning_rate: float = 3e-4
    gamma: float = 1.0
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    net_arch: tuple[int, ...] = (64, 64)

    def __post_init__(self) -> None:
        check_fields("PPOConfig", self, PPO_CONSTRAINTS)
        if (self.n_envs * self.n_steps) % self.batch_size:
            raise ValueError(f"PPOConfig.batch_size ({self.batch_size}) must divide "
                             f"n_envs * n_steps ({self.n_envs * self.n_steps})")



@dataclass(frozen=True)
class EvalSettings:
    """The greedy evaluation: ``episodes`` held-out episode seeds from 10,000 on (those of
    ``ilpss-holder-learning``; training episodes start from 1,000,000 (seed + 1)), and
    what counts as a seed that learned: a greedy success of at least
    ``learned_fraction`` of the best fixed rule's on the same episodes (0.9: close to
    the rule, not a fraction of it)."""

    episodes: int = 200
    learned_fraction: float = 0.9

    def __post_init__(self) -> None:
        check_fields("EvalSettings", self,
                     {"episodes": Integer(1), "learned_fraction": Real(0.0, 1.0)})


@dataclass(frozen=True)
class HolderSetting:
    """PPO or MaskablePPO on the holder (``HolderSB3VecEnv``), one team per job.

    ``timeout_terminal``: the drill ends an episode at its timeout paying -1, a failure
    as an interception is, but reports it as a truncation, at which SB3 adds the
    discounted value of the last state to the reward (a bootstrap, right for an episode
    cut short, not for one that ended). With ``True`` (the default) the learner takes
    the timeout as the end it is (``TimeLimit.truncated`` cleared); the reward is the
    drill's either way. ``False`` is SB3's treatment.
    """

    algo: str = "ppo"
    ppo: PPOConfig = field(default_factory=PPOConfig)
    normalize_obs: bool = True
    timeout_terminal: bool = True
    reward: RewardOption = field(default_factory=RewardOption)

    def __post_init__(self) -> None:
        check_fields("HolderSetting", self, {
            "algo": OneOf(ALGOS), "normalize_obs": Bool(), "timeout_terminal": Bool(),
        })


SIDES = ("attackers", "defenders")
"""Which side of the parallel drill learns against a scripted one."""
CRITICS = ("state", "own")
"""What the critic sees: ``state()`` (MAPPO) or the player's own observation (IPPO)."""
OBS_TYPES = ("features", "kinematic", "full")
"""The parallel drill's observation types."""


def _marl_ppo() -> PPOConfig:
    return PPOConfig(steps=2_000_000, n_envs=64, n_steps=128, batch_size=2048, n_epochs=4,
                     learning_rate=2.5e-4, gamma=1.0, ent_coef=0.01)


@dataclass(frozen=True)
class MarlSetting:
    """MAPPO or IPPO for one side of the parallel drill (``ilpss/reference/marl_ppo.py``).

    ``side``: the attackers (against a scripted defending team) or the defenders
    (against the scripted ``attack``, an id of ``soccer_drill.vector.attack.ATTACKS``).
    ``critic``: ``"state"`` (MAPPO: the critic sees ``state()``) or ``"own"`` (IPPO: the
    player's observation). ``obs_type``: the players' observation. ``mask_input``: the
    action mask is an input of the actor too. ``value_norm``: the critic's targets
    normalised by running statistics. ``shaping`` (the reward option, 0 = off): a
    potential-based term, ``shaping`` times the ball's progress toward the goal line in
    fields, the end's potential 0, so that an episode's total is the drill's reward minus
    a constant of its start (the drill's best policies stay the best; ``marl_ppo``).
    ``decision_cycles``: the players decide every that many cycles and whenever the ball
    changes hands, keeping their action in between (1: every cycle, the drill's pace;
    ``marl_ppo.Decisions``). ``anneal``: the learning rate and the entropy bonus fall
    linearly to 0 over the budget (CleanRL anneals the learning rate), so that the
    policy settles. ``agent_id``: each player's observation ends with a one-hot of its
    index in its side (the actor's input, and the critic's with ``critic="own"``), as
    MAPPO gives agent ids to a shared policy, so that the side's two players can take
    different roles in the same situation.
    """

    side: str = "attackers"
    critic: str = "state"
    obs_type: str = "full"
    mask_input: bool = True
    value_norm: bool = True
    shaping: float = 1.0
    decision_cycles: int = 1
    anneal: bool = False
    agent_id: bool = False
    attack: str = "mixed_rules"
    ppo: PPOConfig = field(default_factory=_marl_ppo)

    def __post_init__(self) -> None:
        check_fields("MarlSetting", self, {
            "side": OneOf(SIDES), "critic": OneOf(CRITICS), "obs_type": OneOf(OBS_TYPES),
            "mask_input": Bool(), "value_norm": Bool(), "shaping": Real(0.0, 10.0),
            "decision_cycles": Integer(1, 50), "anneal": Bool(), "agent_id": Bool(),
            "attack": Name(dots=False),
        })


OPPONENT_SAMPLING = ("uniform", "pfsp")
KEEP_RULES = ("last", "least_exploited")
"""How self-play draws each half's opponents (:class:`SelfPlaySetting`)."""


@dataclass(frozen=True)
class SelfPlaySetting:
    """Self-play of both sides against a pool of their past checkpoints (fictitious
    self-play; ``marl_ppo.train_self_play``): the attackers' and the defenders' networks
    (``marl``'s critic, observation and options; its ``side`` and ``attack`` unused)
    learn together, each half of the drills training one side against checkpoints of
    the other. ``snapshots`` checkpoints are kept, evenly over training (the untrained
    networks first, the trained last), and played against each other on
    ``crossplay_episodes`` held-out episodes (the cross-play table).

    ``opponents`` is how a half's opponents are drawn at each rollout:

    | ``opponents`` | the other side's players in a half's drills |
    |---|---|
    | ``"uniform"`` | one opponent for the whole half: a checkpoint drawn uniformly from the pool with probability 1/2, else its current networks (or, with exploiters, its exploiter, evenly) |
    | ``"pfsp"`` | one per drill, from the pool, the current networks (and the exploiter), with probability proportional to ``q (1 - q) + pfsp_floor``, ``q`` the attackers' recent success in that pairing (prioritised fictitious self-play, Vinyals et al. 2019, "variance" weighting) |

    Why ``"pfsp"`` exists (a reading of the uniform pool's collapse in some seeds, not
    shown; ``docs/reference_rl.md``): a side whose episodes all end the same way learns
    no outcome from them (the drill pays one reward at the end, and the reward option's
    terms add up to a constant over an episode), and under ``"uniform"`` a whole half
    may face such an opponent for a rollout. Opponents that the learning side beats some of the time
    give it a signal; ``pfsp_floor`` keeps every opponent in play. ``pfsp_decay`` is
    the weight each rollout keeps of the pairings' earlier results.

    ``exploiter_share`` (0: none, the default) adds a *main exploiter* per side
    (Vinyals et al. 2019): the last drills of each half (:meth:`exploiter_drills`)
    train another network of that half's side, only against the other side's current
    networks, and each side's main networks may draw the other side's exploiter as an
    opponent (one more live candidate beside its current networks). An exploiter looks
    for what beats the other side now, so that side meets it. Its drills are taken from
    its half's main side (give ``marl.ppo`` more drills and steps to keep the main
    sides' data); it is neither kept in the pool nor evaluated. On four development
    seeds the defenders trained with exploiters still pressed, as prioritised
    self-play's do (``docs/reference_rl.md``).

    ``keep`` is which checkpoints a job evaluates as the trained networks (training is
    the same whatever it says):

    | ``keep`` | the attackers kept | the defenders kept |
    |---|---|---|
    | ``"last"`` | the last checkpoint | the last checkpoint |
    | ``"least_exploited"`` | the trained checkpoint whose fewest successes against any trained defenders' checkpoint are most | the trained checkpoint that concedes fewest successes to the trained attackers' checkpoint that beats it most |

    ``"least_exploited"`` reads only the cross-play table (the checkpoints against each
    other, untrained ones left out; ties go to the later checkpoint,
    ``jobs.KEEP``), never the scripted teams: a side whose last networks
    learnt a reply to its opponents' latest play that older opponents beat is kept at
    an earlier, sturdier checkpoint.
    """

    marl: MarlSetting = field(default_factory=MarlSetting)
    snapshots: int = 6
    crossplay_episodes: int = 100
    opponents: str = "uniform"
    pfsp_floor: float = 0.02
    pfsp_decay: float = 0.9
    exploiter_share: float = 0.0
    keep: str = "last"

    def __post_init__(self) -> None:
        check_fields("SelfPlaySetting", self, {
            "snapshots": Integer(2, 50), "crossplay_episodes": Integer(1),
            "opponents": OneOf(OPPONENT_SAMPLING), "pfsp_floor": Real(0.0, 1.0, low_open=True),
            "pfsp_decay": Real(0.0, 1.0, high_open=True),
            "exploiter_share": Real(0.0, 0.5, high_open=True), "keep": OneOf(KEEP_RULES)})

    def exploiter_drills(self) -> int:
        """Each half's drills for its exploiter: ``exploiter_share`` of the half, rounded,
        at least one if the share is not 0, and at most all but one (the main side's)."""
        half = self.ppo.n_envs // 2
        if not self.exploiter_share:
            return 0
        return min(max(1, round(self.exploiter_share * half)), half - 1)

    @property
    def ppo(self) -> PPOConfig:
        """The learners' PPO configuration (``marl.ppo``)."""
        return self.marl.ppo


@dataclass(frozen=True)
class TransferSetting:
    """PPO fine-tuned on the holder from its policy after the source teams (in order,
    ``source_steps`` each), against learning anew, on the held-out target for
    ``target_episodes`` episodes (its learning curve in episodes, as ``ilpss``'s), then
    evaluated greedily. ``window`` episodes make the jumpstart (first) and the final
    (last)."""

    holder: HolderSetting = field(default_factory=HolderSetting)
    source_steps: int = 150_000
    target_episodes: int = 3_000
    window: int = 300

    def __post_init__(self) -> None:
        check_fields("TransferSetting", self, dict.fromkeys(
            ("source_steps", "target_episodes", "window"), Integer(1)))
        if self.window * 2 > self.target_episodes:
            raise ValueError(f"TransferSetting.window ({self.window}) must be at most half of "
                             f"target_episodes ({self.target_episodes})")


SETTINGS: dict[str, HolderSetting | MarlSetting | SelfPlaySetting | TransferSetting] = {
    "ppo": HolderSetting(algo="ppo"),
    "maskable_ppo": HolderSetting(algo="maskable_ppo"),
    "mappo": MarlSetting(critic="state"),
    "ippo": MarlSetting(critic="own"),
    "defenders": MarlSetting(side="defenders", critic="state"),
    "self_play": SelfPlaySetting(),
    "self_play_pfsp": SelfPlaySetting(opponents="pfsp"),
    # each side's half of the drills gets the 2,000,000 steps of a one-side setting
    "self_play_pfsp_long": SelfPlaySetting(
        marl=MarlSetting(ppo=replace(_marl_ppo(), steps=4_000_000)), opponents="pfsp"),
    # the same training as self_play_pfsp_long; each side kept at its least exploited
    # checkpoint in cross-play
    "self_play_pfsp_long_kept": SelfPlaySetting(
        marl=MarlSetting(ppo=replace(_marl_ppo(), steps=4_000_000)), opponents="pfsp",
        keep="least_exploited"),
    # the main sides keep self_play_pfsp's 32 drills a half and steps; exploiters add 8
    "self_play_league": SelfPlaySetting(
        marl=MarlSetting(ppo=replace(_marl_ppo(), n_envs=80, steps=2_500_000)),
        opponents="pfsp", exploiter_share=0.2),
    "transfer": TransferSetting(),
}
"""The command's settings by name, in the page's order."""
