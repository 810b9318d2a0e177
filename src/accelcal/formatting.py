"""Numbers as people read them: digits the uncertainty supports, units with powers.

Shared by the command line's tables and the HTML report, so both round the
same way: an estimate keeps every digit down to one tenth of its standard
uncertainty (the uncertainty itself is shown with two significant digits,
GUM 7.2.6), so a table never rounds away what the data resolve. No value
shows more than :data:`MAX_DIGITS` significant digits, what a double
carries: an uncertainty at rounding level (a noise-free simulation's fit,
1e-17 relative) would otherwise ask for digits that are rounding noise.

References
----------
.. [GUM] JCGM 100:2008, Evaluation of measurement data - Guide to the
   expression of uncertainty in measurement, sec. 7.2.6.
.. [IEEE754] IEEE Std 754-2019, Floating-Point Arithmetic, sec. 5.12.2:
   a decimal of 15 significant digits survives the round trip through a
   binary64 number (``sys.float_info.dig``).
"""

import math
import re
import sys

MAX_DIGITS = sys.float_info.dig
"""Most significant digits a value shows: 15, the decimal digits a double
carries [IEEE754]; any more would print its rounding error."""


def format_value(value: float, std: float | None = None) -> str:
    """A value with as many digits as its uncertainty supports (two on the uncertainty).

    At most :data:`MAX_DIGITS` significant digits, however small ``std``.
    """
    if value is None or not math.isfinite(value):
        return "n/a"
    if std is None or not math.isfinite(std) or std <= 0:
        return f"{value:.7g}"
    magnitude = math.floor(math.log10(abs(value))) if value != 0 else math.floor(math.log10(std))
    digits = min(MAX_DIGITS, max(2, magnitude - math.floor(math.log10(std)) + 2))
    return f"{value:#.{digits}g}".rstrip(".")  # '#': keep significant trailing zeros


def format_std(std: float) -> str:
    """An uncertainty with two significant digits."""
    if std is None or not math.isfinite(std):
        return "not identified"
    return f"{std:#.2g}".rstrip(".")


def pm(value: float, std: float) -> str:
    """``value ± std`` with the digits the uncertainty supports."""
    return f"{format_value(value, std)} ± {format_std(std)}"


def pm_polar(magnitude: float, magnitude_std: float, phase_deg: float,
             phase_std_deg: float) -> str:
    """A complex value as magnitude and phase: ``1.0012 ± 0.0021 ∠ -3.41 ± 0.12°``."""
    return f"{pm(magnitude, magnitude_std)} ∠ {pm(phase_deg, phase_std_deg)}°"


def format_engineering(items) -> str:
    """Engineering units for people: ``-9.54 ± 0.68 µrad; -1.97 ± 0.14 arcsec``.

    ``items`` are dicts with ``estimate``, ``std`` and ``unit`` (the
    ``engineering`` list of :func:`accelcal.outputs.reduction_rows`).
    """
    return "; ".join(f"{pm(e['estimate'], e['std'])} {format_unit(e['unit'])}" for e in items)


def format_unit(unit: str) -> str:
    """A unit as printed: superscript powers, micro and degree signs, roots.

    ``ug/g^2`` -> ``µg/g²``, ``ppm/degC`` -> ``ppm/°C``, ``g*sqrt(s)`` -> ``g·√s``.
    """
    return format_text(unit)


_TEXT_RULES = (
    (re.compile(r"\+-\s?"), "± "),
    (re.compile(r"(?<![A-Za-z])u(?=(g|rad|V|A)(?![A-Za-z]))"), "µ"),
    (re.compile(r"(?<![A-Za-z])degC(?![A-Za-z])"), "°C"),
    (re.compile(r"\^2(?!\d)"), "²"),
    (re.compile(r"\^3(?!\d)"), "³"),
    (re.compile(r"\^4(?!\d)"), "⁴"),
    (re.compile(r"\bsqrt\((\w+)\)"), r"√\1"),
    (re.compile(r"(?<=\w)\*(?=[√\w])"), "·"),
)
"""Plain-ASCII unit spellings in notes and units -> the printed ones."""


def format_text(text: str) -> str:
    """A note or a unit with the printed symbols the report's tables use.

    ``+-`` -> ``±``, ``ug``/``urad`` -> ``µg``/``µrad``, ``degC`` -> ``°C``,
    ``^2`` -> ``²`` (and ³, ⁴), ``sqrt(Hz)`` -> ``√Hz``, ``g*√s`` -> ``g·√s``:
    notes, tables and figures then speak alike.
    """
    for pattern, replacement in _TEXT_RULES:
        text = pattern.sub(replacement, text)
    return text


def format_date(text: str) -> str:
    """An ISO 8601 time stamp as people read it: ``2026-11-26 14:03 UTC``.

    A time with an offset is shown in UTC; a date alone stays a date; text
    that is not an ISO time is returned unchanged.
    """
    import datetime as dt

    try:
        when = dt.datetime.fromisoformat(str(text))
    except ValueError:
        return str(text)
    if len(str(text)) <= len("2026-11-26"):
        return when.date().isoformat()
    if when.tzinfo is None:
        return when.strftime("%Y-%m-%d %H:%M")
    return when.astimezone(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")


def unit_squared(unit: str) -> str:
    """The square of a unit (of a variance, a power): ``g^2``, ``(m/s^2)^2``, ``(V/g)^2``.

    A unit with a power or a quotient is put in parentheses first, so its
    power is not doubled into ``m/s^2^2``.
    """
    return f"{unit}^2" if re.fullmatch(r"[^/^*() ]+", unit) else f"({unit})^2"


def format_correlation(x: float) -> str:
    """A correlation coefficient with three decimals (no negative zero; n/a for NaN)."""
    if x is None or not math.isfinite(x):
        return "n/a"
    text = f"{x:.3f}"
    return "0.000" if text == "-0.000" else text
