"""How many drills, and frames of them, fit in the memory available: the batched
environments' checks of ``num_envs`` and of rendering, before anything is built."""

from __future__ import annotations

from soccer_drill.config import DrillConfig
from soccer_drill.constraints import Integer, checked
from soccer_drill.rendering.batch import frame_bytes

DRILL_BYTES = 32 * 1024
"""An upper estimate of one drill's memory in a batch (measured at 13-23 KiB a drill from
64 drills on, 42 KiB in the first small batch of a process: docs/benchmarks.md)."""


def available_memory() -> int | None:
    """Bytes this process can still take: the smaller of the system's available memory
    and what its cgroup's limit leaves (``None`` where neither can be read)."""
    found = []
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as limit, \
                open("/sys/fs/cgroup/memory.current", encoding="ascii") as current:
            text = limit.read().strip()
            if text != "max":
                found.append(max(0, int(text) - int(current.read().strip())))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_num_envs(num_envs: object) -> int:
    """``num_envs`` as an int, or ``ValueError`` saying what is allowed: an integer in
    [1, 1,000,000] whose drills fit in the memory available (at :data:`DRILL_BYTES` a drill;
    beyond it the process is killed, or crashes inside pymunk, while it builds them)."""
    n = checked("num_envs", num_envs, Integer(1, 1_000_000))
    available = available_memory()
    if available is not None and n * DRILL_BYTES > available:
        raise ValueError(
            f"num_envs={n} needs about {n * DRILL_BYTES / 2**20:,.0f} MiB (up to "
            f"{DRILL_BYTES // 1024} KiB a drill), more than the {available / 2**20:,.0f} MiB "
            f"of memory available; at most {available // DRILL_BYTES:,} drills fit now"
        )
    return n


def check_frames_fit(n: int, config: DrillConfig) -> None:
    """``ValueError`` if ``n`` drills and their frames do not fit in the memory available
    (:func:`available_memory`): ``render()`` returns ``n`` frames at once, and draws each
    through one more (so ``n + 1``), besides the drills themselves (:data:`DRILL_BYTES`
    each). Nothing is checked where the memory available cannot be read (imports pygame,
    for the frames' size)."""
    available = available_memory()
    if available is None:
        return
    each, (width, height) = frame_bytes(config)
    drill = DRILL_BYTES
    needed = n * drill + (n + 1) * each
    if needed > available:
        fit = max(0, (available - each) // (drill + each))
        raise ValueError(
            f"num_envs={n} with render_mode='rgb_array' needs about {needed / 2**20:,.0f} MiB: "
            f"{n} drills (up to {drill // 1024} KiB each) and their frames ({n + 1} of {width} "
            f"x {height} pixels, {each / 2**20:.2f} MiB each, render() returns them together), "
            f"more than the {available / 2**20:,.0f} MiB of memory available; at most {fit:,} "
            "drills fit now with their frames (or draw fewer: a HolderEnv draws one drill, "
            "also as a video)"
        )


def check_frames_memory(n: int, config: DrillConfig) -> None:
    """``RuntimeError`` if ``render()``'s ``n`` frames (returned at once, and one more while
    drawing) do not fit in the memory available now: the check that
    :class:`~soccer_drill.rendering.batch.BatchRenderer` makes before it draws."""
    available = available_memory()
    if available is not None:
        each, (width, height) = frame_bytes(config)
        if (n + 1) * each > available:
            raise RuntimeError(
                f"render() of {n} drills needs about {(n + 1) * each / 2**20:,.1f} MiB for "
                f"their frames ({n + 1} of {width} x {height} pixels, {each / 2**20:.2f} MiB "
                f"each), more than the {available / 2**20:,.1f} MiB of memory available "
                f"now; at most {max(0, available // each - 1):,} frames fit"
            )
