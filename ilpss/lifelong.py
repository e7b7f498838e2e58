"""The lifelong loop of ILPSS (paper Algorithm 1), with atomic checkpoints.

For every new task instance (here: a new opponent team):

1. learn a policy by SMDP learning over the primitives and the current options
   (Algorithm 1, line 7);
2. roll the learnt policy out greedily; keep the states of the successful episodes
   as this instance's *bag of states* (lines 2-4), and tell the option library which
   options the learnt policy used, so unused ones are discounted and pruned (paper
   section 6);
3. freeze the policy and add it to the input policies (line 8);
4. refit the shared kernels on all bags (line 5) and rebuild the option library
   from them and all policies, keeping option identities across the refit (line 6).

Everything random in a trial is seeded from ``(seed, trial index)``, so a run
resumed from the checkpoint of trial ``t`` ends identical to an uninterrupted one.
The loop talks to environments only through the Gymnasium API.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ilpss._io import (
    atomic_write_bytes,
    check_inside,
    json_record_bytes,
    load_archive,
    load_json_record,
    locked_folder,
    read_regular,
    remove_stale_temporaries,
    save_npz_atomic,
    sha256_file,
)
from ilpss._schema import FLOAT, ArchiveSchema, Field
from ilpss.episode import EpisodeResult, check_env, options_used
from ilpss.kernels import KERNEL_CONSTRAINTS, SharedKernelModel, UniformKernel
from ilpss.options import OptionLibrary, OptionSettings
from ilpss.policy import FrozenPolicy
from ilpss.reuse import REUSES, Fresh, Reuse, learn_with
from ilpss.smdp import LearnerConfig, SmdpLearner
from ilpss.tiles import box_bounds
from soccer_drill.constraints import (
    Integer,
    ListOf,
    Name,
    NoneOr,
    OneOf,
    Real,
    Text,
    check,
    check_fields,
    check_keys,
    checked,
    from_json,
)

CHECKPOINT_SCHEMA = "ilpss.lifelong/2"
TRIAL = Integer(0)
"""What :meth:`LifelongLearner.learn`'s ``trial`` may be (``None``: the next trial)."""


LIFELONG_CONSTRAINTS = {
    "n_kernels": KERNEL_CONSTRAINTS["n_components"],
    # Every episode's result is kept in memory: far above any useful value, a typo fails
    # here rather than after hours.
    "train_episodes": Integer(0, 1_000_000),
    "rollout_episodes": Integer(0, 100_000),
    "options": Name(),  # and registered: checked against REUSES
    "kernel_n_init": KERNEL_CONSTRAINTS["n_init"],
    "kernel_max_iter": KERNEL_CONSTRAINTS["max_iter"],
    "kernel_reg_covar": KERNEL_CONSTRAINTS["reg_covar"],
}
"""What each scalar field of :class:`LifelongConfig` allows (the kernel settings are
:data:`~ilpss.kernels.KERNEL_CONSTRAINTS`)."""


@dataclass(frozen=True)
class LifelongConfig:
    """How ILPSS extracts structure after each trial."""

    n_kernels: int = 5
    """Shared kernels fitted after every trial (the paper uses 5)."""
    train_episodes: int = 300
    """Learning episodes per task instance."""
    rollout_episodes: int = 50
    """Greedy rollouts of the learnt policy: its traces and the options it uses."""
    options: str = "kernels"
    """How past policies are reused: the name of a registered :class:`~ilpss.reuse.Reuse`
    (:data:`~ilpss.reuse.REUSES`): ``"kernels"`` (ILPSS), ``"whole_policies"`` (ablation:
    past policies as options that start anywhere and never stop), ``"none"`` (learning
    anew every time), ``"finetune_latest"`` / ``"finetune_best"`` (start from a past
    policy's values)."""
    kernel_n_init: int = 3
    """EM restarts per fit."""
    kernel_max_iter: int = 200
    """EM iterations at most per restart."""
    kernel_reg_covar: float = 1e-6
    """Added to the diagonal of every (standardised) covariance."""
    library: OptionSettings = field(default_factory=OptionSettings)
    """The option library's discounting, pruning, pointers, matching and option duration."""
    learner: LearnerConfig = field(default_factory=LearnerConfig)
    """The SMDP learner's hyper-parameters."""

    def __post_init__(self) -> None:
        check_fields("LifelongConfig", self, LIFELONG_CONSTRAINTS)
        REUSES.check("LifelongConfig.options", self.options)
        for name, kind in (("library", OptionSettings), ("learner", LearnerConfig)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(
                    f"LifelongConfig.{name} must be a {kind.__name__} (from_dict takes a "
                    f"dict), got {type(getattr(self, name)).__name__}"
                )

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)

    @property
    def reuse(self) -> Reuse:
        """The registered way of reusing past policies that :attr:`options` names."""
        return REUSES.get(self.options)

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> LifelongConfig:
        """Inverse of :meth:`to_dict`; unknown keys are refused by name."""
        return from_json(cls, values, nested={"library": OptionSettings,
                                              "learner": LearnerConfig})


def handing_back(config: LifelongConfig) -> LifelongConfig:
    """``config`` with the settings of ILPSS+, the improved method: kernel options that
    are followed first and hand control back to the primitives as these learn.

    Every change is a switch whose default is the paper's; this is where they are set
    together (``docs/discussion.md`` records how they were chosen and what they give):

    ==========================================  =========  ==========  ======================
    setting                                     the paper  ILPSS+      why
    ==========================================  =========  ==========  ======================
    ``kernel_reg_covar``                        1e-6       0.1         broader kernels: the
                                                                       options can start at
                                                                       a new opponent's
                                                                       states
    ``learner.option_initial_value``            1 (=       0           no lasting optimism
                                                primitives)            about options
    ``learner.option_bonus`` / ``_episodes``    0          1.5 / 100   options first, fading
                                                                       to the primitives
    ``learner.interruption``                    false      true        hand back where a
                                                                       primitive is worth more
    ``learner.intra_option_primitives``         false      true        primitives learn from
                                                                       the options' steps
    ``library.continuation_exponent``           1          0.5         options run longer
    ``library.max_match_distance``              3          None        kernel identities
                                                                       persist across refits
    ``library.used_min_decisions``              1          20          "used" means relied on
    ==========================================  =========  ==========  ======================

    The base learner (primitives' initial value, traces, step size, exploration) is
    ``config``'s, unchanged: the same as learning anew's.
    """
    return replace(
        config,
        kernel_reg_covar=0.1,
        learner=replace(config.learner, option_initial_value=0.0, option_bonus=1.5,
                        option_bonus_episodes=100, interruption=True,
                        intra_option_primitives=True),
        library=replace(config.library, continuation_exponent=0.5, max_match_distance=None,
                        used_min_decisions=20),
    )


@dataclass(frozen=True)
class TrialRecord:
    """What one trial (one task instance) produced."""

    name: str
    """The instance's name (e.g. the opponent team)."""
    rewards: tuple[float, ...]
    """Reward of every learning episode: the learning curve."""
    rollout_success_rate: float
    """Share of successful greedy rollouts of the learnt policy."""
    rollout_mean_reward: float
    """Mean reward of those rollouts."""
    bag_size: int
    """States kept from the successful rollouts."""
    options_offered: int
    """Options the learner could use in this trial."""
    options_used: tuple[int, ...]
    """Option ids the learnt policy used in its greedy rollouts."""
    options_pruned: tuple[int, ...]
    """Option ids pruned at the end of this trial."""
    library_size: int
    """Active options after the refit that closes the trial."""

    @classmethod
    def from_dict(cls, values: object, where: str = "TrialRecord") -> TrialRecord:
        """A record from its JSON form (lists for tuples), every field checked by name."""
        if not isinstance(values, dict):
            raise ValueError(f"{where}: must be an object of TrialRecord fields, got {values!r}")
        check_keys(where, values, RECORD_CONSTRAINTS)
        check_fields(where, values, RECORD_CONSTRAINTS, dict.get)
        return cls(**{
            **values,
            "rewards": tuple(float(r) for r in values["rewards"]),
            "rollout_success_rate": float(values["rollout_success_rate"]),
            "rollout_mean_reward": float(values["rollout_mean_reward"]),
            **{k: tuple(int(o) for o in values[k]) for k in ("options_used", "options_pruned")},
        })


RECORD_CONSTRAINTS = {
    "name": Text(),
    "rewards": ListOf(Real()),
    "rollout_success_rate": Real(0.0, 1.0),
    "rollout_mean_reward": Real(),
    "bag_size": Integer(0),
    "options_offered": Integer(0),
    "options_used": ListOf(Integer(0), unique=True),
    "options_pruned": ListOf(Integer(0), unique=True),
    "library_size": Integer(0),
}
"""What each field of a saved :class:`TrialRecord` may hold."""


def trial_seeds(seed: int, trial: int) -> tuple[int, int, int, int]:
    """Independent seeds (learner, learning env, rollout env, kernels) of one trial."""
    child = np.random.SeedSequence([seed, trial]).generate_state(4, dtype=np.uint32)
    return tuple(int(s) for s in child)  # type: ignore[return-value]


def choice_seed(seed: int, trial: int) -> int:
    """The seed of the episodes a start rule spends choosing among the past policies
    (independent of :func:`trial_seeds`, which keep their values)."""
    return int(np.random.SeedSequence([seed, trial, 1]).generate_state(1, dtype=np.uint32)[0])


class LifelongLearner:
    """ILPSS across a sequence of task instances (Algorithm 1).

    Parameters
    ----------
    config : LifelongConfig
    observation_space : gymnasium.spaces.Box
        The shared state space (1-D, finite bounds): sets the tile coder's range.
    n_primitive : int
        Number of primitive actions (``Discrete(n)``).
    seed : int
        Seeds every trial (see :func:`trial_seeds`).
    provenance : dict, optional
        A JSON record of where this run comes from (an experiment runner puts its
        configuration and job here); saved in every checkpoint and restored by
        :meth:`load`, so that a resume can refuse a checkpoint of another run.

    Attributes
    ----------
    policies : list of FrozenPolicy
        The input policies ``pi_0 .. pi_n`` learnt so far.
    bags : list of numpy.ndarray
        One bag of states per instance (possibly empty).
    library : OptionLibrary or None
        The current options (``None`` before the first extraction, or without options).
    kernel_model : SharedKernelModel, UniformKernel or None
    records : list of TrialRecord
    """

    def __init__(
        self,
        config: LifelongConfig,
        observation_space: Any,
        n_primitive: int,
        seed: int = 0,
        *,
        provenance: dict[str, Any] | None = None,
    ) -> None:
        self.config = config
        check("LifelongLearner n_primitive (the number of primitive actions)", n_primitive,
              STATE_CONSTRAINTS["n_primitive"])
        self.n_primitive = int(n_primitive)
        # Checked here, not by NumPy in the first trial: a float would be truncated.
        check("LifelongLearner seed", seed, STATE_CONSTRAINTS["seed"])
        self.seed = int(seed)
        if provenance is not None and not isinstance(provenance, dict):
            raise ValueError(f"provenance must be a dict or None, got {provenance!r}")
        # A JSON copy: what is saved is exactly what a resume compares with.
        self.provenance = None if provenance is None else json.loads(json.dumps(provenance))
        self.tile_coder = config.learner.tile_coder(observation_space)
        self.policies: list[FrozenPolicy] = []
        self.bags: list[np.ndarray] = []
        self.library: OptionLibrary | None = None
        self.kernel_model: SharedKernelModel | UniformKernel | None = None
        self.records: list[TrialRecord] = []

    @property
    def n_trials(self) -> int:
        """Trials completed."""
        return len(self.records)

    # ------------------------------------------------------------------ learning
    def make_learner(self, seed: int, with_options: bool = True,
                     task: str | None = None) -> SmdpLearner:
        """A fresh SMDP learner offered the current options (or none): those the reuse's
        offer rule gives for the task named ``task``, if it has one and ``task`` is
        given."""
        lc = self.config.learner
        reuse = self.config.reuse
        library = self.library if with_options and reuse.offers_options else None
        if library is not None and reuse.offer is not None and task is not None:
            library = reuse.offer.offer(library, [r.name for r in self.records], task)
        return SmdpLearner(self.n_primitive, self.tile_coder, library, lc, seed=seed)

    def learn(
        self,
        env: Any,
        *,
        trial: int | None = None,
        with_options: bool = True,
        task: str | None = None,
        callback: Callable[[int, EpisodeResult], None] | None = None,
    ) -> tuple[SmdpLearner, list[EpisodeResult]]:
        """Learn on ``env`` for ``train_episodes``, without changing the lifelong state (its
        episodes do add to the option library's usage counts, as every use of an option does).

        ``trial`` (default: the next trial index) chooses the seeds, so learning with
        and without options on the same trial sees the same environment seeds. The
        reuse's start rule sets the learner's initial values first; any episodes it
        spends choosing them are the first of the ``train_episodes`` (its greedy
        episodes seeded apart from the learning episodes, which are the same as without
        them). ``task``, the task's name, is what the reuse's offer rule reads.
        """
        index = self.n_trials if trial is None else checked("trial", trial, TRIAL)
        check_env(env, self.n_primitive, self.tile_coder.n_features,
                  (self.tile_coder.low, self.tile_coder.high))
        learner_seed, env_seed, _, _ = trial_seeds(self.seed, index)
        learner = self.make_learner(learner_seed, with_options, task)
        start = self.config.reuse.start if with_options else Fresh()
        results = learn_with(start, learner, self.policies, env, self.config.train_episodes,
                             seed=env_seed, choice_seed=choice_seed(self.seed, index),
                             callback=callback, bags=self.bags)
        return learner, results

    def run_trial(
        self,
        env: Any,
        name: str,
        callback: Callable[[int, EpisodeResult], None] | None = None,
    ) -> TrialRecord:
        """One full trial: learn, roll out, extract (Algorithm 1, one iteration).

        ``name`` must be a non-empty string (what a checkpoint's record holds); it is
        checked before any episode.
        """
        _check_name(name)
        # Learning counts option starts in the library: a failed trial undoes them too,
        # so that a retry runs as the first try did.
        with self._all_or_nothing():
            learner, results = self.learn(env, task=name, callback=callback)
            return self.extract(env, name, learner, results)

    def extract(
        self, env: Any, name: str, learner: SmdpLearner, results: list[EpisodeResult]
    ) -> TrialRecord:
        """Close a trial: traces, discounting, the new policy, the refit.

        All or nothing: if any step fails (e.g. the kernel fit on degenerate states),
        the lifelong state is put back as it was before, so that a save afterwards
        writes the last complete trial and a retry runs as the first try did.
        """
        _check_name(name)
        # The rollouts count option starts in the library: undone with the rest.
        with self._all_or_nothing():
            return self._close(env, name, learner, results)

    @contextlib.contextmanager
    def _all_or_nothing(self) -> Iterator[None]:
        """The lifelong state put back as it was if the block fails (any exception,
        Ctrl-C included)."""
        undo = self._undo_point()
        try:
            yield
        except BaseException:
            undo()
            raise

    def _close(
        self, env: Any, name: str, learner: SmdpLearner, results: list[EpisodeResult]
    ) -> TrialRecord:
        """:meth:`extract`'s steps, which change the lifelong state as they go."""
        cfg = self.config
        _, _, rollout_seed, kernel_seed = trial_seeds(self.seed, self.n_trials)
        rollouts = learner.evaluate(env, cfg.rollout_episodes, seed=rollout_seed)
        successes = [r for r in rollouts if r.success]
        d = self.tile_coder.n_features
        bag = (
            np.concatenate([np.asarray(r.trace, dtype=float) for r in successes])
            if successes else np.zeros((0, d))
        )
        offered = tuple(int(o) for o in learner.option_ids)
        used = (
            tuple(sorted(options_used(rollouts, min_decisions=cfg.library.used_min_decisions)))
            if offered else ()
        )
        pruned: tuple[int, ...] = ()
        if self.library is not None and offered:
            pruned = self.library.end_trial(used, offered).pruned
        self.policies.append(learner.freeze())
        self.bags.append(bag)
        self._refit(kernel_seed)
        record = TrialRecord(
            name=name,
            rewards=tuple(float(r.total_reward) for r in results),
            rollout_success_rate=len(successes) / max(len(rollouts), 1),
            rollout_mean_reward=float(np.mean([r.total_reward for r in rollouts]))
            if rollouts else 0.0,
            bag_size=len(bag),
            options_offered=len(offered),
            options_used=used,
            options_pruned=pruned,
            library_size=0 if self.library is None else len(self.library),
        )
        self.records.append(record)
        return record

    def _undo_point(self) -> Callable[[], None]:
        """A function that puts the lifelong state back as it is now (the lists in place,
        the library's discounting and pruning undone)."""
        policies, bags, records = list(self.policies), list(self.bags), list(self.records)
        library, model = self.library, self.kernel_model
        undo_library = None if library is None else library.undo_point()

        def undo() -> None:
            self.policies[:] = policies
            self.bags[:] = bags
            self.records[:] = records
            self.library, self.kernel_model = library, model
            if undo_library is not None:
                undo_library()

        return undo

    def _refit(self, kernel_seed: int) -> None:
        """Refit the kernels on all bags and rebuild the library (identities kept)."""
        cfg = self.config
        regions = cfg.reuse.regions
        if regions is None:
            return
        model = regions.fit(self.bags, self.tile_coder.n_features, cfg, kernel_seed)
        if model is None:
            return
        if self.library is None:
            # Policies learnt before any options existed never point to options.
            self.library = OptionLibrary(model, self.policies, cfg.library)
        else:
            known = len(self.library.policies)
            self.library = self.library.refit(model, self.policies[known:])
        self.kernel_model = model

    # --------------------------------------------------------------- checkpoints
    def save(self, directory: str | os.PathLike[str]) -> Path:
        """Write a checkpoint of the whole lifelong state into ``directory``, atomically.

        The checkpoint is built in a fresh sibling folder ``<directory>/trial_<n>`` and
        published by rewriting the small file ``<directory>/LATEST`` atomically, so a
        crash at any point leaves the previous checkpoint intact and current. Older
        checkpoints are removed once the new one is published.

        A folder whose current checkpoint is another run's (another seed, configuration
        or number of primitive actions, or trials that are not this learner's first ones)
        is refused, and nothing in it changes: saving would delete or hide it.
        """
        root = Path(directory)
        if root.exists() and not root.is_dir():
            raise ValueError(f"{root}: exists and is not a folder; a checkpoint is a folder "
                             "(give a new or empty one, or one this run saved to)")
        root.mkdir(parents=True, exist_ok=True)
        # One writer at a time: a second process saving here gets a clear error.
        with locked_folder(root, "checkpoint folder"):
            self._check_same_run(root)
            target = root / f"trial_{self.n_trials:04d}"
            building = root / f".building_{self.n_trials:04d}"
            for stale in _own_entries(root, _BUILDING_NAME):  # left by a crash: no one
                shutil.rmtree(stale, ignore_errors=True)       # else is here
            remove_stale_temporaries(root)
            for own in (target, root / "LATEST"):
                if own.is_symlink():
                    raise ValueError(f"{own}: a symbolic link where this checkpoint folder's "
                                     "own entry belongs; remove it")
            building.mkdir()
            for i, policy in enumerate(self.policies):
                policy.save(building / f"policy_{i}.npz")
            if self.library is not None:
                self.library.save(building / "library")
            save_npz_atomic(
                building / "bags.npz",
                {f"bag_{i}": b for i, b in enumerate(self.bags)},
                {"schema": CHECKPOINT_SCHEMA + "/bags", "n_bags": len(self.bags)},
            )
            # A digest of every file, so a load refuses files mixed from different checkpoints.
            files = {
                p.relative_to(building).as_posix(): sha256_file(p)
                for p in sorted(building.rglob("*")) if p.is_file()
            }
            state = {
                "schema": CHECKPOINT_SCHEMA,
                "files": files,
                "seed": self.seed,
                "n_primitive": self.n_primitive,
                "config": self.config.to_dict(),
                "provenance": self.provenance,
                "kernel": None if self.kernel_model is None else type(self.kernel_model).__name__,
                "records": [asdict(r) for r in self.records],
            }
            atomic_write_bytes(building / "state.json", json_record_bytes(state))
            shutil.rmtree(target, ignore_errors=True)
            os.replace(building, target)
            atomic_write_bytes(root / "LATEST", target.name.encode())
            # Only now that LATEST names the new checkpoint may older ones go: only the
            # checkpoints this class writes (trial_ and digits, real folders), never
            # anything else a user keeps beside them.
            for old in _own_entries(root, _CHECKPOINT_NAME):
                if old.name < target.name:
                    shutil.rmtree(old, ignore_errors=True)
            return target

    def _check_same_run(self, root: Path) -> None:
        """Refuse to save over ``root``'s current checkpoint unless it is an earlier (or
        the same) state of this run: its seed, configuration and primitive actions, and
        its trials this learner's first ones, as they were saved."""
        if not (root / "LATEST").exists():
            return
        try:
            ckpt = latest_checkpoint(root)
            state, config, _ = read_state(ckpt)
        except (OSError, ValueError) as exc:
            raise ValueError(
                f"{root}: holds a checkpoint that cannot be read ({exc}); saving here would "
                "replace it: save into another folder, or remove it first") from None
        n = len(state["records"])
        # the records as saved (JSON), so that a loaded learner's compare equal
        records = json.loads(json.dumps([asdict(r) for r in self.records[:n]]))
        same = {"seed": state["seed"] == self.seed,
                "n_primitive": state["n_primitive"] == self.n_primitive,
                "config": config == self.config, "records": state["records"] == records}
        differs = [key for key, equal in same.items() if not equal]
        if n > len(self.records):
            differs.append(f"{n} trials there against this learner's {len(self.records)}")
        if differs:
            raise ValueError(
                f"{root}: holds another run's checkpoint ({ckpt.name}; it differs from this "
                f"learner in {', '.join(differs)}); saving here would delete or hide it: "
                "save into another folder, or remove it first")

    @classmethod
    def load(
        cls, directory: str | os.PathLike[str], observation_space: Any
    ) -> LifelongLearner:
        """Restore the checkpoint that ``<directory>/LATEST`` names.

        Every field of ``state.json`` is checked (its digest, types and ranges), and so is
        the agreement of the files with one another: records, bags, policies, the option
        library and its kernel model, and the digest of every file. Errors name the file
        and the field.

        Raises
        ------
        FileNotFoundError
            If ``directory`` holds no ``LATEST``.
        ValueError
            For any damaged, modified, inconsistent or mixed-up checkpoint.
        """
        ckpt = latest_checkpoint(directory)
        check_inside(directory, ckpt, "checkpoint folder")
        for path in ckpt.rglob("*"):  # every file read below lies inside the checkpoint
            check_inside(ckpt, path, "checkpoint")
        state, config, records = read_state(ckpt)
        for rel in state["files"]:  # a file gone is damage, as a changed one is (a folder
            path = ckpt / rel         # gone, the option library's, is named below)
            if path.parent.is_dir() and not path.is_file():
                raise ValueError(f"{path}: missing (state.json lists it as a file of this "
                                 "checkpoint)")
        _check_space(config, observation_space, ckpt / "state.json")
        learner = cls(config, observation_space, state["n_primitive"], state["seed"],
                      provenance=state["provenance"])
        learner.records = records
        learner.bags = _read_bags(ckpt, records, learner.tile_coder.n_features)
        learner.policies = _read_policies(learner, ckpt)
        _read_library(learner, ckpt, state["kernel"])
        # Last, so that the errors above say what is wrong; this catches files that
        # load but were mixed in from another checkpoint.
        for rel, digest in state["files"].items():
            path = ckpt / rel
            if not path.is_file() or sha256_file(path) != digest:
                raise ValueError(f"{path}: missing, modified, or from another checkpoint")
        return learner


def bags_archive(n_bags: int, n_features: int) -> ArchiveSchema:
    """What the ``bags.npz`` of a checkpoint of ``n_bags`` trials holds: each trial's bag
    of states, ``(states, n_features)`` finite floats."""
    return ArchiveSchema(
        CHECKPOINT_SCHEMA + "/bags",
        {f"bag_{i}": Field((None, n_features), FLOAT, each=Real()) for i in range(n_bags)},
        record={"n_bags": OneOf((n_bags,))},
    )


def _check_space(config: LifelongConfig, observation_space: Any, where: Path) -> None:
    """The observation space given to a load has the dimension the checkpoint's tile
    widths were set for."""
    low, _ = box_bounds(observation_space)
    widths = config.learner.tile_widths
    if widths is not None and len(widths) != len(low):  # not a fault of the settings
        raise ValueError(
            f"{where}: the checkpoint was saved for a {len(widths)}-feature observation "
            f"space (its LearnerConfig.tile_widths has {len(widths)} entries), but the "
            f"observation space given is {observation_space!r}, with {len(low)}: load it "
            "with the space it was learnt on"
        )


def _read_bags(ckpt: Path, records: list[TrialRecord], n_features: int) -> list[np.ndarray]:
    """The bags of a checkpoint, one per record and of the size it names."""
    path = ckpt / "bags.npz"
    arrays = load_archive(path, bags_archive(len(records), n_features)).arrays
    bags = [arrays[f"bag_{i}"] for i in range(len(records))]
    for i, (bag, record) in enumerate(zip(bags, records, strict=True)):
        if len(bag) != record.bag_size:
            raise ValueError(
                f"{path}: bag_{i} holds {len(bag)} states, but records[{i}].bag_size in "
                f"{ckpt / 'state.json'} is {record.bag_size}"
            )
    return bags


def _read_policies(learner: LifelongLearner, ckpt: Path) -> list[FrozenPolicy]:
    """The policies of a checkpoint, each on the learner's tile coder and actions, and
    choosing among the options its record says it was offered."""
    where = ckpt / "state.json"
    policies = []
    for i, record in enumerate(learner.records):
        path = ckpt / f"policy_{i}.npz"
        policy = FrozenPolicy.load(path)
        policies.append(policy)
        if policy.tile_coder != learner.tile_coder:
            raise ValueError(
                f"{path}: its tile coder is not the one the checkpoint's configuration "
                "and observation space give"
            )
        if policy.n_primitive != learner.n_primitive:
            raise ValueError(
                f"{path}: {policy.n_primitive} primitive actions, but n_primitive in "
                f"{where} is {learner.n_primitive}"
            )
        if len(policy.option_ids) != record.options_offered:
            raise ValueError(
                f"{path}: chooses among {len(policy.option_ids)} options, but "
                f"records[{i}].options_offered in {where} is {record.options_offered}"
            )
    return policies


def _read_library(learner: LifelongLearner, ckpt: Path, kernel: str | None) -> None:
    """Give ``learner`` the option library of a checkpoint (by its reuse's kernel
    loader), if the state names a kernel model; refuse a library where none is named,
    or a missing one."""
    where = ckpt / "state.json"
    library = ckpt / "library"
    if (kernel is None) == library.is_dir():
        raise ValueError(
            f"{ckpt}: the option library is missing (the state names a {kernel} kernel "
            "model)" if kernel is not None else
            f"{ckpt}: holds an option library, but kernel in {where} is null"
        )
    regions = learner.config.reuse.regions
    records = learner.records
    if kernel is not None and regions is not None:  # read_state: its model
        learner.library = OptionLibrary.load(library, kernel_loader=regions.load)
        learner.kernel_model = learner.library.kernel_model
        _check_library(learner, ckpt)
    elif records and records[-1].library_size:
        raise ValueError(
            f"{where}: records[{len(records) - 1}].library_size is "
            f"{records[-1].library_size} without an option library"
        )


def _check_name(name: object) -> None:
    """The rule a saved record's name must meet, applied before a trial is run."""
    check("the trial name", name, RECORD_CONSTRAINTS["name"])


_CHECKPOINT_NAME = re.compile(r"trial_\d{4,}")
_BUILDING_NAME = re.compile(r"\.building_\d{4,}")
_LATEST_BYTES = 64
_FILE_NAME = re.compile(r"(policy_\d+|bags|library/(kernels|library|policy_\d+))\.npz")
STATE_CONSTRAINTS = {
    "seed": Integer(0),
    "n_primitive": Integer(1),
    "kernel": NoneOr(Name()),  # and the model that the configuration's reuse builds
}
"""What the scalar fields of ``state.json`` may hold (``config`` is a LifelongConfig,
``records`` TrialRecords, ``files`` the digests, ``provenance`` an object or null)."""


def latest_checkpoint(directory: str | os.PathLike[str]) -> Path:
    """The checkpoint folder that ``<directory>/LATEST`` names (checked for form)."""
    root = Path(directory)
    latest = root / "LATEST"
    if latest.is_dir():
        raise ValueError(f"{latest}: a folder, where the file naming the checkpoint belongs")
    try:
        data = read_regular(latest, _LATEST_BYTES, "the file naming the checkpoint")
    except FileNotFoundError:
        raise FileNotFoundError(f"no checkpoint in {root} (no LATEST file)") from None
    name = data.decode("ascii", errors="replace").strip()
    if not _CHECKPOINT_NAME.fullmatch(name):
        # Its content is not echoed: LATEST may name, or be, any file of the machine.
        raise ValueError(f"{latest}: does not name a checkpoint (trial_ and 4 or more digits)")
    return root / name


def _own_entries(root: Path, name: re.Pattern[str]) -> list[Path]:
    """The entries of ``root`` whose names are this module's own (``name``), and that are
    real folders: a symbolic link is never followed into, whatever its name."""
    return [p for p in root.iterdir()
            if name.fullmatch(p.name) and p.is_dir() and not p.is_symlink()]


def read_state(checkpoint: Path) -> tuple[dict[str, Any], LifelongConfig, list[TrialRecord]]:
    """``state.json`` of a checkpoint folder, every field checked: the record, its
    configuration and its trial records (array files are not read)."""
    where = checkpoint / "state.json"
    try:
        state = load_json_record(where, CHECKPOINT_SCHEMA)
    except (FileNotFoundError, NotADirectoryError) as exc:
        raise ValueError(f"{where}: unreadable checkpoint state: {exc}") from exc
    check_keys(str(where), state, {"schema", "files", "seed", "n_primitive", "config",
                                   "provenance", "kernel", "records"})
    check_fields(str(where), state, STATE_CONSTRAINTS, dict.get)
    try:
        config = LifelongConfig.from_dict(state["config"])
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: config: {exc}") from exc
    if state["provenance"] is not None and not isinstance(state["provenance"], dict):
        raise ValueError(f"{where}: provenance must be an object or null")
    if not isinstance(state["records"], list):
        raise ValueError(f"{where}: records must be a list of trial records")
    records = [TrialRecord.from_dict(r, f"{where}: records[{i}]")
               for i, r in enumerate(state["records"])]
    n = len(records)
    if checkpoint.name != f"trial_{n:04d}":
        raise ValueError(
            f"{checkpoint}: holds {n} trial records, but its name says {checkpoint.name}"
        )
    kernel = config.reuse.model_name
    if state["kernel"] not in (None, kernel):
        raise ValueError(
            f"{where}: kernel {state['kernel']!r} is not what options={config.options!r} "
            f"builds ({kernel!r})"
        )
    rollouts = config.rollout_episodes
    for i, r in enumerate(records):
        field = f"{where}: records[{i}]"
        if len(r.rewards) != config.train_episodes:
            raise ValueError(
                f"{field}.rewards has {len(r.rewards)} values, but the configuration's "
                f"train_episodes is {config.train_episodes}"
            )
        successes = r.rollout_success_rate * max(rollouts, 1)
        if abs(successes - round(successes)) > 1e-6 or (round(successes) == 0) != (
            r.bag_size == 0
        ):
            raise ValueError(
                f"{field}.rollout_success_rate {r.rollout_success_rate!r} is not a share of "
                f"{rollouts} rollouts consistent with bag_size {r.bag_size}"
            )
        if (i == 0 or not config.reuse.offers_options) and r.options_offered:
            raise ValueError(f"{field}.options_offered must be 0 (no options to offer yet)")
    files = state["files"]
    expected = {f"policy_{i}.npz" for i in range(n)} | {"bags.npz"}
    if not (isinstance(files, dict) and all(
        isinstance(k, str) and _FILE_NAME.fullmatch(k) and isinstance(v, str)
        for k, v in files.items()
    ) and expected <= set(files)):
        raise ValueError(
            f"{where}: files must map every file of the checkpoint (policy_<i>.npz, "
            f"bags.npz, library/...) to its SHA-256"
        )
    listed = any(k.startswith("library/") for k in files)
    if (state["kernel"] is None) == listed:
        raise ValueError(
            f"{where}: kernel is {state['kernel']!r}, but files "
            f"{'list' if listed else 'do not list'} an option library"
        )
    return state, config, records


def _check_library(learner: LifelongLearner, ckpt: Path) -> None:
    """The option library of a checkpoint agrees with its policies and records."""
    lib = learner.library
    assert lib is not None
    where = ckpt / "library" / "library.npz"
    if len(lib.policies) > len(learner.policies):
        raise ValueError(
            f"{where}: {len(lib.policies)} policies, more than the checkpoint's "
            f"{len(learner.policies)}"
        )
    for i, policy in enumerate(lib.policies):
        mine = learner.policies[i]
        if policy.tile_coder != mine.tile_coder or policy.option_ids != mine.option_ids or \
                not np.array_equal(policy.weights, mine.weights):
            raise ValueError(f"{where}: its policy {i} is not the checkpoint's policy_{i}.npz")
    last = learner.records[-1]
    if last.library_size != len(lib):
        raise ValueError(
            f"{ckpt / 'state.json'}: records[{len(learner.records) - 1}].library_size is "
            f"{last.library_size}, but the library holds {len(lib)} active options"
        )
    for i, record in enumerate(learner.records):
        unknown = sorted(set(record.options_used + record.options_pruned) - set(lib.registry))
        if unknown:
            raise ValueError(
                f"{ckpt / 'state.json'}: records[{i}] names option ids {unknown} that the "
                "library never issued"
            )

