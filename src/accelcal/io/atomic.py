"""Atomic file writing: a file appears whole or not at all."""

import contextlib
import os
import tempfile
from pathlib import Path

from accelcal.errors import AccelcalError


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; move it into place on success.

    The temporary file is removed if the block raises, so a failed write
    leaves nothing on disk.

    Raises
    ------
    AccelcalError
        If the target's directory does not exist.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise AccelcalError(f"cannot write {target}: directory {target.parent} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
