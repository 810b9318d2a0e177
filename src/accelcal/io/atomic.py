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

Temporary files and directories carry the writer's process id
(``.NAME.accelcal-<pid>-<hex>.tmp``, :func:`temp_name`; a name that would
pass the file system's limit is shortened to a hash), so that a run killed
where it cannot clean up (SIGKILL, a power cut) leaves nothing for good: the
next run that writes in the same directory removes those whose process is
gone (:func:`sweep`). Those of the running process are listed
(:data:`LIVE`), so that an exit forced by a signal removes them too.
"""

import contextlib
import errno
import hashlib
import os
import re
import secrets
import shutil
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
    errno.EFBIG: "the file is larger than this process may write (a file-size limit); "
                 "raise the limit or write less",
    errno.ENOTDIR: "a part of the path is not a directory; choose another location",
    errno.ELOOP: "the path has too many symbolic links (a loop?); choose another location",
    errno.EXDEV: "it cannot be moved there from the staging directory; write elsewhere",
}

NAME_MAX = 255
"""Longest file name (bytes) most file systems take; the directory's own limit is asked."""

LIVE: set[Path] = set()
"""Temporary files and directories of this process not yet moved into place or removed."""

_OURS = re.compile(r"^\..+\.accelcal-(\d+)-[0-9a-f]{12}(?:\.tmp|\.f64)?$")
"""A temporary of accelcal's (:func:`temp_name`): ``.NAME.accelcal-<pid>-<12 hex digits>``,
then ``.tmp`` (a file being written), ``.f64`` (a noise phase file) or nothing (a directory)."""

_SWEPT: set[str] = set()
"""Directories already swept by this process."""


def write_error(path, exc: OSError) -> AccelcalError:
    """The one-line error of a write to ``path`` that failed with ``exc``: the path and advice."""
    advice = _ADVICE.get(exc.errno, f"{exc.strerror or exc}; choose another location")
    return AccelcalError(f"cannot write {shown_path(path)}: {advice}")


def temp_name(name: str, suffix: str = ".tmp", *, directory=".", prefix: str = ".") -> str:
    """A new temporary name for ``name``: ``<prefix>NAME.accelcal-<pid>-<hex><suffix>``.

    When that would be longer than the directory's file-name limit (a valid
    name of 238-255 bytes), ``NAME`` is replaced by a 16-digit hash of it.
    """
    tag = f"accelcal-{os.getpid()}-{secrets.token_hex(6)}{suffix}"
    full = f"{prefix}{name}.{tag}"
    if len(os.fsencode(full)) <= _name_max(directory):
        return full
    return f"{prefix}{hashlib.sha256(os.fsencode(name)).hexdigest()[:16]}.{tag}"


def _name_max(directory) -> int:
    try:
        return min(int(os.pathconf(directory, "PC_NAME_MAX")), NAME_MAX)
    except (OSError, ValueError):
        return NAME_MAX


def sweep(directory) -> int:
    """Remove accelcal's temporaries in ``directory`` whose process is gone; how many.

    Once per directory and process; only entries named as :func:`temp_name`
    names them and owned by this user; a process id that is alive (even reused by
    another program) keeps its entry.
    """
    key = os.fspath(directory)
    if key in _SWEPT:
        return 0
    _SWEPT.add(key)
    removed = 0
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return 0
    for entry in entries:
        match = _OURS.match(entry.name)
        if not match or int(match.group(1)) == os.getpid() or _alive(int(match.group(1))):
            continue
        try:
            if entry.stat(follow_symlinks=False).st_uid != os.getuid():
                continue
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
            removed += 1
        except OSError:
            continue
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # another user's process, or a number no process can have
    return True


def remove_live() -> None:
    """Remove every temporary of this process (an exit forced by a signal)."""
    for path in list(LIVE):
        _remove(path)


def check_output(path) -> Path:
    """The one check of an output path before any work: refuse what cannot be written.

    A missing directory, a path that exists and is not a regular file (a
    directory, a FIFO, a device, or a link to one), or one the system
    refuses to look at (a name too long, a loop of links, no permission to
    search the directory) is refused with one line naming the path.

    Raises
    ------
    AccelcalError
    """
    target = Path(path)
    try:
        _check_target(target)
    except OSError as exc:
        raise write_error(target, exc) from None
    return target


@contextlib.contextmanager
def temp_directory(parent, name: str):
    """A new directory in ``parent`` named by :func:`temp_name`, removed at the end.

    Made with mode 0o777, so it has the permissions the umask gives any new
    directory; listed in :data:`LIVE` while it exists.
    """
    sweep(parent)
    path = Path(parent) / temp_name(name, "", directory=parent)
    os.mkdir(path, 0o777)
    LIVE.add(path)
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
        LIVE.discard(path)


@contextlib.contextmanager
def atomic_path(path, *, flush: bool = True):
    """Yield a temporary path beside ``path``; move it into place on success.

    The block writes the temporary file (it exists, empty); when the block
    ends normally the file is flushed to the disk (not with ``flush=False``:
    a scratch file read back at once and removed) and renamed to ``path``.
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
        sweep(target.parent)
        tmp = _create_beside(target)
        yield tmp
        if flush:
            _flush_to_disk(tmp)
        os.replace(tmp, target)
        LIVE.discard(tmp)
    except OSError as exc:
        _remove(tmp)
        raise write_error(target, exc) from None
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
        tmp = target.with_name(temp_name(target.name, directory=target.parent))
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue
        LIVE.add(tmp)
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
            if os.path.isdir(tmp) and not os.path.islink(tmp):
                shutil.rmtree(tmp)
            else:
                os.unlink(tmp)
        LIVE.discard(tmp)
