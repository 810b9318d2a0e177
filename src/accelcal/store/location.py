"""Where a records store lives: its address, and the SQLite file behind a path.

An address is a path or a URL. A path is taken literally: ``%``, ``?`` and
``#`` are characters of the file name (a path never goes through URL
parsing), a leading ``~`` is the home directory, and a blank one is
refused. A URL needs an explicit scheme followed by ``://``
(``sqlite:///records.sqlite``, ``postgresql+psycopg://user@host/db``);
``file:x.db`` (an SQLite URI filename) and ``sqlite:x.db`` are refused,
naming what to give instead.
"""

import contextlib
import errno
import os
import re
import shutil
import stat
import tempfile
import urllib.parse
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.limits import file_type
from accelcal.validation import shown, shown_path

DEFAULT_DB_ENV = "ACCELCAL_DB"

_URL = re.compile(r"[A-Za-z][A-Za-z0-9+.\-]*://")
"""The start of a URL: a scheme and ``://``."""

_SCHEMES = {"file", "sqlite", "postgresql", "postgres", "mysql", "mariadb", "oracle", "mssql"}
"""Schemes that, without ``//`` after the colon, are an address mistyped (not a file name)."""


def default_url() -> str:
    """The default store: ``$ACCELCAL_DB``, else an SQLite file in the user data directory.

    The data directory is ``$XDG_DATA_HOME/accelcal`` (``~/.local/share/accelcal``
    when unset).
    """
    return store_url(None)


def store_url(db: str | os.PathLike | None) -> str:
    """A database URL from a URL, an SQLite file path, or None (the default store)."""
    return store_address(db)[0]


def store_address(db: str | os.PathLike | None) -> tuple[str, Path | None]:
    """The URL of a store and, for an SQLite file, its path.

    Parameters
    ----------
    db : str or path-like or None
        A URL with an explicit scheme, a path, or None: ``$ACCELCAL_DB``
        (set and not empty), else ``records.sqlite`` in the user data
        directory.

    Returns
    -------
    url : str
        ``sqlite:///<absolute path>`` for a path (for messages: connect
        through the path, not the URL, which would read ``%`` and ``?``).
    path : Path or None
        The SQLite file (absolute, ``~`` expanded), None for another database
        or an in-memory SQLite one.

    Raises
    ------
    AccelcalError
        For a blank address, a scheme without ``//`` (``file:x.db``) or an
        unusable path.
    """
    source = "--db"
    if db is None:
        env = os.environ.get(DEFAULT_DB_ENV)
        if env is None or env == "":
            base = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
            path = base / "accelcal" / "records.sqlite"
            return f"sqlite:///{path}", path
        db, source = env, f"${DEFAULT_DB_ENV}"
    text = os.fspath(db)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text.strip():
        raise AccelcalError(f"the store address ({source}) {shown(text)} is blank; give an "
                            "SQLite file path or a database URL")
    if _URL.match(text):
        return text, _sqlite_url_path(text)
    scheme, colon, _ = text.partition(":")
    if colon and scheme.split("+")[0].lower() in _SCHEMES:
        raise AccelcalError(
            f"the store address ({source}) {shown(text)} is neither a path nor a URL with "
            f"'{scheme}://': give a file path (e.g. records.sqlite) or a URL such as "
            "sqlite:///records.sqlite or postgresql+psycopg://user@host/db")
    try:
        path = Path(os.path.abspath(os.path.expanduser(text)))
    except (OSError, ValueError) as exc:
        raise AccelcalError(f"the store path {shown(text)} cannot be used: {exc}") from None
    return f"sqlite:///{path}", path


def _sqlite_url_path(url: str) -> Path | None:
    """The file of an ``sqlite://`` URL (None for another database or an in-memory one)."""
    import sqlalchemy as sa

    try:
        parsed = sa.make_url(url)
    except (sa.exc.ArgumentError, ValueError):
        return None  # refused with the address's message when the store opens
    if parsed.get_backend_name() != "sqlite" or parsed.database in (None, "", ":memory:"):
        return None
    return Path(os.path.abspath(os.path.expanduser(parsed.database)))


def check_sqlite_path(path: Path) -> None:
    """Refuse an SQLite store path that exists and is not a regular file.

    Checked before SQLite opens it: SQLite would block for ever on a FIFO,
    and beside a device such as ``/dev/zero`` it would make its journal
    (``/dev/zero-journal``) and find an empty database. A symbolic link
    loop is named as such.

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
        reason = exc.strerror or exc
        if exc.errno == errno.ELOOP:
            reason = "a loop of symbolic links"
        raise AccelcalError(
            f"cannot use the records store {shown_path(path)}: {reason}") from None
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


def check_sqlite_tables(path: Path, where: str) -> None:
    """Refuse, before writing anything, an existing SQLite file that is not a records store.

    Read through a read-only connection: a writable one would switch
    another application's database to write-ahead logging.

    Raises
    ------
    AccelcalError
        For another application's database (:func:`accelcal.store.schema.refuse_foreign`)
        or a file that is not a database.
    """
    import sqlite3

    from accelcal.store.schema import refuse_foreign

    try:
        if not path.exists() or path.stat().st_size == 0:
            return
        conn = connect(path, readonly=True)
        try:
            names = {r[0] for r in conn.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            conn.close()
    except (OSError, sqlite3.Error) as exc:
        reason = " ".join(str(getattr(exc, "strerror", None) or exc).split())
        raise AccelcalError(f"cannot open the records store {where}: {reason}") from None
    refuse_foreign(names, where)


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


def connect(path: Path, *, readonly: bool = False, immutable: bool = False):
    """An SQLite connection to the file ``path``, named literally (a URI with it quoted)."""
    import sqlite3

    uri = f"file:{urllib.parse.quote(str(path))}"
    if readonly:
        uri += "?mode=ro" + ("&immutable=1" if immutable else "")
    return sqlite3.connect(uri, uri=True, timeout=60)


class ReadonlyFile:
    """How to read an SQLite store without writing to it: connections, and cleaning up.

    ``mode=ro`` first. Where SQLite cannot read that way because it cannot
    create the shared-memory file of a write-ahead-logged store (read-only
    media), a store with no write-ahead log (or an empty one) is read with
    ``immutable=1``: nothing can change such a store while it is read. One
    whose log holds transactions is copied with its log to a temporary
    directory and read there, so that no committed record is hidden (with
    ``immutable=1`` SQLite would ignore the log); when the copy fails, the
    store is refused.

    Parameters
    ----------
    path : Path
        The store file (it exists).
    shown : str
        The store, as messages name it.

    Raises
    ------
    AccelcalError
        For a file that is not a database, or a log that cannot be copied.
    """

    def __init__(self, path: Path, shown: str) -> None:
        import sqlite3

        self.path, self.immutable, self.copy = path, False, None
        try:
            self._probe(path)
        except sqlite3.Error as exc:
            reason = " ".join(str(exc).split())
            if "readonly" not in reason and "unable to open" not in reason:
                raise AccelcalError(f"cannot open the records store {shown}: {reason}"
                                    ) from None
            wal = Path(f"{path}-wal")
            if not (wal.exists() and wal.stat().st_size > 0):
                self.immutable = True
                return
            self.copy = self._copied(path, wal, shown)
            self.path = Path(self.copy) / path.name

    @staticmethod
    def _probe(path: Path) -> None:
        conn = connect(path, readonly=True)
        try:
            conn.execute("SELECT count(*) FROM sqlite_master").fetchone()
        finally:
            conn.close()

    @staticmethod
    def _copied(path: Path, wal: Path, shown: str) -> str:
        """A temporary directory holding the store and its write-ahead log."""
        directory = tempfile.mkdtemp(prefix=f"accelcal-store-{os.getpid()}-")
        try:
            shutil.copyfile(path, Path(directory) / path.name)
            shutil.copyfile(wal, Path(directory) / wal.name)
        except OSError as exc:
            shutil.rmtree(directory, ignore_errors=True)
            raise AccelcalError(
                f"cannot read the records store {shown}: its write-ahead log {wal.name} holds "
                "transactions that SQLite cannot read here without writing (no shared-memory "
                f"file beside it), and copying it to read it failed ({exc.strerror or exc}); "
                "read it where it can be written"
            ) from None
        return directory

    def connect(self):
        """A new read-only connection."""
        return connect(self.path, readonly=True, immutable=self.immutable)

    def close(self) -> None:
        """Remove the temporary copy, if any."""
        if self.copy is not None:
            shutil.rmtree(self.copy, ignore_errors=True)
            self.copy = None
