"""The batched drill's shortcuts against the plain computations they skip or replace."""

from __future__ import annotations

import numpy as np
import pytest

import soccer_drill
from soccer_drill.drill.drills import BatchDrill
from soccer_drill.drill.spaces import BatchPhysics
from soccer_drill.rules.arrays import Outcome
from soccer_drill.rules.cycle import outcome, reward

RUNNING, SUCCESS, INTERCEPTION, OUT, TIMEOUT = Outcome


def test_the_direct_chipmunk_step_moves_the_players_as_space_step_does():
    cfg = soccer_drill.DrillConfig()
    direct, plain = BatchPhysics(40, cfg, 16), BatchPhysics(40, cfg, 16)
    assert all(step is not space.step for step, space in zip(direct._steps, direct.spaces, strict=True))
    plain._steps = [space.step for space in plain.spaces]
    rng = np.random.default_rng(0)
    pos = rng.uniform(2.0, cfg.field_size - 2.0, size=(40, 5, 2))
    pos[:, 1] = pos[:, 0] + 0.3  # players pressed together: contacts to solve
    for _ in range(30):
        vel = rng.normal(0.0, 5.0, size=(40, 5, 2))
        a = direct.cycle(pos, vel, None).copy()
        np.testing.assert_array_equal(a, plain.cycle(pos, vel, None))
        pos[:, :4] = np.clip(a[..., :2], 0.5, cfg.field_size - 0.5)


def _random_states(batch: BatchDrill, rng: np.random.Generator) -> None:
    size, n = batch.config.field_size, batch.n
    edges = np.array([-0.1, 0.0, 1e-12, 5.0, size - 1e-12, size, size + 0.1, np.nan])
    batch.pos[:, 4] = rng.choice(edges, size=(n, 2)) if rng.random() < 0.5 else rng.uniform(
        0.5, size - 0.5, size=(n, 2))
    quiet = rng.random(n) < (1.0 if rng.random() < 0.3 else 0.8)
    batch.pos[quiet, 4] = rng.uniform(0.5, size - 0.5, size=(int(quiet.sum()), 2))
    rare = 0.05 if rng.random() < 0.7 else 0.0  # else no drill near an end but by its ball
    batch.holder[:] = rng.choice([-1, 0, 1, 2, 3], size=n, p=[0.3, 0.35 - rare, 0.35 - rare, rare, rare])
    batch.cycle[:] = rng.choice([0, 5, batch.config.max_cycles - 1, batch.config.max_cycles], size=n,
                                p=[0.3, 0.7 - 2 * rare, rare, rare])


@pytest.mark.parametrize("n", [1, 3, 64])
def test_the_batched_rewards_are_those_of_the_active_drills_that_ended(n):
    batch, rng = BatchDrill(n), np.random.default_rng(n)
    cfg = batch.config
    seen = set()
    for _ in range(500):
        _random_states(batch, rng)
        active = rng.random(n) < 0.7
        codes = [outcome(batch.pos[i], int(batch.holder[i]), int(batch.cycle[i]),
                         cfg.field_size, cfg.max_cycles, cfg.attackers, 1) for i in range(n)]
        batch.outcome[:] = codes
        batch.attacker_reward[:] = 0.0
        batch._rewards(active)
        for i in range(n):
            expected = codes[i] if active[i] else RUNNING
            ended_with = reward(expected, float(batch.pos[i, 4, 0]), cfg) if expected else 0.0
            assert batch.attacker_reward[i] == ended_with
            seen.add(expected)
    assert seen == {RUNNING, SUCCESS, INTERCEPTION, OUT, TIMEOUT}


@pytest.mark.parametrize("shared", [False, True])
def test_the_legality_test_says_what_the_action_masks_say(shared):
    from soccer_drill.vector.agents import ParallelVectorEnv, is_legal

    venv = ParallelVectorEnv(num_envs=32, opponent=None, shared_spaces=shared)
    obs, _ = venv.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(40):
        masks = venv.action_masks()
        for agent, i in venv._index.items():
            n_actions = venv.action_space(agent).n
            for a in range(n_actions):
                actions = np.full(32, a)
                np.testing.assert_array_equal(
                    is_legal(actions, venv._core.batch.holder, i), masks[agent][:, a] == 1)
        obs, *_ = venv.step({a: (rng.random(m.shape) * m).argmax(1) for a, m in masks.items()})


def test_a_frames_pixels_are_the_surfaces_as_surfarray_reads_them():
    import pygame

    from soccer_drill.envs.holder import HolderEnv
    from soccer_drill.rendering.draw import surface_pixels

    env = HolderEnv(opponent="interceptors_cover", render_mode="rgb_array")
    env.reset(seed=3)
    env.step(2)
    frame = env.render()
    surface = pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2)))
    plain = np.ascontiguousarray(np.transpose(pygame.surfarray.array3d(surface), (1, 0, 2)))
    np.testing.assert_array_equal(surface_pixels(surface), plain)
    np.testing.assert_array_equal(frame, plain)
    assert frame.flags.writeable and frame.dtype == np.uint8
    env.close()


def test_a_gif_of_few_colours_is_written_with_its_exact_colours(tmp_path):
    from PIL import Image

    from soccer_drill.rendering.gif import palette_images, save_gif

    rng = np.random.default_rng(0)
    colours = rng.integers(0, 256, size=(200, 3), dtype=np.uint8)
    frames = [colours[rng.integers(0, 200, size=(30, 40))] for _ in range(5)]
    save_gif(frames, tmp_path / "a.gif", fps=8)
    image = Image.open(tmp_path / "a.gif")
    back = []
    for i in range(image.n_frames):
        image.seek(i)
        back.append(np.asarray(image.convert("RGB")))
    assert len(back) == len(frames)
    for a, b in zip(frames, back, strict=True):
        np.testing.assert_array_equal(a, b)
    many = [rng.integers(0, 256, size=(30, 40, 3), dtype=np.uint8)]  # > 256 colours
    assert palette_images(many) is None
    save_gif(many, tmp_path / "b.gif", fps=8)  # quantized by Pillow instead
    assert Image.open(tmp_path / "b.gif").size == (40, 30)
