"""The model file: an :class:`~accelcal.model.ErrorModel` as JSON.

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
"""

import json
import math
from pathlib import Path

from accelcal.errors import ModelFileError
from accelcal.io.atomic import write_text_atomic
from accelcal.model import TERMS, ErrorModel, term_unit, unknown_term_message
from accelcal.units import OUTPUT_UNITS

FORMAT_VERSION = 1
KIND = "accelcal.ErrorModel"
_REQUIRED = ("format_version", "kind", "output_unit", "coefficients")
_OPTIONAL = ("units", "description")


def model_to_dict(model: ErrorModel, description: str | None = None) -> dict:
    """The model as a JSON-ready dict in the current format."""
    data = {
        "format_version": FORMAT_VERSION,
        "kind": KIND,
        "output_unit": model.output_unit,
        "units": model.units(),
        "coefficients": model.terms(),
    }
    if description:
        data["description"] = description
    return data


def dumps_model(model: ErrorModel) -> str:
    """The text of the model file (JSON; floats round-trip exactly)."""
    return json.dumps(model_to_dict(model), indent=2) + "\n"


def model_from_dict(data, *, source: str = "<dict>") -> ErrorModel:
    """Validate a decoded model file and build the model.

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
            f"unknown key(s) {', '.join(map(repr, unknown))}; allowed keys are "
            f"{', '.join(_REQUIRED + _OPTIONAL)}"
        )
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise fail(f"missing key(s) {', '.join(map(repr, missing))}")
    version = data["format_version"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise fail(f"format_version must be an integer, got {version!r}")
    if version > FORMAT_VERSION:
        raise fail(
            f"format_version {version} is newer than this accelcal reads "
            f"({FORMAT_VERSION}); upgrade accelcal"
        )
    if version < 1:
        raise fail(f"format_version {version} is not a valid version (expected 1)")
    if data["kind"] != KIND:
        raise fail(f"kind is {data['kind']!r}, expected {KIND!r} (is this a model file?)")
    unit = data["output_unit"]
    if unit not in OUTPUT_UNITS:
        raise fail(f"output_unit {unit!r} is not one of {', '.join(OUTPUT_UNITS)}")

    coefficients = data["coefficients"]
    if not isinstance(coefficients, dict):
        raise fail("coefficients must be an object mapping term names to numbers")
    for name, value in coefficients.items():
        if name not in TERMS:
            raise fail(f"coefficients: {unknown_term_message(name, TERMS)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail(f"coefficients.{name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise fail(f"coefficients.{name} = {value} is not finite")
    if "K1" not in coefficients:
        raise fail("coefficients.K1 (scale factor) is missing; every model file must give it")

    units = data.get("units", {})
    if not isinstance(units, dict):
        raise fail("units must be an object mapping term names to unit strings")
    for name, given in units.items():
        if name not in TERMS:
            raise fail(f"units: {unknown_term_message(name, TERMS)}")
        expected = term_unit(name, unit)
        if given != expected:
            raise fail(
                f"units.{name} is {given!r} but a model with output_unit {unit!r} "
                f"has {name} in {expected!r}; convert the value or fix output_unit"
            )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise fail("description must be a string")
    try:
        return ErrorModel.from_terms(coefficients, output_unit=unit)
    except ModelFileError:
        raise
    except ValueError as exc:
        raise fail(str(exc)) from None


def loads_model(text: str, *, source: str = "<string>") -> ErrorModel:
    """Parse model-file text; errors name ``source``."""
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise ModelFileError(
            f"{source}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except ValueError as exc:
        raise ModelFileError(f"{source}: {exc}") from None
    return model_from_dict(data, source=source)


def read_model(path) -> ErrorModel:
    """Read and validate a model file.

    Raises
    ------
    ModelFileError
        If the file is missing, unreadable or invalid; the message names it.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelFileError(
            f"model file {path} not found; create one with 'accelcal model new'"
        ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"cannot read model file {path}: {exc}") from None
    return loads_model(text, source=str(path))


def write_model(model: ErrorModel, path) -> None:
    """Write the model file atomically."""
    write_text_atomic(path, dumps_model(model))


def _reject_constant(name: str):
    raise ValueError(f"{name} is not allowed; coefficients must be finite numbers")
