"""The observations of :mod:`soccer_drill.features` for many drills at once.

The same formulas as :func:`~soccer_drill.features.features` and
:func:`~soccer_drill.features.kinematics`, in the same order of operations, on
``(N, 5, 2)`` position arrays; clipped into the same bounds.
"""

from __future__ import annotations

import numpy as np

from soccer_drill.config import DrillConfig

_DEGREES = 180.0 / np.pi
_OPPONENTS = np.array([[2, 3], [2, 3], [0, 1], [0, 1]])


def _angle(cx: np.ndarray) -> np.ndarray:
    return _DEGREES * np.arccos(np.clip(cx, -1.0, 1.0))


def batch_features(
    pos: np.ndarray, player: np.ndarray, cfg: DrillConfig, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """The 9 features of ``player[i]`` in drill ``i`` (``(N, 9)`` float32, clipped)."""
    rows = np.arange(len(pos))
    s = pos[rows, player]
    m = pos[rows, player ^ 1]
    o1 = pos[rows, _OPPONENTS[player, 0]]
    o2 = pos[rows, _OPPONENTS[player, 1]]
    sx, sy = s[:, 0], s[:, 1]
    ax, ay = o1[:, 0] - sx, o1[:, 1] - sy
    bx, by = o2[:, 0] - sx, o2[:, 1] - sy
    ux, uy = m[:, 0] - sx, m[:, 1] - sy
    da, db, dm = np.hypot(ax, ay), np.hypot(bx, by), np.hypot(ux, uy)
    near, far = np.minimum(da, db), np.maximum(da, db)  # (da, db) if da <= db else (db, da)
    ma, mb = np.hypot(ax - ux, ay - uy), np.hypot(bx - ux, by - uy)
    mate_opp = np.where(mb < ma, mb, ma)
    da_ok, db_ok, dm_ok = da >= 1e-9, db >= 1e-9, dm >= 1e-9
    safe_a, safe_b = np.where(da_ok, da, 1.0), np.where(db_ok, db, 1.0)
    safe_am = np.where(da_ok & dm_ok, dm * da, 1.0)
    safe_bm = np.where(db_ok & dm_ok, dm * db, 1.0)
    pa = np.where(da_ok & dm_ok, _angle((ux * ax + uy * ay) / safe_am), 180.0)
    pb = np.where(db_ok & dm_ok, _angle((ux * bx + uy * by) / safe_bm), 180.0)
    ga = np.where(da_ok, _angle(-ay / safe_a), 180.0)
    gb = np.where(db_ok, _angle(-by / safe_b), 180.0)
    raw = np.stack(
        (dm, near, far, mate_opp, np.where(pb < pa, pb, pa), sy, sx - cfg.field_size / 2,
         m[:, 1], np.where(gb < ga, gb, ga)),
        axis=1,
    )
    return np.minimum(np.maximum(raw, low), high).astype(np.float32)


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
