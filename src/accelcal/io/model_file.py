"""The model file: an :class:`~accelcal.model.ErrorModel` as JSON.

This module knows the format, not the class: it validates decoded contents
into plain coefficients and writes a model's terms. The model, on a floor
below io, imports it only inside its file entry points
(``ErrorModel.to_dict/from_dict/to_json/from_json/save/load``), and this
module never imports the model.

Format (``format_version`` 1)::

    {
      "format_version": 1,
      "kind": "accelcal.ErrorModel",
      "output_unit": "V",
      "units": {"K0": "g", "K1": "V/g", ...},
      "coefficients": {"K0": -6.4e-4, "K1": 1.2993698, ...},
      "description": "optional free text"
    }

``coefficients`` must contain K1; a term it omits is zero. ``units`` is
optional; when present, every unit it gives must be the term's unit for the
declared output unit (a file in mV/g labelled as V is refused). Unknown keys
at any level are refused with a message naming them.

A model with temperature terms (:class:`~accelcal.terms.TemperatureTerms`)
is written as ``format_version`` 2, which adds one key (a model without them
is written exactly as before, as version 1)::

      "temperature": {
        "reference_degC": 25.0,
        "valid_range_degC": [-40.0, 70.0],          (optional)
        "units": {"K0_T1": "g/degC", ...},          (optional, checked)
        "coefficients": {"K0_T1": 2.1e-6, "K1_T1": -3.5e-5, ...}
      }

References
----------
.. [DOMAIN] accelcal domain notes, section 8 (temperature polynomials).
"""

import json
from pathlib import Path

from accelcal.errors import AccelcalError, ModelFileError
from accelcal.io.atomic import write_text_atomic
from accelcal.io.limits import MAX_JSON_BYTES, load_json, read_bounded
from accelcal.terms import (
    TEMPERATURE_TERMS,
    TERMS,
    TemperatureTerms,
    term_unit,
    unknown_term,
)
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import is_finite_number, shown

__all__ = ["FORMAT_VERSION", "KIND", "TEMPERATURE_FORMAT_VERSION", "ModelFileError", "dumps",
           "loads", "model_to_dict", "read_text", "temperature_terms", "unknown_term", "validate",
           "write_text"]

FORMAT_VERSION = 1
"""Version written for a model without temperature terms."""
TEMPERATURE_FORMAT_VERSION = 2
"""Version written for a model with temperature terms (the newest this accelcal reads)."""
KIND = "accelcal.ErrorModel"
_REQUIRED = ("format_version", "kind", "output_unit", "coefficients")
_OPTIONAL = ("units", "description", "temperature")
_TEMPERATURE_KEYS = ("reference_degC", "coefficients", "valid_range_degC", "units")


def model_to_dict(model, description: str | None = None) -> dict:
    """A model's (its ``output_unit``, ``units()``, ``terms()``) JSON-ready dict."""
    data = {
        "format_version": FORMAT_VERSION,
        "kind": KIND,
        "output_unit": model.output_unit,
        "units": model.units(),
        "coefficients": model.terms(),
    }
    if description:
        data["description"] = description
    tt = getattr(model, "temperature", None)
    if tt is not None:
        data["format_version"] = TEMPERATURE_FORMAT_VERSION
        data["temperature"] = {"reference_degC": tt.reference}
        if tt.valid_range is not None:
            data["temperature"]["valid_range_degC"] = list(tt.valid_range)
        data["temperature"] |= {"units": tt.units(), "coefficients": tt.as_dict()}
    return data


def dumps(data: dict) -> str:
    """The text of a model file from its dict (JSON; floats round-trip exactly)."""
    return json.dumps(data, indent=2) + "\n"


def validate(data, *, source: str = "<dict>") -> tuple[dict, str]:
    """Validate a decoded model file: its coefficients and output unit.

    Returns
    -------
    coefficients : dict
        Term name -> number (K1 present, all finite).
    output_unit : str

    Raises
    ------
    ModelFileError
        Naming ``source``, the field and what was expected.
    """

    def fail(msg: str) -> ModelFileError:
        return ModelFileError(f"{source}: {msg}")

    if not isinstance(data, dict):
        raise fail(f"expected a JSON object at the top level, got {type(data).__name__}")
    unknown = sorted(set(data) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise fail(
            f"unknown key(s) {', '.join(map(shown, unknown))}; allowed keys are "
            f"{', '.join(_REQUIRED + _OPTIONAL)}"
        )
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise fail(f"missing key(s) {', '.join(map(repr, missing))}")
    version = data["format_version"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise fail(f"format_version must be an integer, got {shown(version)}")
    if version > TEMPERATURE_FORMAT_VERSION:
        raise fail(
            f"format_version {version} is newer than this accelcal reads "
            f"({TEMPERATURE_FORMAT_VERSION}); upgrade accelcal"
        )
    if "temperature" in data and version < TEMPERATURE_FORMAT_VERSION:
        raise fail(f"temperature terms need format_version {TEMPERATURE_FORMAT_VERSION}, "
                   f"the file says {version}")
    if version < 1:
        raise fail(f"format_version {version} is not a valid version (expected 1)")
    if data["kind"] != KIND:
        raise fail(f"kind is {shown(data['kind'])}, expected {KIND!r} (is this a model file?)")
    unit = data["output_unit"]
    if unit not in OUTPUT_UNITS:
        raise fail(f"output_unit {shown(unit)} is not one of {', '.join(OUTPUT_UNITS)}")

    coefficients = data["coefficients"]
    if not isinstance(coefficients, dict):
        raise fail("coefficients must be an object mapping term names to numbers")
    for name, value in coefficients.items():
        if name not in TERMS:
            raise fail(f"coefficients: {unknown_term(name)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail(f"coefficients.{name} must be a number, got {shown(value)}")
        if not is_finite_number(value):
            raise fail(f"coefficients.{name} = {shown(value)} is not finite")
    if "K1" not in coefficients:
        raise fail("coefficients.K1 (scale factor) is missing; every model file must give it")

    units = data.get("units", {})
    if not isinstance(units, dict):
        raise fail("units must be an object mapping term names to unit strings")
    for name, given in units.items():
        if name not in TERMS:
            raise fail(f"units: {unknown_term(name)}")
        expected = term_unit(name, unit)
        if given != expected:
            raise fail(
                f"units.{name} is {shown(given)} but a model with output_unit {unit!r} "
                f"has {name} in {expected!r}; convert the value or fix output_unit"
            )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise fail("description must be a string")
    return coefficients, unit


def temperature_terms(data, *, source: str = "<dict>") -> TemperatureTerms | None:
    """The temperature terms of a validated model file's contents (None without them).

    Raises
    ------
    ModelFileError
        Naming ``source`` and the field of ``temperature`` that is wrong.
    """
    section = data.get("temperature")
    if section is None:
        return None

    def fail(msg: str) -> ModelFileError:
        return ModelFileError(f"{source}: temperature: {msg}")

    if not isinstance(section, dict):
        raise fail("must be an object with reference_degC and coefficients")
    unknown = sorted(set(section) - set(_TEMPERATURE_KEYS))
    if unknown:
        raise fail(f"unknown key(s) {', '.join(map(shown, unknown))}; allowed keys are "
                   f"{', '.join(_TEMPERATURE_KEYS)}")
    if "reference_degC" not in section or not is_finite_number(section["reference_degC"]):
        raise fail("reference_degC (the reference temperature T0) must be a finite number")
    coefficients = section.get("coefficients")
    if not isinstance(coefficients, dict):
        raise fail("coefficients must be an object mapping names such as K0_T1 to numbers")
    for name, value in coefficients.items():
        if name not in TEMPERATURE_TERMS:
            raise fail(f"coefficients: {unknown_term(name, TEMPERATURE_TERMS)}")
        if not is_finite_number(value):
            raise fail(f"coefficients.{name} must be a finite number, got {shown(value)}")
    units = section.get("units", {})
    if not isinstance(units, dict):
        raise fail("units must be an object mapping names to unit strings")
    for name, given in units.items():
        if name not in TEMPERATURE_TERMS:
            raise fail(f"units: {unknown_term(name, TEMPERATURE_TERMS)}")
        if given != TEMPERATURE_TERMS[name].unit:
            raise fail(f"units.{name} is {shown(given)}, expected "
                       f"{TEMPERATURE_TERMS[name].unit!r}; convert the value")
    span = section.get("valid_range_degC")
    if span is not None and not (isinstance(span, list) and len(span) == 2
                                 and all(is_finite_number(v) for v in span)):
        raise fail("valid_range_degC must be [low, high] in degC")
    try:
        return TemperatureTerms(section["reference_degC"], coefficients,
                                None if span is None else tuple(span))
    except AccelcalError as exc:
        raise fail(exc.message) from None


def loads(text: str, *, source: str = "<string>"):
    """Decode model-file text; errors name ``source``.

    Decoded by :func:`accelcal.io.limits.load_json`: bounded size and
    depth, NaN and Infinity refused.
    """
    return load_json(text, source, error=ModelFileError)


def read_text(path) -> str:
    """The text of a model file (at most :data:`~accelcal.io.limits.MAX_JSON_BYTES`).

    Raises
    ------
    ModelFileError
        If the file is missing, unreadable, too large or not UTF-8; the
        message names it.
    """
    path = Path(path)
    try:
        return read_bounded(path, MAX_JSON_BYTES, "model file").decode("utf-8")
    except FileNotFoundError:
        raise ModelFileError(
            f"model file {path} not found; create one with 'accelcal model new'"
        ) from None
    except AccelcalError as exc:
        raise ModelFileError(exc.message) from None
    except OSError as exc:
        raise ModelFileError(f"cannot read model file {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise ModelFileError(f"cannot read model file {path}: not UTF-8 text") from None


def write_text(path, text: str) -> None:
    """Write model-file text atomically."""
    write_text_atomic(path, text)

