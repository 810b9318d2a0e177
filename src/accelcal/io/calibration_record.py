"""The calibration record: what a calibration found, in one JSON file.

Format (``format_version`` 1)::

    {
      "format_version": 1,
      "kind": "accelcal.CalibrationRecord",
      "serial": "SN-0042",
      "method": "dividing-head/joint",
      "date": "2026-11-21T05:20:00+00:00",
      "software": "accelcal 0.1.0",
      "operator": "",
      "coverage_factor": 2.0,
      "coefficients": [
        {"name": "K_F", "unit": "V", "estimate": -8.3e-4, "std": 1.1e-6, "expanded": 2.2e-6},
        ...
      ],
      "covariance": [[...], ...],
      "model": { ... model file contents ... } or null,
      "inputs": {"positions.csv": "sha256:..."},
      "notes": ["first harmonic of the angle error assumed zero"]
    }

``expanded`` is ``coverage_factor * std`` (k = 2 by default, about 95 %
coverage for a Gaussian estimate). The covariance is in the coefficients'
order and units. ``inputs`` holds the SHA-256 of every input file, so a
record says exactly which data it came from.
"""

import datetime as _dt
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.atomic import write_text_atomic
from accelcal.model import ErrorModel

FORMAT_VERSION = 1
KIND = "accelcal.CalibrationRecord"
_KEYS = {
    "format_version", "kind", "serial", "method", "date", "software", "operator",
    "coverage_factor", "coefficients", "covariance", "model", "inputs", "notes",
}
_COEFFICIENT_KEYS = {"name", "unit", "estimate", "std", "expanded"}


def file_sha256(path) -> str:
    """``sha256:<hex>`` of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return "sha256:" + digest.hexdigest()


@dataclass(frozen=True)
class CalibrationRecord:
    """One calibration of one accelerometer.

    Parameters
    ----------
    serial : str
        Serial number of the accelerometer.
    method : str
        Test method and reduction, e.g. ``"dividing-head/joint"``.
    names : tuple of str
        Coefficient names.
    estimates : numpy.ndarray
        Estimates, shape ``(p,)``.
    covariance : numpy.ndarray
        Covariance, shape ``(p, p)``.
    units : dict
        Unit of each coefficient.
    date : str
        ISO 8601 date and time of the calibration.
    software : str
        Software and version that produced the record.
    operator : str
        Who ran the calibration.
    coverage_factor : float
        k of the expanded uncertainty (2 by default).
    model : ErrorModel, optional
        The error model the coefficients define, when they define one.
    inputs : dict
        Input file name to ``sha256:<hex>``.
    notes : tuple of str
        Caveats carried from the reduction.
    """

    serial: str
    method: str
    names: tuple[str, ...]
    estimates: np.ndarray
    covariance: np.ndarray
    units: dict[str, str]
    date: str
    software: str
    operator: str = ""
    coverage_factor: float = 2.0
    model: ErrorModel | None = None
    inputs: dict[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.serial, str) or not self.serial.strip():
            raise AccelcalError("calibration record: serial must be a non-empty string")
        est = np.asarray(self.estimates, dtype=float)
        cov = np.asarray(self.covariance, dtype=float)
        p = len(self.names)
        if est.shape != (p,) or cov.shape != (p, p):
            raise AccelcalError(
                f"calibration record: {p} coefficients need estimates ({p},) and covariance "
                f"({p}, {p}); got {est.shape} and {cov.shape}"
            )
        if not np.isfinite(est).all():
            raise AccelcalError("calibration record: estimates must be finite")
        if not (self.coverage_factor > 0 and math.isfinite(self.coverage_factor)):
            raise AccelcalError("calibration record: coverage_factor must be positive")
        _parse_date(self.date, "calibration record")
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "estimates", est)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def expanded(self) -> np.ndarray:
        """Expanded uncertainties, ``coverage_factor * std``."""
        return self.coverage_factor * self.std

    @classmethod
    def from_estimate(
        cls, estimate, *, serial: str, method: str | None = None, input_files=(),
        date: str | None = None, operator: str = "", model: ErrorModel | None = None,
    ) -> "CalibrationRecord":
        """Record a reduction's :class:`~accelcal.results.Estimate`.

        Input files are hashed; the date defaults to now (UTC).
        """
        from accelcal import __version__

        return cls(
            serial=serial,
            method=method or estimate.method,
            names=estimate.names,
            estimates=estimate.values,
            covariance=estimate.covariance,
            units=dict(estimate.units),
            date=date or _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            software=f"accelcal {__version__}",
            operator=operator,
            model=model,
            inputs={Path(p).name: file_sha256(p) for p in input_files},
            notes=tuple(estimate.notes),
        )

    def to_dict(self) -> dict:
        """The record as a JSON-ready dict in the current format."""
        from accelcal.io.model_file import model_to_dict

        return {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "serial": self.serial,
            "method": self.method,
            "date": self.date,
            "software": self.software,
            "operator": self.operator,
            "coverage_factor": self.coverage_factor,
            "coefficients": [
                {"name": n, "unit": self.units.get(n, ""), "estimate": float(v),
                 "std": float(s), "expanded": float(u)}
                for n, v, s, u in zip(
                    self.names, self.estimates, self.std, self.expanded, strict=True
                )
            ],
            "covariance": self.covariance.tolist(),
            "model": model_to_dict(self.model) if self.model is not None else None,
            "inputs": dict(self.inputs),
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """The record as JSON text (NaN covariance entries written as null)."""
        data = self.to_dict()
        data["covariance"] = [[None if math.isnan(x) else x for x in row]
                              for row in data["covariance"]]
        for c in data["coefficients"]:
            for key in ("std", "expanded"):
                if math.isnan(c[key]):
                    c[key] = None
        return json.dumps(data, indent=2, allow_nan=False) + "\n"

    def save(self, path) -> None:
        """Write the record atomically."""
        write_text_atomic(path, self.to_json())

    @classmethod
    def from_json(cls, text: str, *, source: str = "<string>") -> "CalibrationRecord":
        """Parse and validate record text; errors name ``source`` and the field."""
        try:
            data = json.loads(text, parse_constant=_no_constant)
        except ValueError as exc:
            raise AccelcalError(f"{source}: not a valid calibration record JSON ({exc})") from None
        return _from_dict(data, source)

    @classmethod
    def load(cls, path) -> "CalibrationRecord":
        """Read and validate a calibration record file."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise AccelcalError(f"calibration record {path} not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise AccelcalError(f"cannot read calibration record {path}: {exc}") from None
        return cls.from_json(text, source=str(path))


def _from_dict(data, source: str) -> CalibrationRecord:
    from accelcal.io.model_file import model_from_dict

    def fail(msg):
        return AccelcalError(f"{source}: {msg}")

    if not isinstance(data, dict):
        raise fail("expected a JSON object")
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise fail(f"unknown key(s) {', '.join(map(repr, unknown))}")
    missing = sorted(_KEYS - set(data))
    if missing:
        raise fail(f"missing key(s) {', '.join(map(repr, missing))}")
    if data["kind"] != KIND:
        raise fail(f"kind is {data['kind']!r}, expected {KIND!r}")
    version = data["format_version"]
    if version != FORMAT_VERSION:
        raise fail(
            f"format_version {version!r} is not supported (this accelcal reads {FORMAT_VERSION})"
        )
    for key in ("serial", "method", "date", "software", "operator"):
        if not isinstance(data[key], str):
            raise fail(f"{key} must be a string")
    coefficients = data["coefficients"]
    if not isinstance(coefficients, list) or not coefficients:
        raise fail("coefficients must be a non-empty list")
    names, units, values = [], {}, []
    for i, c in enumerate(coefficients):
        if not isinstance(c, dict) or set(c) != _COEFFICIENT_KEYS:
            raise fail(f"coefficients[{i}] must have exactly the keys {sorted(_COEFFICIENT_KEYS)}")
        if not isinstance(c["estimate"], (int, float)) or isinstance(c["estimate"], bool):
            raise fail(f"coefficients[{i}].estimate must be a number")
        names.append(str(c["name"]))
        units[str(c["name"])] = str(c["unit"])
        values.append(float(c["estimate"]))
    try:
        cov = np.array(
            [[math.nan if x is None else float(x) for x in row] for row in data["covariance"]]
        )
    except (TypeError, ValueError):
        raise fail(
            "covariance must be a square list of lists of numbers (null for unknown)"
        ) from None
    model = None
    if data["model"] is not None:
        model = model_from_dict(data["model"], source=f"{source}: model")
    if not isinstance(data["inputs"], dict):
        raise fail("inputs must map file names to hashes")
    try:
        return CalibrationRecord(
            serial=data["serial"], method=data["method"], names=tuple(names),
            estimates=np.array(values), covariance=cov, units=units, date=data["date"],
            software=data["software"], operator=data["operator"],
            coverage_factor=float(data["coverage_factor"]), model=model,
            inputs=dict(data["inputs"]), notes=tuple(map(str, data["notes"])),
        )
    except AccelcalError as exc:
        raise fail(str(exc)) from None


def _parse_date(text: str, where: str) -> _dt.datetime:
    try:
        return _dt.datetime.fromisoformat(text)
    except (TypeError, ValueError):
        raise AccelcalError(
            f"{where}: date {text!r} is not ISO 8601 (e.g. 2026-11-21T09:30:00+00:00)"
        ) from None


def _no_constant(name: str):
    raise ValueError(f"{name} is not allowed")
