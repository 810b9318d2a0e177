"""Input limits of files: bounded reads and one safe JSON loader.

Every file accelcal reads passes through here, so that no input can
exhaust the stack, the memory or the time of a run:

- :func:`read_bounded` reads at most a stated number of bytes of a regular
  file, so a huge file ends at once with a message instead of filling the
  memory;
- :func:`check_regular_file` refuses, before any reader opens a path,
  anything that is not a regular file: opening a FIFO blocks for ever, a
  device never ends, a directory cannot be read;
- :func:`memory_limit` is the memory the process can still take: the
  least of its address-space limit's headroom (``RLIMIT_AS``), its
  cgroup's limit less its usage, and the machine's ``MemAvailable``;
  readers weigh what a file declares (shapes, chunk sizes) against it
  before reading;
- :func:`load_json` refuses text over :data:`MAX_JSON_BYTES`, nesting
  deeper than :data:`MAX_JSON_DEPTH` (the standard decoder recurses once
  per level and would raise ``RecursionError``), ``NaN``/``Infinity``,
  numbers that overflow to infinity and integers of more than
  :data:`MAX_INT_DIGITS` digits (``float()`` of such an integer raises
  ``OverflowError``).

Checked user strings and values shown in messages are the ground floor's
(:mod:`accelcal.validation`), below every other floor.
"""

import json
import math
import os
import re
import stat
from itertools import accumulate
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.validation import shown, shown_name, shown_path

MAX_JSON_BYTES = 16 * 2**20
"""Largest JSON text read (16 MiB): a model file is about 1 kB, a calibration
record with a 100 x 100 covariance about 250 kB, a record file's metadata
line a few kB; 16 MiB leaves room for 60 times the largest of these."""

MAX_JSON_DEPTH = 64
"""Deepest nesting of JSON arrays and objects accepted. accelcal's own files
nest at most 5 levels; 64 stays far below Python's recursion limit (1000)."""

MAX_INT_DIGITS = 30
"""Most digits of a JSON integer: far more than any count or seed accelcal
writes, far less than the 309 digits at which an integer no longer converts
to a float. An integer outside the int64 range but within this bound is
decoded as a float (numpy cannot hold it as an integer; ``np.isfinite``
would raise ``TypeError`` on it)."""

_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)


NO_LIMIT = 2**40
"""Memory assumed when no limit can be read at all (1 TiB: nothing is refused for it)."""

_CGROUP = Path("/sys/fs/cgroup")


def memory_limit() -> int:
    """Bytes of memory this process can still take, from its real limits.

    The least of:

    - the headroom of the address-space limit (``RLIMIT_AS``, ``ulimit -v``):
      the soft limit less the process's present virtual size (``VmSize`` of
      ``/proc/self/status``); an allocation past it fails however much the
      machine has free;
    - the headroom of the memory cgroup (a container's or a systemd unit's
      limit): cgroup v2 ``memory.max`` less ``memory.current`` of the
      process's cgroup and each of its parents, or cgroup v1
      ``memory.limit_in_bytes`` less ``memory.usage_in_bytes``; past it the
      kernel kills the process;
    - ``MemAvailable`` of ``/proc/meminfo`` (free memory plus what the
      kernel can reclaim), else the free physical pages of ``os.sysconf``.

    A limit that cannot be read (another system, no such file) is left
    out; :data:`NO_LIMIT` when none can be read.

    References
    ----------
    .. [rlimit] Linux man-pages, getrlimit(2): ``RLIMIT_AS``; proc(5):
       ``/proc/self/status`` ``VmSize``, ``/proc/meminfo`` ``MemAvailable``.
    .. [cgroup] Linux kernel documentation, "Control Group v2" (``memory.max``,
       ``memory.current``) and "Memory Resource Controller" (cgroup v1).
    """
    found = [v for v in (_address_space_headroom(), _cgroup_headroom(), _machine_available())
             if v is not None]
    return max(min(found), 0) if found else NO_LIMIT


def _address_space_headroom() -> int | None:
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError, AttributeError):
        return None
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    return soft - (_status_kib("VmSize") or 0) * 1024


def _status_kib(field: str) -> int | None:
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_headroom() -> int | None:
    try:
        lines = Path("/proc/self/cgroup").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    best = None
    for line in lines.splitlines():
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        if parts[0] == "0" and parts[1] == "":
            pairs = [("memory.max", "memory.current")]
            root = _CGROUP
        elif "memory" in parts[1].split(","):
            pairs = [("memory.limit_in_bytes", "memory.usage_in_bytes")]
            root = _CGROUP / "memory"
        else:
            continue
        for directory in _cgroup_dirs(root, parts[2]):
            for limit_name, usage_name in pairs:
                room = _cgroup_room(directory / limit_name, directory / usage_name)
                if room is not None:
                    best = room if best is None else min(best, room)
    return best


def _cgroup_dirs(root: Path, group: str) -> list[Path]:
    """The cgroup's directory and its parents' (a namespaced mount shows only the root)."""
    parts = [p for p in group.split("/") if p and p != ".."]
    return [root.joinpath(*parts[:k]) for k in range(len(parts), -1, -1)]


def _cgroup_room(limit_file: Path, usage_file: Path) -> int | None:
    try:
        limit = limit_file.read_text(encoding="ascii").strip()
        usage = int(usage_file.read_text(encoding="ascii").strip())
    except (OSError, ValueError):
        return None
    if limit == "max" or not limit.isdigit() or int(limit) >= 2**62:
        return None
    return int(limit) - usage


def _machine_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    for pages in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        try:
            return int(os.sysconf(pages)) * int(os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError, AttributeError):
            continue
    return None


def check_regular_file(path, what: str) -> None:
    """Refuse a path that exists and is not a regular file, before opening it.

    Every reader calls this first: opening a FIFO for reading blocks until
    a writer comes (for ever, if none does), a device such as
    ``/dev/zero`` never ends, and a directory or a socket cannot be read as
    a file. A link is followed (a link to a device is a device). A missing
    or inaccessible path passes, so that the reader's own ``open`` reports
    it in its words.

    Parameters
    ----------
    path : path-like
    what : str
        What the file is, for the message (``"model file"``).

    Raises
    ------
    AccelcalError
        One line naming ``path`` and what it is (a directory, a FIFO, a
        device, ...), or for a path containing a NUL character.
    """
    try:
        info = os.stat(path)
    except ValueError:  # an embedded NUL character
        raise AccelcalError(f"{what} path {shown(os.fspath(path))} contains a NUL character"
                            ) from None
    except OSError:
        return
    if not stat.S_ISREG(info.st_mode):
        raise AccelcalError(
            f"{what} {shown_path(path)} is {file_type(info.st_mode)}, not a regular file; "
            "give a file"
        )


def file_type(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, for a message (``"a FIFO (named pipe)"``)."""
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISREG, "a regular file")):
        if test(mode):
            return name
    return "a special file"


def read_bounded(path, limit: int, what: str) -> bytes:
    """The bytes of ``path``, refusing a file larger than ``limit`` bytes.

    Anything but a regular file (a FIFO, a device, a directory) is refused
    before it is opened (:func:`check_regular_file`); the size of the file is
    checked before reading, so the call reads at most ``limit`` bytes.

    Parameters
    ----------
    path : path-like
    limit : int
        Largest size accepted, bytes.
    what : str
        What the file is, for the message (``"model file"``).

    Raises
    ------
    AccelcalError
        If the file is not a regular file or is larger than ``limit``.
    OSError
        If the file cannot be opened or read (callers say which file).
    """
    check_regular_file(path, what)
    with open(path, "rb") as fh:
        data = read_rest(fh, limit)
    if data is None:
        raise AccelcalError(
            f"{what} {path} is larger than {_size(limit)}; is it the right file?"
        )
    return data


def read_rest(fh, limit: int) -> bytes | None:
    """The rest of a binary file, or None if it is longer than ``limit`` bytes.

    A regular file's size is checked before reading; anything else is read
    in pieces up to ``limit + 1`` bytes. Memory is never taken for more than
    the file holds, whatever ``limit`` is.
    """
    info = os.fstat(fh.fileno())
    if stat.S_ISREG(info.st_mode):
        rest = max(info.st_size - fh.tell(), 0)
        return None if rest > limit else fh.read(rest)
    chunks, size = [], 0
    while size <= limit:
        chunk = fh.read(min(2**20, limit + 1 - size))
        if not chunk:
            break
        chunks.append(chunk)
        size += len(chunk)
    return None if size > limit else b"".join(chunks)


def load_json(text: str, where: str, *, error: type[AccelcalError] = AccelcalError):
    """Decode JSON text with bounded size and depth; only finite numbers.

    Parameters
    ----------
    text : str
        The JSON text.
    where : str
        What is decoded (a file, a line), prefixed to every message.
    error : type, optional
        The :class:`AccelcalError` subclass to raise.

    Returns
    -------
    object
        The decoded value.

    Raises
    ------
    AccelcalError
        (or ``error``) for text over :data:`MAX_JSON_BYTES` characters,
        nesting deeper than :data:`MAX_JSON_DEPTH`, invalid JSON, ``NaN``,
        ``Infinity``, a number too large for a float or an integer of more
        than :data:`MAX_INT_DIGITS` digits. An integer outside the int64
        range (and within that bound) is returned as a float.
    """
    if len(text) > MAX_JSON_BYTES:
        raise error(f"{where}: JSON text is larger than {_size(MAX_JSON_BYTES)}")
    if json_depth(text) > MAX_JSON_DEPTH:
        raise error(f"{where}: JSON nests deeper than {MAX_JSON_DEPTH} levels")
    try:
        return json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float,
                          parse_int=_bounded_int)
    except json.JSONDecodeError as exc:
        raise error(
            f"{where}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except ValueError as exc:  # a refused constant or number, an over-long integer
        raise error(f"{where}: {exc}") from None


def json_depth(text: str) -> int:
    """Deepest nesting of arrays and objects in JSON ``text`` (brackets in strings ignored).

    Linear in the length of the text and without recursion, so it can be
    asked of any text before decoding it.
    """
    brackets = re.findall(r"[\[\]{}]", _STRING.sub("", text))
    return max(accumulate(1 if b in "[{" else -1 for b in brackets), default=0)


def _size(n: int) -> str:
    return f"{n / 2**20:g} MiB" if n >= 2**20 else f"{n} bytes"


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not allowed; numbers must be finite")


def _bounded_int(text: str) -> int | float:
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        raise ValueError(f"integer {text[:20]}... has {digits} digits; at most {MAX_INT_DIGITS} "
                         "are allowed (numbers must be within the range of a float)")
    value = int(text)
    return value if -(2**63) <= value < 2**63 else float(value)


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{shown_name(text)} is not allowed; numbers must be finite (too large "
                         "for a float)")
    return value
