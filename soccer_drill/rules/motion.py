"""The skills' rules, written once for one drill: a command becomes a desired velocity and,
for the ball holder, a ball action.

Every function here reads one drill's arrays, ``pos`` and ``vel`` (``(players + 1, 2)``
float64: the attackers, the defenders, then the ball, as
:attr:`~soccer_drill.state.DrillState.pos`; ``attackers`` says where the defenders
start) or its records (:mod:`soccer_drill.rules.arrays`), and is compiled per drill
(:mod:`soccer_drill.rules.compiled`). The drill's cycle runs them for each of its drills;
teams call them (:func:`interception_points` and :func:`mark_targets` for many drills at
once); :mod:`soccer_drill.skills` offers them on a :class:`~soccer_drill.state.DrillState`.
The numbers they need of a :class:`~soccer_drill.config.DrillConfig` are its rule
parameters, read by name (:func:`~soccer_drill.rules.arrays.rule_parameters`), and the
rolling ball's table (:func:`~soccer_drill.rules.arrays.roll_table`).
"""

from __future__ import annotations

import math

import numpy as np

from soccer_drill.commands import Skill
from soccer_drill.config import DrillConfig
from soccer_drill.interruptions import QuietIntEnum
from soccer_drill.rules.arrays import roll_table, rule_parameters
from soccer_drill.rules.compiled import compiled, hypot


class BallAction(QuietIntEnum):
    """What a player's motion does with the ball: nothing, keep it at the control point,
    or kick it."""

    NO_BALL = 0
    CONTROL = 1
    KICK = 2


_NO_BALL, _CONTROL, _KICK = (int(a) for a in BallAction)  # as compiled code stores them
GUARD_DEPTH = 2.5
"""Distance from the goal line at which ``GUARD_LINE`` stands, in metres."""
MARK_FRACTION = 0.35
"""``MARK`` stands this fraction of the way from the free opponent to the ball."""
_ARRIVE_SECONDS = 0.3  # slow down this long before a target, so players do not orbit it
_HOLD_EDGE = 3.0  # a shielding holder stops backing away this close to a touchline
_LEAD_SECONDS = 1.5  # how far ahead a defender aims at a dribbling holder


def _heading(deg: int) -> tuple[float, float, float]:
    """Unit heading ``deg`` degrees off straight down the field, and its initial score."""
    a = math.radians(deg)
    return math.sin(a), -math.cos(a), math.cos(a)


HEADINGS = tuple(_heading(deg) for deg in range(-70, 71, 10))
"""The dribbling headings tried, in order: ``(hx, hy, initial score)``."""
# (position in HEADINGS, hx, hy, initial score), highest initial score first.
_HEADINGS_BY_SCORE = np.array(sorted(
    ((order, *heading) for order, heading in enumerate(HEADINGS)),
    key=lambda item: (-item[3], item[0]),
))
_HEADINGS_BY_SCORE.flags.writeable = False


@compiled
def unit(x, y):
    """``(x, y)`` made a unit vector (straight down the field if it is tiny)."""
    n = hypot(x, y)
    if n > 1e-9:
        return x / n, y / n
    return 0.0, -1.0


@compiled
def opponents_range(player, attackers, players):
    """``(first, stop)``: the indices of ``player``'s opponents, ``range(first, stop)``."""
    if player < attackers:
        return attackers, players
    return 0, attackers


@compiled
def interception_point(pos, vel, holder, player, vmax, params, table):
    """Earliest point of the rolling ball's path that ``player`` can reach in time (a
    carried ball: where it will be when ``player`` gets there), running at ``vmax``."""
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    bvx, bvy = vel[ball, 0], vel[ball, 1]
    px, py = pos[player, 0], pos[player, 1]
    if holder >= 0 and holder != player:
        # Aim where a carried ball will be when we get there, so chasers do not trail.
        lead = hypot(bx - px, by - py) / vmax if vmax > 0 else 0.0
        if _LEAD_SECONDS < lead:  # min(lead, _LEAD_SECONDS), as min() compares
            lead = _LEAD_SECONDS
        return bx + vel[holder, 0] * lead, by + vel[holder, 1] * lead
    ball_speed = hypot(bvx, bvy)
    if ball_speed < 1.0 or holder >= 0:
        return bx, by
    last = table.shape[1] - 1
    reach, spacing = params[0].control_radius, params[0].roll_spacing
    # The first point of the table within reach, as a scan of every point finds it, but
    # skipping points that cannot be: after a point the gap (the distance to the ball's
    # point less the reach) shrinks per second by at most vmax plus the ball's speed
    # there (it only slows down), and by vmax alone once the ball rolls away from the
    # player. The bound is widened far beyond rounding errors.
    vmax_step = vmax * spacing * (1.0 + 1e-9)
    speed_bound = ball_speed * (1.0 + 1e-9)
    k = 0
    while True:
        travelled = table[1, k]
        x, y = bx + bvx * travelled, by + bvy * travelled
        dx, dy = x - px, y - py
        r = vmax * table[0, k] + reach
        d2 = dx * dx + dy * dy
        if d2 <= r * r or k == last:
            return x, y
        gap = math.sqrt(d2) - r - 1e-9 * (r + 1.0)
        if dx * bvx + dy * bvy >= 0.0:  # rolling away: no nearer from here on
            closing = vmax_step
        else:
            closing = speed_bound * table[2, k] + vmax_step
        if gap <= closing:
            k += 1
        elif gap >= closing * (last - k):  # none left can be reached: the last point
            k = last
        else:
            k += math.ceil(gap / closing)


@compiled
def support_spot(pos, player, size, attackers):
    """Where an off-ball attacker gets open: wide of the ball and a little ahead of it."""
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    side = 1.0 if pos[player, 0] >= bx else -1.0
    if not 3.0 <= bx + side * 11.0 <= size - 3.0:
        side = -side
    lo, hi = 2.0, size - 2.0  # each clamp min(max(v, lo), hi), as the builtins compare
    tx, ty = bx + side * 11.0, by - 3.0
    tx = lo if tx < lo else hi if tx > hi else tx
    ty = lo if ty < lo else hi if ty > hi else ty
    # Step away from an opponent standing on the spot.
    first, stop = opponents_range(player, attackers, ball)
    for d in range(first, stop):
        dx, dy = tx - pos[d, 0], ty - pos[d, 1]
        dist = hypot(dx, dy)
        if dist < 5.0:
            ux, uy = unit(dx, dy)
            tx += ux * (5.0 - dist)
            ty += uy * (5.0 - dist)
    lo, hi = 1.0, size - 1.0
    return (lo if tx < lo else hi if tx > hi else tx), (lo if ty < lo else hi if ty > hi else ty)


@compiled
def dribble_heading(pos, player, size, attackers):
    """Unit heading toward the goal line that keeps clear of opponents and touchlines.

    The candidate with the highest score wins, the first in :data:`HEADINGS`' order among
    equals. A candidate's score is its initial score less penalties, so candidates are
    tried from the highest initial score down, and the search stops once no candidate
    left could reach the best score found.
    """
    px, py = pos[player, 0], pos[player, 1]
    best_x, best_y, best_score, best_order = 0.0, -1.0, -math.inf, len(HEADINGS)
    first, stop = opponents_range(player, attackers, pos.shape[0] - 1)
    headings = _HEADINGS_BY_SCORE
    for h in range(headings.shape[0]):
        order, hx, hy, score = headings[h, 0], headings[h, 1], headings[h, 2], headings[h, 3]
        if score < best_score:
            break
        # Each opponent ahead within 12 m costs more the closer it is to the heading line.
        for d in range(first, stop):
            rx, ry = pos[d, 0] - px, pos[d, 1] - py
            ahead = rx * hx + ry * hy
            if 0.0 < ahead < 12.0:
                free = 1.0 - abs(rx * hy - ry * hx) / 4.0
                score -= 2.0 * (free if free > 0.0 else 0.0) * (1.0 - ahead / 12.0)
        ex = px + hx * 4.0
        if not 1.0 <= ex <= size - 1.0:
            score -= 3.0
        if score > best_score or (score == best_score and order < best_order):
            best_x, best_y, best_score, best_order = hx, hy, score, order
    return best_x, best_y


@compiled
def shield_direction(pos, player, attackers):
    """Unit direction away from the nearest opponent: where a shielded ball is kept."""
    px, py = pos[player, 0], pos[player, 1]
    first, stop = opponents_range(player, attackers, pos.shape[0] - 1)
    x1, y1 = pos[first, 0], pos[first, 1]
    for d in range(first + 1, stop):
        x2, y2 = pos[d, 0], pos[d, 1]
        if hypot(x2 - px, y2 - py) < hypot(x1 - px, y1 - py):  # the first if equal
            x1, y1 = x2, y2
    return unit(px - x1, py - y1)


@compiled
def nearest_teammate(pos, player, attackers):
    """``player``'s nearest teammate (the lowest index among equals), or -1: none."""
    first, stop = (0, attackers) if player < attackers else (attackers, pos.shape[0] - 1)
    px, py = pos[player, 0], pos[player, 1]
    best, best_d = -1, 0.0
    for m in range(first, stop):
        if m == player:
            continue
        d = hypot(pos[m, 0] - px, pos[m, 1] - py)
        if best < 0 or d < best_d:
            best, best_d = m, d
    return best


@compiled
def players_by_distance(pos, first, stop, skip, sx, sy, order, dist):
    """Players ``first .. stop - 1`` but ``skip`` by their distance to ``(sx, sy)`` into
    ``order`` (their indices) and ``dist`` (their distances), nearest first, the lower
    index first among equals (an insertion sort); returns how many there are. ``order``
    and ``dist`` hold at least as many."""
    count = 0
    for j in range(first, stop):
        if j == skip:
            continue
        d = hypot(pos[j, 0] - sx, pos[j, 1] - sy)
        k = count
        while k > 0 and dist[k - 1] > d:
            order[k], dist[k] = order[k - 1], dist[k - 1]
            k -= 1
        order[k], dist[k] = j, d
        count += 1
    return count


@compiled
def teammates_by_distance(pos, player, attackers, order, dist):
    """``player``'s teammates by distance into ``order`` (their indices) and ``dist``
    (their distances), nearest first, the lower index first among equals
    (:func:`players_by_distance`); returns how many there are."""
    first, stop = (0, attackers) if player < attackers else (attackers, pos.shape[0] - 1)
    return players_by_distance(pos, first, stop, player, pos[player, 0], pos[player, 1],
                               order, dist)


@compiled
def in_cone(ax, ay, bx, by, px, py, width):
    """Whether ``(px, py)`` lies in the cone from ``a`` to ``b`` whose half-width grows by
    ``width`` per metre along it (between the two ends): a pass from ``a`` to ``b`` that
    a player at ``p`` can block."""
    dx, dy = bx - ax, by - ay
    length = hypot(dx, dy)
    if length < 1e-9:
        return False
    along = ((px - ax) * dx + (py - ay) * dy) / length
    if along <= 0.0 or along > length:
        return False
    across = abs((px - ax) * dy - (py - ay) * dx) / length
    return across <= width * along


@compiled
def ranked_teammate(pos, player, attackers, rank):
    """``player``'s teammate of ``rank`` (0: the nearest) by distance, the lower index
    first among equals; -1 if it has fewer teammates."""
    order = np.empty(4, np.int64)
    dist = np.empty(4)
    count = teammates_by_distance(pos, player, attackers, order, dist)
    return order[rank] if 0 <= rank < count else -1


@compiled
def pass_velocity(pos, vel, player, mate, angle_normal, speed_normal, params):
    """Kick velocity that brings the ball to teammate ``mate`` at about arrival speed, with
    ``angle_normal`` and ``speed_normal`` (standard normals) as its noise."""
    ball = pos.shape[0] - 1
    bx, by = pos[ball, 0], pos[ball, 1]
    mx, my = pos[mate, 0], pos[mate, 1]
    p = params[0]
    k, arrival, top = p.damping_rate, p.arrival_speed, p.ball_max_speed
    dist = hypot(mx - bx, my - by)
    rate = arrival + k * dist
    lead = dist / (rate if rate > 1e-6 else 1e-6)  # rough travel time
    tx, ty = mx + vel[mate, 0] * lead, my + vel[mate, 1] * lead
    dist = hypot(tx - bx, ty - by)
    speed = arrival + k * dist
    speed = top if top < speed else speed
    angle = math.atan2(ty - by, tx - bx) + p.angle_noise * angle_normal
    speed = speed * (1.0 + p.speed_noise * speed_normal)
    speed = speed if speed > 0.0 else 0.0
    speed = top if top < speed else speed
    return speed * math.cos(angle), speed * math.sin(angle)


@compiled
def free_opponent(pos, holder, player, attackers):
    """The opponent of ``player`` to mark: of those without the ball, the nearest to
    ``player`` while an opponent holds it, else the farthest from the ball (the later
    index among equals). With two opponents: the one without the ball, or for a loose
    ball (or one a teammate holds) the one farther from it."""
    ball = pos.shape[0] - 1
    first, stop = opponents_range(player, attackers, ball)
    if stop - first == 1:
        return first
    px, py = pos[player, 0], pos[player, 1]
    bx, by = pos[ball, 0], pos[ball, 1]
    held = first <= holder < stop
    best, best_d = -1, 0.0
    for k in range(first, stop):
        if k == holder:
            continue
        if held:
            d = hypot(pos[k, 0] - px, pos[k, 1] - py)
            if best < 0 or d < best_d:
                best, best_d = k, d
        else:
            d = hypot(pos[k, 0] - bx, pos[k, 1] - by)
            if best < 0 or d >= best_d:
                best, best_d = k, d
    return best


@compiled
def mark_target(pos, holder, player, fraction, attackers):
    """``fraction`` of the way from ``player``'s free opponent to the ball."""
    free = free_opponent(pos, holder, player, attackers)
    fx, fy = pos[free, 0], pos[free, 1]
    ball = pos.shape[0] - 1
    return fx + fraction * (pos[ball, 0] - fx), fy + fraction * (pos[ball, 1] - fy)


@compiled
def motion(state, cycle, player, params, table):
    """Player ``player``'s command in one drill (``state`` and ``cycle``: its records) as
    ``(vx, vy, ball action, bx, by)``: the desired velocity, and for the holder's ball
    skill the ball action with its vector (the kick's velocity, or the direction the ball
    is kept in). A ball skill of a player not holding the ball stands still."""
    pos, vel, holder = state.pos, state.vel, state.holder
    skill, speed = cycle.skill[player], cycle.speed[player]
    tx, ty = cycle.target[player, 0], cycle.target[player, 1]
    p = params[0]
    attackers = p.attackers
    is_attacker = player < attackers
    top = p.attacker_speed if is_attacker else p.defender_speed
    vmax = top * speed
    px, py = pos[player, 0], pos[player, 1]
    size = p.field_size
    if skill <= Skill.DRIBBLE:  # a ball skill
        if player != holder:
            return 0.0, 0.0, _NO_BALL, 0.0, 0.0
        if skill == Skill.DRIBBLE:
            hx, hy = dribble_heading(pos, player, size, attackers)
            v = p.dribble_speed * speed
            return hx * v, hy * v, _CONTROL, hx, hy
        if skill == Skill.PASS:
            mate = cycle.receiver[player]
            if mate < 0 or mate >= attackers or mate == player:
                mate = nearest_teammate(pos, player, attackers)
            if mate < 0:  # no teammate to pass to: stands still, as a ball skill off the ball
                return 0.0, 0.0, _NO_BALL, 0.0, 0.0
            kx, ky = pass_velocity(pos, vel, player, mate, cycle.noise[0], cycle.noise[1],
                                   params)
            return 0.0, 0.0, _KICK, kx, ky
        sx, sy = shield_direction(pos, player, attackers)  # HOLD
        v = p.hold_speed * speed
        vx, vy = sx * v, sy * v
        # Shielding backs away from pressure, but never over a touchline.
        lo, hi = _HOLD_EDGE, size - _HOLD_EDGE
        if (px < lo and vx < 0) or (px > hi and vx > 0):
            vx = 0.0
        if (py < lo and vy < 0) or (py > hi and vy > 0):
            vy = 0.0
        # Nor is the ball kept over a touchline or the far end (or, without a goal line,
        # the near end): near one, it is kept along the line instead (else a pressing
        # defender simply pushes it out of the region).
        if (px < lo and sx < 0) or (px > hi and sx > 0):
            sx, sy = 0.0, (1.0 if sy > 0 else -1.0)
        if (py > hi and sy > 0) or (p.goal_line == 0 and py < lo and sy < 0):
            sx, sy = (1.0 if sx > 0 else -1.0), 0.0
        return vx, vy, _CONTROL, sx, sy
    if skill == Skill.GET_OPEN:
        tx, ty = support_spot(pos, player, size, attackers)
    elif skill == Skill.GO_TO_BALL or skill == Skill.INTERCEPT:
        tx, ty = interception_point(pos, vel, holder, player, vmax, params, table)
    elif skill == Skill.MARK:
        tx, ty = mark_target(pos, holder, player, MARK_FRACTION, attackers)
    elif skill == Skill.GUARD_LINE:
        x = pos[pos.shape[0] - 1, 0]
        x = 4.0 if x < 4.0 else x  # min(max(x, 4.0), size - 4.0), as the builtins compare
        tx, ty = (size - 4.0 if size - 4.0 < x else x), GUARD_DEPTH
    # Toward the target at most vmax, slowing on arrival.
    dx, dy = tx - px, ty - py
    dist = hypot(dx, dy)
    if dist < 1e-6:
        return 0.0, 0.0, _NO_BALL, 0.0, 0.0
    run = dist / _ARRIVE_SECONDS
    if not run < vmax:  # min(vmax, run), as min() compares
        run = vmax
    return dx / dist * run, dy / dist * run, _NO_BALL, 0.0, 0.0


@compiled
def motions_into(state, cycle, params, table):
    """:func:`motion` of every player of one drill, into ``cycle.motions``."""
    out = cycle.motions
    for k in range(out.shape[0]):
        vx, vy, ball, bx, by = motion(state, cycle, k, params, table)
        out[k, 0] = vx
        out[k, 1] = vy
        out[k, 2] = ball
        out[k, 3] = bx
        out[k, 4] = by


# ------------------------------------------------------------------ many drills
@compiled
def _interception_points(out, pos, vel, holder, vmax, params, table):
    for i in range(pos.shape[0]):
        for k in range(pos.shape[1] - 1):
            x, y = interception_point(pos[i], vel[i], holder[i], k, vmax[i, k], params, table)
            out[i, k, 0] = x
            out[i, k, 1] = y


def interception_points(
    pos: np.ndarray, vel: np.ndarray, holder: np.ndarray, vmax: np.ndarray, cfg: DrillConfig
) -> np.ndarray:
    """:func:`interception_point` of each player of each drill (``pos``, ``vel``:
    ``(n, players + 1, 2)``; ``vmax``: ``(n, players)``, each player's running speed):
    ``(n, players, 2)``."""
    out = np.empty((len(pos), pos.shape[1] - 1, 2))
    _interception_points(out, _floats(pos), _floats(vel), _ints(holder), _floats(vmax),
                         rule_parameters(cfg), roll_table(cfg))
    return out


@compiled
def _mark_targets(out, pos, holder, fraction, attackers):
    for i in range(pos.shape[0]):
        for k in range(pos.shape[1] - 1):
            x, y = mark_target(pos[i], holder[i], k, fraction, attackers)
            out[i, k, 0] = x
            out[i, k, 1] = y


def mark_targets(pos: np.ndarray, holder: np.ndarray, fraction: float = MARK_FRACTION,
                 attackers: int = 2) -> np.ndarray:
    """:func:`mark_target` of each player of each drill (``pos``: ``(n, players + 1, 2)``,
    the first ``attackers`` of them attackers): ``(n, players, 2)``."""
    out = np.empty((len(pos), pos.shape[1] - 1, 2))
    _mark_targets(out, _floats(pos), _ints(holder), float(fraction), int(attackers))
    return out


def _floats(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _ints(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)
