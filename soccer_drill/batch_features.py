"""The observations of :mod:`soccer_drill.features` for many drills at once.

The same formulas as :func:`~soccer_drill.features.features` and
:func:`~soccer_drill.features.kinematics`, in the same order of operations, on
``(N, 5, 2)`` position arrays; clipped into the same bounds.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.batch_skills import rows
from soccer_drill.config import DrillConfig

_DEGREES = 180.0 / np.pi
_OPPONENTS = np.array([[2, 3], [2, 3], [0, 1], [0, 1]])


def _angle(cx: np.ndarray) -> np.ndarray:
    return _DEGREES * np.arccos(np.minimum(np.maximum(cx, -1.0), 1.0))  # clip, without its wrapper


def batch_features(
    pos: np.ndarray, player: np.ndarray, cfg: DrillConfig, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """The 9 features of ``player[i]`` in drill ``i`` (``(N, 9)`` float32, clipped)."""
    r = rows(len(pos))
    return _features(pos[r, player], pos[r, player ^ 1], pos[r, _OPPONENTS[player, 0]],
                     pos[r, _OPPONENTS[player, 1]], cfg, low, high)


def players_features(
    pos: np.ndarray, players: tuple[int, ...], cfg: DrillConfig, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """The 9 features of each of ``players`` in every drill: ``(N, len(players), 9)``,
    in one pass (the cost of one player's, not of one per player)."""
    p = np.asarray(players)
    return _features(pos[:, p], pos[:, p ^ 1], pos[:, _OPPONENTS[p, 0]], pos[:, _OPPONENTS[p, 1]],
                     cfg, low, high)


def _features(
    s: np.ndarray, m: np.ndarray, o1: np.ndarray, o2: np.ndarray, cfg: DrillConfig,
    low: np.ndarray, high: np.ndarray,
) -> np.ndarray:
    """:func:`~soccer_drill.features.features` from the positions (``(..., 2)``) of the
    player, its mate and its two opponents."""
    a, b, u = o1 - s, o2 - s, m - s  # opponents and mate relative to self
    ax, ay, bx, by, ux, uy = a[..., 0], a[..., 1], b[..., 0], b[..., 1], u[..., 0], u[..., 1]
    da, db, dm = np.hypot(ax, ay), np.hypot(bx, by), np.hypot(ux, uy)
    am, bm = a - u, b - u
    ma, mb = np.hypot(am[..., 0], am[..., 1]), np.hypot(bm[..., 0], bm[..., 1])
    da_ok, db_ok, dm_ok = da >= 1e-9, db >= 1e-9, dm >= 1e-9
    pa_ok, pb_ok = da_ok & dm_ok, db_ok & dm_ok
    pa = np.where(pa_ok, _angle((ux * ax + uy * ay) / np.where(pa_ok, dm * da, 1.0)), 180.0)
    pb = np.where(pb_ok, _angle((ux * bx + uy * by) / np.where(pb_ok, dm * db, 1.0)), 180.0)
    ga = np.where(da_ok, _angle(-ay / np.where(da_ok, da, 1.0)), 180.0)
    gb = np.where(db_ok, _angle(-by / np.where(db_ok, db, 1.0)), 180.0)
    raw = np.empty((*s.shape[:-1], 9))
    np.minimum(da, db, out=raw[..., 1])  # near, far: (da, db) if da <= db else (db, da)
    np.maximum(da, db, out=raw[..., 2])
    raw[..., 0] = dm
    np.minimum(ma, mb, out=raw[..., 3])  # mb if mb < ma else ma
    np.minimum(pa, pb, out=raw[..., 4])
    raw[..., 5] = s[..., 1]
    np.subtract(s[..., 0], cfg.field_size / 2, out=raw[..., 6])
    raw[..., 7] = m[..., 1]
    np.minimum(ga, gb, out=raw[..., 8])
    np.maximum(raw, low, out=raw)
    np.minimum(raw, high, out=raw)
    return raw.astype(np.float32)


def batch_kinematics(
    pos: np.ndarray,
    vel: np.ndarray,
    holder: np.ndarray,
    passer_locked: np.ndarray,
    player: int,
    low: np.ndarray,
    high: np.ndarray,
) -> np.ndarray:
    """The 26-value egocentric kinematic observation of ``player`` in every drill."""
    n = len(pos)
    s, sv = pos[:, player], vel[:, player]
    others = (player ^ 1, *_OPPONENTS[player], 4)
    parts = [s, sv]
    for j in others:
        parts += [pos[:, j] - s, vel[:, j] - sv]
    opponent_holds = (holder >= 0) & ((holder >= 2) != (player >= 2))
    flags = np.stack(
        (holder == player, holder == player ^ 1, opponent_holds, holder < 0,
         np.full(n, player < 2), passer_locked == player),
        axis=1,
    ).astype(np.float64)
    raw = np.concatenate((*parts, flags), axis=1)
    return np.minimum(np.maximum(raw, low), high).astype(np.float32)


def batch_global_state(batch: object, cfg: DrillConfig, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """:func:`~soccer_drill.features.global_state` of every drill of ``batch`` (a
    :class:`~soccer_drill.batch.BatchDrill`): ``(N, 29)`` float32, clipped."""
    pos, vel = batch.pos, batch.vel  # type: ignore[attr-defined]
    holder, passer = batch.holder, batch.passer  # type: ignore[attr-defined]
    cycle, lockout_until = batch.cycle, batch.lockout_until  # type: ignore[attr-defined]
    n = len(pos)
    values = np.empty((n, 29))
    bodies = values[:, :20].reshape(n, 5, 4)
    bodies[..., :2] = pos
    bodies[..., 2:] = vel
    values[:, 20:24] = holder[:, None] == _PLAYERS
    values[:, 24:28] = (cycle < lockout_until)[:, None] & (passer[:, None] == _PLAYERS)
    values[:, 28] = cycle / cfg.max_cycles
    return np.minimum(np.maximum(values.astype(np.float32), low), high)


_PLAYERS = np.arange(4)
