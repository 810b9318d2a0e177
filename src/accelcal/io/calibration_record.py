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
      "notes": ["first harmonic of the angle error assumed zero"],
      "dof": 55,
      "simulated": false
    }

``expanded`` is ``coverage_factor * std``. The coverage factor is Student's
t for the degrees of freedom ``dof`` of the standard uncertainties at the
coverage probability of k = 2 for a normal distribution (95.45 %, GUM G.3
and Table G.2): 2 when the noise level was given (``dof`` null: infinite),
2.04 for 55 dof, 13.97 for one. The covariance is in the coefficients'
order and units. ``inputs`` holds the SHA-256 of every input file, so a
record says exactly which data it came from; ``simulated`` is true when
they are simulated (a rig simulator or the demo wrote them). ``dof`` and
``simulated`` are optional on reading (records written before them load,
as dof unknown and not simulated).

A coefficient whose standard uncertainty includes Type B contributions (the
priors of terms the reduction takes as zero, :mod:`accelcal.aliasing`)
carries their combined standard uncertainty as an optional ``type_b`` key,
in the coefficient's unit: ``std`` is ``sqrt(u_A^2 + type_b^2)``, so the
Type A part is ``sqrt(std^2 - type_b^2)``. A coefficient without the key
has no Type B part recorded (a record made before the key, or a reduction
that bounded nothing)::

    {"name": "b_x", "unit": "m/s^2", "estimate": 0.0512, "std": 2.1e-4,
     "expanded": 4.2e-4, "type_b": 6.3e-5}

A record may keep the uncertainty budgets a certificate was issued with
(``accelcal certificate --keep-budgets``), in an optional ``budget`` block
written only when present (so a record without one is byte for byte as
before)::

    "budget": {
      "lab": {"sha256": "<hex of the lab file's bytes>", "path": "lab.toml",
              "name": "Inertial Sensors Laboratory"},
      "standards": [{"quantity": "local_gravity", "certificate": "AG-2025-017",
                     "due": "2030-06-30"}, ...],
      "budgets": [{"coefficient": "K_F", "estimate": ..., "unit": "V", "u_c": ...,
                   "nu_eff": ..., "k": ..., "U": ..., "correlated": false,
                   "rows": [...]}, ...]
    }

``budgets`` holds :meth:`accelcal.budget.gum.Budget.as_dict` of each
coefficient; with the lab file of the same SHA-256 a certificate is reissued
from it identically (:mod:`accelcal.certificate`).

Complex coefficients (a frequency response's sensitivities) are written as
``format_version`` 2 with ``"complex": true``; a record of real
coefficients is still written as version 1, byte for byte as before, and
both versions are read. In version 2 every ``estimate`` is
``{"re": .., "im": ..}``, ``std`` and ``expanded`` are the magnitude's,
``magnitude``, ``phase_deg``, ``phase_std_deg`` and ``phase_expanded_deg``
are added (derived, like ``std`` and ``expanded``: recomputed on reading),
and ``covariance`` is the ``2p x 2p`` covariance of ``[Re x1, Im x1, Re x2,
...]`` (:mod:`accelcal.polar`)::

    {"format_version": 2, ..., "complex": true,
     "coefficients": [{"name": "S_80Hz", "unit": "V/g",
                       "estimate": {"re": 1.0012, "im": -0.0213},
                       "std": 4.1e-4, "expanded": 8.2e-4, "magnitude": 1.0014,
                       "phase_deg": -1.219, "phase_std_deg": 0.023,
                       "phase_expanded_deg": 0.046}],
     "covariance": [[1.7e-7, 2.0e-9], [2.0e-9, 1.6e-7]], ...}

An accelcal that reads only version 1 refuses such a record by its version
instead of misreading its covariance.
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
from accelcal.io.limits import MAX_JSON_BYTES, check_regular_file, load_json, read_bounded
from accelcal.io.record_checks import check_budget_block, check_type_b
from accelcal.method_ids import canonical
from accelcal.model import ErrorModel
from accelcal.polar import Polar, polar, real_names
from accelcal.validation import check_label, is_finite_number, shown, shown_name

FORMAT_VERSION = 1
COMPLEX_FORMAT_VERSION = 2
"""The version of a record of complex coefficients (real ones stay version 1)."""
KIND = "accelcal.CalibrationRecord"
_KEYS = {
    "format_version", "kind", "serial", "method", "date", "software", "operator",
    "coverage_factor", "coefficients", "covariance", "model", "inputs", "notes",
}
_OPTIONAL_KEYS = {"dof", "simulated", "complex", "budget"}
_COEFFICIENT_KEYS = {"name", "unit", "estimate", "std", "expanded"}
_OPTIONAL_COEFFICIENT_KEYS = {"plain", "type_b"}
_POLAR_KEYS = ("magnitude", "phase_deg", "phase_std_deg", "phase_expanded_deg")
"""Keys a complex coefficient adds, derived from its estimate and 2x2 block."""
_LABELS = (("serial", "serial number", 200), ("method", "method", 200),
           ("software", "software", 100), ("operator", "operator", 200))
"""Text fields, what they are called in messages and their longest length: the
widths of the records store's columns (:mod:`accelcal.store`)."""
_NAME_LENGTH, _UNIT_LENGTH = 100, 40
"""Longest coefficient name and unit (the store's column widths)."""


def file_sha256(path) -> str:
    """``sha256:<hex>`` of a file's bytes (a regular file: :func:`check_regular_file`)."""
    check_regular_file(path, "input file")
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
        Test method and reduction, e.g. ``"dividing-head/joint"``; an id of
        the older pattern (``"tumble-fourier"``) is read as its id today
        (:func:`accelcal.method_ids.canonical`).
    names : tuple of str
        Coefficient names.
    estimates : numpy.ndarray
        Estimates, shape ``(p,)``, real or complex.
    covariance : numpy.ndarray
        Covariance, shape ``(p, p)``; for complex estimates ``(2p, 2p)``,
        that of ``[Re x1, Im x1, Re x2, ...]`` (:mod:`accelcal.polar`).
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
    dof : int or None
        Degrees of freedom of the standard uncertainties (None: the noise
        level was given, or unknown in an older record).
    simulated : bool
        True when the input data were simulated.
    plain : dict
        The plain coefficient name of each row that estimates a combination
        (row name -> plain name, e.g. ``"K0+Kpp" -> "K0"``); written as the
        coefficient's ``plain`` key. A record made before combinations were
        named has none, and reads as before.
    budget : dict or None
        The budgets kept with the record (module docs: ``lab``, ``standards``,
        ``budgets``); None for a record without them.
    type_b : dict
        The combined Type B standard uncertainty of each row that has one
        (row name -> u_B, the row's unit): the part of its standard
        uncertainty the priors of unestimated terms contribute; written as
        the coefficient's ``type_b`` key. Rows without an entry have none
        recorded (older records read with an empty dict).
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
    dof: int | None = None
    simulated: bool = False
    plain: dict[str, str] = field(default_factory=dict)
    budget: dict | None = None
    type_b: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.serial, str) or not self.serial.strip():
            raise AccelcalError("calibration record: serial must be a non-empty string")
        for name, what, limit in _LABELS:
            try:
                check_label(getattr(self, name), what, file_name=name == "serial", limit=limit)
            except AccelcalError as exc:
                raise AccelcalError(f"calibration record: {exc}") from None
        object.__setattr__(self, "method", canonical(self.method))
        for name in self.names:
            check_label(name, "calibration record: coefficient name", limit=_NAME_LENGTH)
            check_label(self.units.get(name, ""), f"calibration record: unit of {name}",
                        limit=_UNIT_LENGTH)
        complex_ = np.iscomplexobj(self.estimates)
        est = np.asarray(self.estimates, dtype=complex if complex_ else float)
        if np.iscomplexobj(self.covariance):
            raise AccelcalError("calibration record: the covariance must be real (that of "
                                "[Re x1, Im x1, ...] for complex estimates)")
        cov = np.asarray(self.covariance, dtype=float)
        p = len(self.names)
        n = 2 * p if complex_ else p
        if est.shape != (p,) or cov.shape != (n, n):
            raise AccelcalError(
                f"calibration record: {p} coefficients need estimates ({p},) and covariance "
                f"({n}, {n}); got {est.shape} and {cov.shape}"
            )
        if not np.isfinite(est).all():
            raise AccelcalError("calibration record: estimates must be finite")
        if np.isinf(cov).any() or (np.diag(cov) < 0).any():
            raise AccelcalError(
                "calibration record: the covariance has infinite entries or negative variances "
                "(NaN marks an unknown one); the uncertainties could not be determined, check "
                "the inputs for values out of range"
            )
        _check_covariance(cov, real_names(self.names) if complex_ else self.names)
        if not (self.coverage_factor > 0 and math.isfinite(self.coverage_factor)):
            raise AccelcalError("calibration record: coverage_factor must be positive")
        _parse_date(self.date, "calibration record")
        object.__setattr__(self, "type_b", check_type_b(self.type_b, self.names, cov,
                                                        complex_))
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "estimates", est)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def is_complex(self) -> bool:
        """True for complex estimates (``format_version`` 2)."""
        return self.estimates.dtype.kind == "c"

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties (of the magnitudes, for complex estimates)."""
        if self.is_complex:
            return self.polar().magnitude_std
        return np.sqrt(np.diag(self.covariance))

    @property
    def expanded(self) -> np.ndarray:
        """Expanded uncertainties, ``coverage_factor * std``."""
        return self.coverage_factor * self.std

    @property
    def type_b_std(self) -> np.ndarray:
        """Each row's Type B standard uncertainty (NaN where the record states none)."""
        return np.array([self.type_b.get(n, math.nan) for n in self.names], dtype=float)

    @property
    def type_a_std(self) -> np.ndarray:
        """Each row's Type A standard uncertainty, ``sqrt(std^2 - type_b^2)``.

        The whole ``std`` where no Type B is recorded.
        """
        b = np.nan_to_num(self.type_b_std, nan=0.0)
        return np.sqrt(np.maximum(self.std**2 - b**2, 0.0))

    def polar(self) -> Polar:
        """Magnitudes and phases (rad) of complex estimates with first-order uncertainties."""
        if not self.is_complex:
            raise AccelcalError("calibration record: polar() is for complex estimates")
        return polar(self.estimates, self.covariance)

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
        """The record as a JSON-ready dict (format 2 for complex estimates, else 1)."""
        if self.is_complex:
            version, coefficients = COMPLEX_FORMAT_VERSION, self._complex_coefficients()
        else:
            version, coefficients = FORMAT_VERSION, [
                {"name": n, "unit": self.units.get(n, ""), "estimate": float(v),
                 "std": float(s), "expanded": float(u),
                 **({"plain": self.plain[n]} if n in self.plain else {}),
                 **({"type_b": self.type_b[n]} if n in self.type_b else {})}
                for n, v, s, u in zip(
                    self.names, self.estimates, self.std, self.expanded, strict=True
                )
            ]
        data = {
            "format_version": version,
            "kind": KIND,
            "serial": self.serial,
            "method": self.method,
            "date": self.date,
            "software": self.software,
            "operator": self.operator,
            "coverage_factor": self.coverage_factor,
            "coefficients": coefficients,
            "covariance": self.covariance.tolist(),
            "model": self.model.to_dict() if self.model is not None else None,
            "inputs": dict(self.inputs),
            "notes": list(self.notes),
            "dof": self.dof,
            "simulated": bool(self.simulated),
        }
        if self.is_complex:
            data["complex"] = True
        if self.budget is not None:
            data["budget"] = self.budget
        return data

    def _complex_coefficients(self) -> list[dict]:
        """The ``coefficients`` of format 2: estimate as ``{"re", "im"}``, magnitude, phase."""
        pol, k = self.polar(), self.coverage_factor
        return [
            {"name": n, "unit": self.units.get(n, ""), "estimate": {"re": v.real, "im": v.imag},
             "std": float(s), "expanded": float(k * s), "magnitude": float(m),
             "phase_deg": math.degrees(ph), "phase_std_deg": math.degrees(phs),
             "phase_expanded_deg": math.degrees(k * phs),
             **({"plain": self.plain[n]} if n in self.plain else {}),
             **({"type_b": self.type_b[n]} if n in self.type_b else {})}
            for n, v, m, s, ph, phs in zip(self.names, self.estimates.tolist(), pol.magnitude,
                                           pol.magnitude_std, pol.phase, pol.phase_std,
                                           strict=True)
        ]

    def to_json(self) -> str:
        """The record as JSON text (NaN covariance entries written as null)."""
        data = self.to_dict()
        data["covariance"] = [[None if math.isnan(x) else x for x in row]
                              for row in data["covariance"]]
        for c in data["coefficients"]:
            for key in ("std", "expanded", *_POLAR_KEYS):
                if key in c and math.isnan(c[key]):
                    c[key] = None
        return json.dumps(data, indent=2, allow_nan=False) + "\n"

    def save(self, path) -> None:
        """Write the record atomically."""
        write_text_atomic(path, self.to_json())

    @classmethod
    def from_json(cls, text: str, *, source: str = "<string>") -> "CalibrationRecord":
        """Parse and validate record text; errors name ``source`` and the field.

        The JSON is decoded by :func:`accelcal.io.limits.load_json` (bounded
        size and depth, only finite numbers).
        """
        return _from_dict(load_json(text, source), source)

    @classmethod
    def load(cls, path) -> "CalibrationRecord":
        """Read and validate a calibration record file.

        At most :data:`~accelcal.io.limits.MAX_JSON_BYTES` are read, so a
        device or a huge file is refused at once.
        """
        path = Path(path)
        try:
            text = read_bounded(path, MAX_JSON_BYTES, "calibration record").decode("utf-8")
        except FileNotFoundError:
            raise AccelcalError(f"calibration record {path} not found") from None
        except OSError as exc:
            raise AccelcalError(
                f"cannot read calibration record {path}: {exc.strerror or exc}") from None
        except UnicodeDecodeError:
            raise AccelcalError(f"cannot read calibration record {path}: not UTF-8 text") from None
        return cls.from_json(text, source=str(path))


def _from_dict(data, source: str) -> CalibrationRecord:

    def fail(msg):
        return AccelcalError(f"{source}: {msg}")

    if not isinstance(data, dict):
        raise fail("expected a JSON object")
    unknown = sorted(set(data) - _KEYS - _OPTIONAL_KEYS)
    if unknown:
        raise fail(f"unknown key(s) {', '.join(map(repr, unknown))}")
    missing = sorted(_KEYS - set(data))
    if missing:
        raise fail(f"missing key(s) {', '.join(map(repr, missing))}")
    if data["kind"] != KIND:
        raise fail(f"kind is {shown(data['kind'])}, expected {KIND!r}")
    version = data["format_version"]
    if isinstance(version, bool) or version not in (FORMAT_VERSION, COMPLEX_FORMAT_VERSION):
        raise fail(
            f"format_version {shown(version)} is not supported (this accelcal reads "
            f"{FORMAT_VERSION} and {COMPLEX_FORMAT_VERSION})"
        )
    complex_ = data.get("complex", False)
    if not isinstance(complex_, bool) or complex_ != (version == COMPLEX_FORMAT_VERSION):
        raise fail(f'format_version {COMPLEX_FORMAT_VERSION} is that of complex coefficients, '
                   f'with "complex": true (and only it); this record has format_version '
                   f'{version} and complex {shown(complex_)}')
    for key in ("serial", "method", "date", "software", "operator"):
        if not isinstance(data[key], str):
            raise fail(f"{key} must be a string")
    coefficients = data["coefficients"]
    if not isinstance(coefficients, list) or not coefficients:
        raise fail("coefficients must be a non-empty list")
    names, units, values, plain, type_b = [], {}, [], {}, {}
    keys = _COEFFICIENT_KEYS | set(_POLAR_KEYS) if complex_ else _COEFFICIENT_KEYS
    for i, c in enumerate(coefficients):
        if not isinstance(c, dict) or set(c) - _OPTIONAL_COEFFICIENT_KEYS != keys:
            raise fail(f"coefficients[{i}] must have exactly the keys {sorted(keys)} "
                       "(and optionally plain, type_b)")
        if complex_:
            x = c["estimate"]
            if not (isinstance(x, dict) and set(x) == {"re", "im"}
                    and is_finite_number(x["re"]) and is_finite_number(x["im"])):
                raise fail(f'coefficients[{i}].estimate must be {{"re": number, "im": number}}'
                           " of finite numbers")
        elif not is_finite_number(c["estimate"]):
            raise fail(f"coefficients[{i}].estimate must be a finite number")
        for key in ("std", "expanded", *(_POLAR_KEYS if complex_ else ())):
            if not (c[key] is None or is_finite_number(c[key])):
                raise fail(f"coefficients[{i}].{key} must be a finite number or null")
        for key in ("name", "unit", "plain"):
            if key in c and not isinstance(c[key], str):
                raise fail(f"coefficients[{i}].{key} must be a string")
        names.append(c["name"])
        units[c["name"]] = c["unit"]
        if "plain" in c:
            plain[c["name"]] = c["plain"]
        if "type_b" in c:
            if not is_finite_number(c["type_b"]):
                raise fail(f"coefficients[{i}].type_b must be a finite number")
            type_b[c["name"]] = float(c["type_b"])
        values.append(complex(c["estimate"]["re"], c["estimate"]["im"]) if complex_
                      else float(c["estimate"]))
    rows = data["covariance"]
    if not (isinstance(rows, list) and all(
            isinstance(row, list) and all(x is None or is_finite_number(x) for x in row)
            for row in rows)):
        raise fail("covariance must be a square list of lists of finite numbers (null for unknown)")
    try:
        cov = np.array([[math.nan if x is None else float(x) for x in row] for row in rows])
    except ValueError:
        raise fail("covariance must be a square list of lists of finite numbers (null for unknown)"
                   ) from None
    if not is_finite_number(data["coverage_factor"]):
        raise fail("coverage_factor must be a finite number")
    if not (isinstance(data["notes"], list) and all(isinstance(n, str) for n in data["notes"])):
        raise fail("notes must be a list of strings")
    dof = data.get("dof")
    if not (dof is None or (isinstance(dof, int) and not isinstance(dof, bool) and dof > 0)):
        raise fail("dof must be a positive integer or null")
    simulated = data.get("simulated", False)
    if not isinstance(simulated, bool):
        raise fail("simulated must be true or false")
    model = None
    if data["model"] is not None:
        model = ErrorModel.from_dict(data["model"], source=f"{source}: model")
    if not isinstance(data["inputs"], dict) or not all(
            isinstance(v, str) for v in data["inputs"].values()):
        raise fail("inputs must map file names to hashes")
    for name in data["inputs"]:
        check_label(name, f"{source}: input file name", limit=255)
    budget = data.get("budget")
    if budget is not None:
        check_budget_block(budget, fail)
    try:
        return CalibrationRecord(
            serial=data["serial"], method=data["method"], names=tuple(names),
            estimates=np.array(values), covariance=cov, units=units, date=data["date"],
            software=data["software"], operator=data["operator"],
            coverage_factor=float(data["coverage_factor"]), model=model,
            inputs=dict(data["inputs"]), notes=tuple(data["notes"]), dof=dof,
            simulated=simulated, plain=plain, budget=budget, type_b=type_b,
        )
    except AccelcalError as exc:
        raise fail(str(exc)) from None


COVARIANCE_RTOL = 1e-6
"""Relative tolerance of the covariance checks (:func:`_check_covariance`): far
above the rounding of a covariance computed in float64 and written with full
precision, far below any real asymmetry or correlation beyond 1."""


def _check_covariance(cov: np.ndarray, names) -> None:
    """Refuse a covariance that no set of uncertainties can have.

    It must be symmetric (to :data:`COVARIANCE_RTOL` of the larger of the
    two entries and of ``s_i s_j``, with unknown entries, NaN, in symmetric
    places), and every correlation ``c_ij / (s_i s_j)`` must lie within
    ``[-1, 1]`` (Cauchy-Schwarz), to the same tolerance, where it is defined
    (both variances known); a zero variance allows only off-diagonal entries
    at rounding level. Variances are checked to be >= 0 before.

    Raises
    ------
    AccelcalError
        Naming the first pair of coefficients at fault.
    """
    known = ~np.isnan(cov)
    with np.errstate(over="ignore", invalid="ignore"):
        s = np.sqrt(np.diag(cov))
        scale = np.fmax(np.fmax(np.abs(cov), np.abs(cov.T)), np.outer(s, s))
        asymmetric = (known != known.T) | (np.abs(cov - cov.T) > COVARIANCE_RTOL * scale)
        slack = 1e-9 * np.fmax.outer(s, s) ** 2
        beyond = known & (np.abs(cov) > (1 + COVARIANCE_RTOL) * np.outer(s, s) + slack)
    for bad, what in ((asymmetric, "is not symmetric"),
                      (beyond, "has a correlation beyond +/-1 (|c_ij| > s_i s_j)")):
        if bad.any():
            i, j = (int(k) for k in np.argwhere(bad)[0])
            raise AccelcalError(
                f"calibration record: the covariance {what} at {shown_name(names[i])}, "
                f"{shown_name(names[j])} ({cov[i, j]:.6g} and {cov[j, i]:.6g}, variances "
                f"{cov[i, i]:.6g} and {cov[j, j]:.6g}); no set of uncertainties has it"
            )


def _parse_date(text: str, where: str) -> _dt.datetime:
    try:
        return _dt.datetime.fromisoformat(text)
    except (TypeError, ValueError):
        raise AccelcalError(
            f"{where}: date {shown(text)} is not ISO 8601 (e.g. 2026-11-21T09:30:00+00:00)"
        ) from None


