"""Where a records store lives: its URL, and the SQLite file behind a path."""

import contextlib
import os
import stat
import urllib.parse
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.limits import file_type
from accelcal.validation import shown, shown_path

DEFAULT_DB_ENV = "ACCELCAL_DB"


def default_url() -> str:
    """The default store: ``$ACCELCAL_DB``, else an SQLite file in the user data directory.

    The data directory is ``$XDG_DATA_HOME/accelcal`` (``~/.local/share/accelcal``
    when unset).
    """
    if os.environ.get(DEFAULT_DB_ENV):
        return store_url(os.environ[DEFAULT_DB_ENV])
    base = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
    return f"sqlite:///{base / 'accelcal' / 'records.sqlite'}"


def store_url(db: str | os.PathLike | None) -> str:
    """A database URL from a URL, an SQLite file path, or None (the default store)."""
    if db is None:
        return default_url()
    text = os.fspath(db)
    if "://" in text:
        return text
    try:
        return f"sqlite:///{Path(text).resolve()}"
    except (OSError, ValueError) as exc:
        raise AccelcalError(f"the store path {shown(text)} cannot be used: {exc}") from None


def check_sqlite_path(path: Path) -> None:
    """Refuse an SQLite store path that exists and is not a regular file.

    Checked before SQLite opens it: SQLite would block for ever on a FIFO,
    and beside a device such as ``/dev/zero`` it would make its journal
    (``/dev/zero-journal``) and find an empty database.

    Raises
    ------
    AccelcalError
        Naming the path and what it is (a directory, a FIFO, a device).
    """
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise AccelcalError(
            f"cannot use the records store {shown_path(path)}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise AccelcalError(
            f"the records store {shown_path(path)} is a directory; give a file name")
    if not stat.S_ISREG(mode):
        raise AccelcalError(
            f"the records store {shown_path(path)} is {file_type(mode)}, not a regular file; "
            "give an SQLite file (new or existing) or a database URL")


def prepare_sqlite_file(path: Path) -> bool:
    """Make the directory of an SQLite store; return whether the file is new.

    Raises
    ------
    AccelcalError
        If ``path`` is a directory or its directory cannot be made.
    """
    try:
        if path.is_dir():
            raise AccelcalError(
                f"the records store {shown_path(path)} is a directory; give a file name")
        new = not path.exists()
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccelcalError(
            f"cannot create the records store {shown_path(path)}: {exc.strerror or exc}; "
            "choose a writable location"
        ) from None
    return new


def store_exists(path: Path) -> bool:
    """Whether an SQLite store file exists (an unusable path is refused)."""
    try:
        return path.exists()
    except OSError as exc:
        raise AccelcalError(
            f"cannot read the records store {shown_path(path)}: {exc.strerror or exc}") from None


def remove_sqlite_files(path: Path) -> None:
    """Remove an SQLite file this process created, with its journal files."""
    for suffix in ("", "-journal", "-wal", "-shm"):
        with contextlib.suppress(OSError):
            os.unlink(f"{path}{suffix}")


def connect_readonly(path: Path):
    """A read-only SQLite connection to ``path``.

    ``mode=ro`` first; where SQLite cannot read that way because it cannot
    create the shared-memory file of a write-ahead-logged store (read-only
    media), ``immutable=1``: nothing can change such a store while it is read.
    """
    import sqlite3

    uri = f"file:{urllib.parse.quote(str(path))}?mode=ro"
    conn = sqlite3.connect(uri, uri=True, timeout=60)
    try:
        conn.execute("SELECT count(*) FROM sqlite_master").fetchone()
    except sqlite3.OperationalError as exc:
        conn.close()
        if "readonly" not in str(exc) and "unable to open" not in str(exc):
            raise
        conn = sqlite3.connect(uri + "&immutable=1", uri=True, timeout=60)
    return conn
