"""A writer that fails as a full disk does, for the tests of what a command keeps."""

from __future__ import annotations

import errno
from collections.abc import Callable
from pathlib import Path


def full_disk(write: Callable[[Path, bytes], None] | None = None,
              at: Callable[[Path], bool] = lambda path: True) -> Callable[[Path, bytes], None]:
    """``write`` (an ``atomic_write_bytes``), failing with ``ENOSPC`` naming the file for
    every path where ``at`` holds; with no ``write``, every write fails."""

    def writing(path: Path, data: bytes) -> None:
        if write is None or at(Path(path)):
            raise OSError(errno.ENOSPC, f"cannot write {path}: No space left on device",
                          str(path))
        write(path, data)

    return writing
