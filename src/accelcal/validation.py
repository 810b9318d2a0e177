"""The ground floor: checked user strings and values shown in one-line messages.

Every floor of accelcal (the domain model, the physics, io, signal, rigs,
methods, the store and the command line) quotes values in its error
messages and checks the strings users give through these helpers, so that
no value can break a one-line message, a file name or a report:

- :func:`shown`, :func:`shown_name`, :func:`shown_path` and
  :func:`one_line` put a value, a name, a path or a message on one short
  line;
- :func:`check_label` bounds a user string (serial number, operator,
  method) to :data:`MAX_LABEL_LENGTH` characters without control
  characters, and a string that becomes part of a file name to one without
  path separators;
- :func:`is_finite_number` tells a finite JSON number from everything else,
  and :func:`check_rate` checks a sample rate (read from a recording or
  given to the Allan deviations).

This module imports only the standard library and :mod:`accelcal.errors`;
the limits that are about files (bounded reads, the JSON loader) are in
:mod:`accelcal.io.limits`.
"""

import json
import math
import re

from accelcal.errors import AccelcalError

__all__ = ["MAX_LABEL_LENGTH", "MAX_MESSAGE_LENGTH", "MAX_RATE_HZ", "MIN_RATE_HZ", "check_label",
           "check_rate", "is_finite_number", "one_line", "shown", "shown_name", "shown_path"]

MAX_MESSAGE_LENGTH = 500
"""Longest error message printed, in characters (``accelcal.cli`` clips
longer ones): values are quoted shortened (:func:`shown`), and this bound
holds whatever a message quotes."""

MAX_LABEL_LENGTH = 200
"""Longest serial number, operator or method name, in characters: the width
of the records store's ``serial`` and ``method`` columns, and well below the
255-byte limit of a file name that a serial number becomes part of."""

MAX_RATE_HZ = 1e9
"""Highest sample rate accepted (1 GHz): beyond any accelerometer's DAQ."""

MIN_RATE_HZ = 1e-6
"""Lowest sample rate accepted (one sample in 11.6 days): slower is not a recording of
an accelerometer, and averaging times of m / rate stay far inside the float range."""

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
"""Control characters (C0, DEL, C1), line and paragraph separators and
bidirectional overrides: none belongs in a label, a file name or a report."""


def shown(value, limit: int = 40) -> str:
    """A value as a message shows it, cut to about ``limit`` characters.

    A string is quoted (``'x'``), anything else is shown as JSON (``null``,
    ``true``), so that a message stays one short line whatever the value.
    """
    text = repr(value) if isinstance(value, str) else json.dumps(value, default=repr)
    if len(text) <= limit:
        return text
    size = f" ({len(value)} characters)" if isinstance(value, str) else ""
    return f"{text[:limit]}...{size}"


def shown_name(name, limit: int = 60) -> str:
    """A name (a column, a term) for a message, bounded.

    As it is when short and printable, else quoted and cut by :func:`shown`.
    """
    if isinstance(name, str) and len(name) <= limit and name.isprintable():
        return name
    return shown(name, limit)


def shown_path(path) -> str:
    """A path or address for a one-line message: a long one keeps its start and end."""
    text = str(path)
    return text if len(text) <= 160 else f"{text[:100]}...{text[-50:]}"


def one_line(text, limit: int = 300) -> str:
    """A message (such as an exception's text) on one line of at most about ``limit`` characters."""
    flat = " ".join(str(text).split())
    return flat if len(flat) <= limit else f"{flat[:limit]}..."


def check_label(value, what: str, *, file_name: bool = False, limit: int = MAX_LABEL_LENGTH,
                parameter: str | None = None) -> str:
    """Check a user string that goes into records, reports or file names.

    Parameters
    ----------
    value : object
        The string to check.
    what : str
        What it is, for the message (``"serial number"``).
    file_name : bool
        It becomes part of a file name: no path separator (slash or backslash) either.
    limit : int
        Longest length accepted, characters.
    parameter : str, optional
        The Python parameter that gave it, for the error.

    Returns
    -------
    str
        ``value`` unchanged.

    Raises
    ------
    AccelcalError
        For a non-string, an over-long string, a control character or (with
        ``file_name``) a path separator.
    """
    if not isinstance(value, str):
        raise AccelcalError(f"{what} must be a string, got {shown(value)}", parameter=parameter)
    if len(value) > limit:
        raise AccelcalError(
            f"{what} {shown(value)} is longer than {limit} characters; shorten it",
            parameter=parameter,
        )
    if _CONTROL.search(value):
        raise AccelcalError(
            f"{what} {shown(value)} contains a control character (such as a line break "
            "or a tab); remove it", parameter=parameter,
        )
    if file_name and ("/" in value or "\\" in value):
        raise AccelcalError(
            f"{what} {shown(value)} contains a path separator (/ or \\), which cannot be "
            "part of a file name; use another character", parameter=parameter,
        )
    return value


def is_finite_number(value) -> bool:
    """A JSON number that is a finite float (``true``/``false`` and huge integers are not)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer beyond the float range
        return False


def check_rate(rate) -> float:
    """Check a sample rate in Hz (finite, :data:`MIN_RATE_HZ` to :data:`MAX_RATE_HZ`).

    A boolean is not a number here (``rate = true`` in a mapping file is not 1 Hz).
    """
    try:
        value = math.nan if isinstance(rate, bool) else float(rate)
    except (TypeError, ValueError, OverflowError):
        value = math.nan
    if not (math.isfinite(value) and MIN_RATE_HZ <= value <= MAX_RATE_HZ):
        raise AccelcalError(f"sample rate {shown(rate)} Hz must be a number from "
                            f"{MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz", parameter="rate")
    return value
