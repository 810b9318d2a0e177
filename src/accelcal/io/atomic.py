"""Atomic file writing: a file appears whole or not at all.

Every file accelcal writes (records, calibration records, model files,
reports, figures) goes through :func:`atomic_path`: the content is written
to a temporary file beside the target, flushed to the disk, and moved over
the target in one step. A target that exists and is not a regular file (a
directory, a FIFO, a device such as ``/dev/full``, or a link to one) is
refused before anything is written. A failure at any point (a missing or
read-only directory, a full disk, a location such as ``/proc``
where no file can be made) raises :class:`~accelcal.errors.AccelcalError`
naming the file and what to do, leaves an existing file as it was and
removes the temporary file.

A new file gets the permissions ``0o666`` less the process umask, like any
file a program creates (``-rw-r--r--`` under the usual umask 022); a file
that is replaced keeps its permissions.
"""

import contextlib
import errno
import os
import secrets
import stat
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.limits import file_type
from accelcal.validation import shown_path

_ADVICE = {
    errno.EACCES: "permission denied; choose a location you can write to",
    errno.EPERM: "permission denied; choose a location you can write to",
    errno.EROFS: "the file system is read-only; choose a writable location",
    errno.ENOSPC: "no space left on the device; free some space or write elsewhere",
    errno.EDQUOT: "the disk quota is exhausted; free some space or write elsewhere",
    errno.EISDIR: "it is a directory; give a file name",
    errno.ENAMETOOLONG: "the file name is too long; choose a shorter name",
    errno.ENOENT: "no file can be created there; choose another location",
}


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; move it into place on success.

    The block writes the temporary file (it exists, empty); when the block
    ends normally the file is flushed to the disk and renamed to ``path``.
    If anything fails the temporary file is removed, so a failed write
    leaves nothing on disk and an existing ``path`` unchanged. A ``path``
    that exists and is not a regular file (a directory, a FIFO, a device,
    or a link to one) is refused before anything is written.

    Raises
    ------
    AccelcalError
        If ``path`` is a directory or another special file (or a link to
        one), its directory does not exist, or the
        file cannot be created, written or moved into place (permissions, a
        read-only file system, a full disk, ...); the message names
        ``path`` and what to do. Exceptions of the block other than
        :class:`OSError` pass unchanged.
    """
    target = Path(path)
    tmp = None
    try:
        _check_target(target)
        tmp = _create_beside(target)
        yield tmp
        _flush_to_disk(tmp)
        os.replace(tmp, target)
    except OSError as exc:
        _remove(tmp)
        advice = _ADVICE.get(exc.errno, f"{exc.strerror or exc}; choose another location")
        raise AccelcalError(f"cannot write {shown_path(target)}: {advice}") from None
    except BaseException:
        _remove(tmp)
        raise


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _check_target(target: Path) -> None:
    """Refuse a target in a missing directory, or one that exists and is not a regular file.

    A directory, a FIFO, a device (``/dev/full``) or a socket, or a link to
    one, is refused before anything is written: renaming the new file over
    it would replace the special file itself (run as root, the system's
    ``/dev/full`` would become a regular file).
    """
    if not target.parent.is_dir():
        raise AccelcalError(
            f"cannot write {shown_path(target)}: directory {shown_path(target.parent)} does "
            "not exist; create it first or choose another location"
        )
    if target.is_dir():
        raise AccelcalError(f"cannot write {shown_path(target)}: {_ADVICE[errno.EISDIR]}")
    try:
        info = os.stat(target)
    except FileNotFoundError:  # a new file (or a link to nothing, which is replaced)
        return
    if not stat.S_ISREG(info.st_mode):
        raise AccelcalError(
            f"cannot write {shown_path(target)}: it is {file_type(info.st_mode)}, not a regular "
            "file; give the name of a file to write"
        )


def _create_beside(target: Path) -> Path:
    """Create an empty, new temporary file in ``target``'s directory.

    Created with mode 0o666, so the kernel applies the umask; given the
    permissions of ``target`` when it exists, so a replaced file keeps them.
    """
    while True:
        tmp = target.with_name(f".{target.name[:200]}.{secrets.token_hex(6)}.tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue
        try:
            with contextlib.suppress(FileNotFoundError):
                info = os.stat(target)
                if stat.S_ISREG(info.st_mode):
                    os.fchmod(fd, stat.S_IMODE(info.st_mode))
        except BaseException:
            os.close(fd)
            _remove(tmp)
            raise
        os.close(fd)
        return tmp


def _flush_to_disk(tmp: Path) -> None:
    """Fsync ``tmp``, so a full disk is reported now and a crash cannot leave it empty."""
    fd = os.open(tmp, os.O_RDONLY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _remove(tmp: Path | None) -> None:
    if tmp is not None:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
