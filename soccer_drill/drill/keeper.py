"""pymunk spaces freed where no signal handler can cut the freeing.

pymunk frees a space, and each of its bodies and shapes, in a cffi finaliser written in
Python; cffi prints and ignores an exception raised there. A body and a shape each hold a
handle to themselves, so they are freed by the cyclic garbage collector, at whatever
point of the program it runs. A signal handler that raises (a Ctrl-C, a wall-clock
bound's ``SIGALRM``, ``sys.exit()`` in a ``SIGTERM`` handler) and runs in such a
finaliser is lost, and a space freed half-way leaves bodies pointing into freed memory:
a later collection aborts the process ("Aborting due to Chipmunk error") or crashes it.

So the drill's spaces are held here, each under its owner (a
:class:`~soccer_drill.drill.spaces.DrillSpace` or
:class:`~soccer_drill.drill.spaces.BatchPhysics`) and a slot, until the owner replaces
it (:func:`keep`) or is gone. They are freed only inside
:class:`~soccer_drill.interruptions.SignalsDeferred`, by the owner's next replacement or
by the next :func:`keep` of any owner (called where a space is built, inside it) (a space whose owner is gone waits for it): the
space first (it lets go of its bodies and shapes), then each body and shape, their
self-handles dropped so that reference counting frees them there and then rather than a
later garbage collection.
"""

from __future__ import annotations

import weakref

import pymunk

_kept: dict[tuple[int, int], tuple[weakref.ref, pymunk.Space]] = {}
_SELF_HANDLES = ("_data_handle", "_h")  # pymunk's Body and Shape: handles to themselves


def keep(owner: object, slot: int, space: pymunk.Space) -> None:
    """Hold ``space`` as ``owner``'s ``slot``, freeing the space held there before and
    every space whose owner is gone. Called inside
    :class:`~soccer_drill.interruptions.SignalsDeferred` (where the owner builds the
    space). The owner keeps no other reference to a space it replaces (its step function
    included)."""
    key = (id(owner), slot)
    doomed = [key] if key in _kept else []
    doomed += [k for k, (ref, _) in _kept.items() if ref() is None and k != key]
    spaces = [_kept.pop(k)[1] for k in doomed]
    _kept[key] = (weakref.ref(owner), space)
    del space
    _free(spaces)


def kept_spaces() -> int:
    """How many spaces are held (those of owners gone included, until the next :func:`keep`)."""
    return len(_kept)


def _free(spaces: list[pymunk.Space]) -> None:
    """Free each of ``spaces`` (popped from the list, so that nothing else holds it):
    the space, then its bodies and shapes."""
    while spaces:
        space = spaces.pop()
        objects = [*space.bodies, space.static_body, *space.shapes]
        del space  # pymunk's finaliser runs here: the bodies and shapes leave the space
        for obj in objects:
            state = getattr(obj, "__dict__", {})
            for name in _SELF_HANDLES:
                state.pop(name, None)
        objects.clear()  # each body and shape freed here
