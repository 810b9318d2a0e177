"""The lab file: the laboratory, its signatories and its declared measurement standards.

A lab file (TOML [TOML]_) states what a laboratory knows about the
standards and influence quantities its tests rely on, each with a value,
a unit, a standard uncertainty and degrees of freedom, so that a method's
measurement model can put them into an itemised budget (GUM [GUM]_)::

    [laboratory]
    name = "Inertial Sensors Laboratory"
    address = "..."
    accreditation = "DAkkS D-K-12345-01-00"

    [[signatory]]
    name = "A. Metrologist"
    role = "Head of laboratory"

    [customer]                      # optional
    name = "..."

    [environment]                   # free keys, reported as given
    temperature_degC = 23.0

    [[standard]]
    quantity = "local_gravity"      # one of QUANTITIES
    value = 9.80935
    unit = "m/s^2"
    U = 0.03                        # exactly one of: u | U and k | bounds and distribution
    k = 2
    uncertainty_unit = "mGal"       # optional: the uncertainty's unit (default: unit;
                                    # a relative unit, %, ppm: relative to the value)
    reliability = 0.1               # or dof = 50; neither: dof infinite
    certificate = "AG-2024-017"
    due = 2027-06-30
    description = "absolute-gravity survey at the tumble pier"

    [[correlation]]
    quantities = ["daq_gain", "load_resistor"]
    r = 0.2

Every error is one :class:`~accelcal.errors.AccelcalError` naming the
file and the entry.

References
----------
.. [GUM] JCGM 100:2008, Evaluation of measurement data - Guide to the
   expression of uncertainty in measurement, secs. 4.3, G.4.2.
.. [TOML] TOML v1.0.0 specification (https://toml.io); Python's :mod:`tomllib`.
"""

import datetime as _dt
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

from accelcal.budget.gum import DIVISORS, dof_from_reliability, from_bounds, from_expanded
from accelcal.errors import AccelcalError

MAX_BYTES = 1 << 20
"""Largest lab file read, bytes (a lab file is a few kilobytes)."""

_ARCSEC = math.pi / 648000.0
UNITS = {
    "acceleration": {"m/s^2": 1.0, "mGal": 1e-5, "uGal": 1e-8, "Gal": 1e-2,
                     "g": 9.80665, "mg": 9.80665e-3, "ug": 9.80665e-6},
    "angle": {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "deg": math.pi / 180.0,
              "arcmin": 60.0 * _ARCSEC, "arcsec": _ARCSEC},
    "relative": {"1": 1.0, "%": 1e-2, "ppm": 1e-6, "ppb": 1e-9},
    "voltage": {"V": 1.0, "mV": 1e-3, "uV": 1e-6},
    "resistance": {"ohm": 1.0, "kohm": 1e3, "Mohm": 1e6},
    "relative/temperature": {"1/degC": 1.0, "1/K": 1.0, "ppm/degC": 1e-6, "ppm/K": 1e-6},
    "temperature": {"degC": 1.0, "K": 1.0},
    "length": {"m": 1.0, "mm": 1e-3, "um": 1e-6},
    "rate": {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0},
    "frequency": {"Hz": 1.0, "kHz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "sensitivity": {"V/g": 1.0, "mV/g": 1e-3, "mV/(m/s^2)": 9.80665e-3},
    "charge sensitivity": {"pC/g": 1.0, "pC/(m/s^2)": 9.80665},
    "coil constant": {"mT/A": 1.0, "uT/A": 1e-3, "T/A": 1e3, "G/A": 0.1},
}
"""Units of each dimension with their size in the dimension's first unit.

Temperatures: a value in degC or K is used as given (the models use
differences from a reference temperature, the same in either unit)."""

QUANTITIES = {
    "local_gravity": (("acceleration",), "m/s^2",
                      "local gravity at the test position (absolute-gravity survey)"),
    "head_angle": (("angle",), "arcsec",
                   "angle error of each indexing-head or rate-table position (one per position)"),
    "head_repeatability": (("angle",), "arcsec",
                           "repeatability of a head or tilt-table position (one error per visit)"),
    "head_axis_tilt": (("angle",), "arcsec", "tilt of the head's rotation axis from level"),
    "autocollimator": (("angle",), "arcsec", "autocollimator or polygon reading of a position"),
    "daq_gain": (("relative",), "ppm", "relative gain error of the data acquisition"),
    "daq_offset": (("voltage",), "uV", "offset of the data acquisition"),
    "daq_linearity": (("relative",), "ppm", "integral nonlinearity of the data acquisition"),
    "daq_resolution": (("voltage",), "uV",
                       "quantization error of a reading (half the least significant bit)"),
    "load_resistor": (("resistance", "relative"), "ohm",
                      "load resistor of a current-output accelerometer (V = I R)"),
    "load_resistor_tc": (("relative/temperature",), "ppm/degC",
                         "temperature coefficient of the load resistor"),
    "sensor_temperature": (("temperature",), "degC", "the sensor's temperature during the test"),
    "centrifuge_radius": (("length",), "m", "radius of the centrifuge arm to the sensor"),
    "centrifuge_rate": (("rate", "relative"), "rad/s", "rotation rate of the centrifuge"),
    "reference_sensitivity": (("sensitivity", "charge sensitivity", "relative"), "mV/g",
                              "sensitivity of the reference accelerometer (shaker)"),
    "reference_phase": (("angle",), "deg", "phase of the reference accelerometer (shaker)"),
    "frequency": (("frequency", "relative"), "Hz", "frequency of the excitation"),
    "daq_gain_mismatch": (("relative",), "ppm",
                          ("gain of the DUT's DAQ channel relative to the reference's, beyond "
                          "the correction the record states")),
    "daq_delay_mismatch": (("time",), "ns",
                           ("delay of the DUT's DAQ channel behind the reference's, beyond the "
                           "correction the record states")),
    "transverse_motion": (("relative",), "%",
                          ("the shaker's transverse acceleration along the DUT's most sensitive "
                          "transverse axis, of the axial (each quadrature component)")),
    "transverse_sensitivity": (("relative",), "%", "the DUT's largest transverse sensitivity"),
    "distortion": (("relative",), "%",
                   ("harmonic distortion of the shaker's motion (each of the 2nd and 3rd "
                   "harmonics, of the fundamental)")),
    "relative_motion": (("relative",), "%",
                        ("motion of the DUT relative to the reference's, of the axial (each "
                        "quadrature component)")),
    "sensitivity_tc": (("relative/temperature",), "ppm/degC",
                       "temperature coefficient of the DUT's sensitivity"),
    "coil_constant": (("coil constant", "relative"), "mT/A",
                      "field per ampere of the Helmholtz coils (the applied field's scale)"),
}
"""The vocabulary of input quantities: ``name -> (dimensions, usual unit, meaning)``."""


@dataclass(frozen=True)
class Standard:
    """A declared measurement standard or influence quantity.

    Attributes
    ----------
    quantity : str
        One of :data:`QUANTITIES`.
    value, u : float
        Estimate and standard uncertainty, both in ``unit``.
    unit : str
    distribution : str
        ``normal``, ``rectangular``, ``triangular`` or ``u-shaped``.
    dof : float
        Degrees of freedom (``inf`` when not stated).
    certificate : str
    due : datetime.date or None
        Calibration due date.
    description : str
    source : str
        How the uncertainty was stated (``"u = ..."``, ``"U = ... (k = 2)"``, ...).
    """

    quantity: str
    value: float
    unit: str
    u: float
    distribution: str = "normal"
    dof: float = math.inf
    certificate: str = ""
    due: _dt.date | None = None
    description: str = ""
    source: str = ""

    @property
    def dimension(self) -> str:
        """The dimension of ``unit`` (a key of :data:`UNITS`)."""
        return _dimension(self.unit)

    def value_in(self, unit: str) -> float:
        """The value in another unit of the same dimension."""
        return self.value * self.factor(unit)

    def u_in(self, unit: str) -> float:
        """The standard uncertainty in another unit of the same dimension."""
        return self.u * self.factor(unit)

    def factor(self, unit: str) -> float:
        """Size of one ``self.unit`` in ``unit`` (same dimension), e.g. 1e-6 from ppm to 1."""
        dim = self.dimension
        if unit not in UNITS[dim]:
            raise AccelcalError(f"{self.quantity}: cannot express {self.unit} in {unit}")
        return UNITS[dim][self.unit] / UNITS[dim][unit]


@dataclass(frozen=True)
class Laboratory:
    """The laboratory issuing the results."""

    name: str
    address: str = ""
    accreditation: str = ""


@dataclass(frozen=True)
class Signatory:
    """An authorised signatory."""

    name: str
    role: str = ""


@dataclass(frozen=True)
class Lab:
    """A lab file, read and checked (:func:`load_lab`).

    Attributes
    ----------
    laboratory : Laboratory
    signatories : tuple of Signatory
    environment : dict
        As given (e.g. ``temperature_degC``, ``humidity_percent``).
    customer : dict or None
        As given (``name``, ``address``, ...).
    standards : dict
        ``quantity -> Standard``.
    correlations : dict
        ``(quantity_a, quantity_b) -> r``.
    sha256 : str
        Hex digest of the file's bytes.
    path : pathlib.Path
    """

    laboratory: Laboratory
    signatories: tuple[Signatory, ...]
    environment: dict
    customer: dict | None
    standards: dict
    correlations: dict
    sha256: str
    path: Path
    notes: tuple[str, ...] = field(default=())

    def expired(self, on: _dt.date | None = None) -> list[Standard]:
        """The standards whose due date is before ``on`` (default: today)."""
        on = on or _dt.date.today()
        return [s for s in self.standards.values() if s.due is not None and s.due < on]

    def check_due(self, on: _dt.date | None = None, quantities=None) -> None:
        """Raise :class:`AccelcalError` naming the expired standards, if any.

        ``quantities``: only those (a method's inputs); default every one.
        """
        late = [s for s in self.expired(on) if quantities is None or s.quantity in quantities]
        if late:
            names = ", ".join(f"{s.quantity} (certificate {s.certificate or '?'}, due {s.due})"
                              for s in late)
            raise AccelcalError(f"{self.path.name}: expired standard(s): {names}; recalibrate "
                                "them or allow expired standards explicitly",
                                parameter="lab")


def empty_lab() -> Lab:
    """A lab declaring nothing (a budget of the Type A part and the priors only)."""
    return Lab(Laboratory(""), (), {}, None, {}, {}, "", Path())


def _dimension(unit: str) -> str:
    for dim, units in UNITS.items():
        if unit in units:
            return dim
    raise AccelcalError(f"unknown unit {unit!r}")


def _fail(where: str, message: str) -> AccelcalError:
    return AccelcalError(f"{where}: {message}", parameter="lab")


def _number(where: str, entry: dict, key: str, *, positive: bool = False) -> float:
    value = entry[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(where, f"{key} = {value!r} is not a number")
    value = float(value)
    if not math.isfinite(value):
        raise _fail(where, f"{key} = {value} is not finite")
    if positive and value < 0:
        raise _fail(where, f"{key} = {value} is negative")
    return value


def _text(where: str, entry: dict, key: str, default: str = "") -> str:
    value = entry.get(key, default)
    if not isinstance(value, str):
        raise _fail(where, f"{key} = {value!r} is not a string")
    return value


_STANDARD_KEYS = {"quantity", "value", "unit", "u", "U", "k", "bounds", "distribution",
                  "uncertainty_unit", "dof", "reliability", "certificate", "due",
                  "description"}


def _standard(where: str, entry: dict) -> Standard:
    unknown = sorted(set(entry) - _STANDARD_KEYS)
    if unknown:
        raise _fail(where, f"unknown key(s) {', '.join(unknown)}; expected "
                    f"{', '.join(sorted(_STANDARD_KEYS))}")
    for key in ("quantity", "value", "unit"):
        if key not in entry:
            raise _fail(where, f"missing {key}")
    quantity = _text(where, entry, "quantity")
    if quantity not in QUANTITIES:
        raise _fail(where, f"unknown quantity {quantity!r}; one of {', '.join(QUANTITIES)}")
    where = f"{where} ({quantity})"
    value = _number(where, entry, "value")
    unit = _text(where, entry, "unit")
    dims = QUANTITIES[quantity][0]
    fits = [d for d in dims if unit in UNITS[d]]
    if not fits:
        allowed = ", ".join(u for d in dims for u in UNITS[d])
        raise _fail(where, f"unit {unit!r} does not fit {quantity}; use one of {allowed}")
    u_unit = _text(where, entry, "uncertainty_unit", unit)
    relative_u = u_unit not in UNITS[fits[0]] and u_unit in UNITS["relative"]
    if u_unit not in UNITS[fits[0]] and not relative_u:
        raise _fail(where, f"uncertainty_unit {u_unit!r} does not fit unit {unit!r}; use one "
                    f"of {', '.join([*UNITS[fits[0]], *UNITS['relative']])}")
    forms = [f for f in ("u", "U", "bounds") if f in entry]
    if len(forms) != 1:
        raise _fail(where, "state the uncertainty exactly once: u (standard), U with k "
                    "(expanded) or bounds with distribution" +
                    (f"; got {' and '.join(forms)}" if forms else ""))
    distribution = _text(where, entry, "distribution", "normal")
    if forms == ["u"]:
        if "k" in entry:
            raise _fail(where, "k belongs to an expanded U, not to a standard u")
        u = _number(where, entry, "u", positive=True)
        source = f"u = {entry['u']} {u_unit}"
    elif forms == ["U"]:
        if "k" not in entry:
            raise _fail(where, "an expanded U needs its coverage factor k")
        U = _number(where, entry, "U", positive=True)
        k = _number(where, entry, "k")
        if k <= 0:
            raise _fail(where, f"k = {k} must be > 0")
        u = from_expanded(U, k)
        source = f"U = {entry['U']} {u_unit} (k = {entry['k']})"
    else:
        if "k" in entry:
            raise _fail(where, "k belongs to an expanded U, not to bounds")
        if "distribution" not in entry or distribution == "normal":
            raise _fail(where, "bounds need a distribution: rectangular, triangular or "
                        "u-shaped")
        a = _number(where, entry, "bounds", positive=True)
        u = from_bounds(a, distribution) if distribution in DIVISORS else math.nan
        source = f"bounds +-{entry['bounds']} {u_unit} ({distribution})"
    if distribution not in DIVISORS:
        raise _fail(where, f"distribution {distribution!r}: one of {', '.join(DIVISORS)}")
    if relative_u:  # a relative uncertainty of the value
        u *= UNITS["relative"][u_unit] * abs(value)
    else:
        u *= UNITS[fits[0]][u_unit] / UNITS[fits[0]][unit]
    if "dof" in entry and "reliability" in entry:
        raise _fail(where, "state dof or reliability, not both")
    dof = math.inf
    if "dof" in entry:
        dof = _number(where, entry, "dof")
        if not dof > 0:
            raise _fail(where, f"dof = {dof} must be > 0")
    elif "reliability" in entry:
        rel = _number(where, entry, "reliability")
        if not rel > 0:
            raise _fail(where, f"reliability = {rel} must be > 0 (relative, e.g. 0.1)")
        dof = dof_from_reliability(rel)
    due = entry.get("due")
    if due is not None:
        if isinstance(due, _dt.datetime):
            due = due.date()
        elif isinstance(due, str):
            try:
                due = _dt.date.fromisoformat(due)
            except ValueError:
                raise _fail(where, f"due = {due!r} is not a date (YYYY-MM-DD)") from None
        elif not isinstance(due, _dt.date):
            raise _fail(where, f"due = {due!r} is not a date (YYYY-MM-DD)")
    return Standard(quantity, value, unit, u, distribution, dof,
                    _text(where, entry, "certificate"), due,
                    _text(where, entry, "description"), source)


def _section(doc: dict, key: str, name: str, *, kind=dict, required: bool = True):
    value = doc.get(key)
    if value is None:
        if required:
            raise _fail(name, f"missing [{key}]")
        return None
    if not isinstance(value, kind):
        shape = f"[[{key}]]" if kind is list else f"[{key}]"
        raise _fail(name, f"{key} has the wrong shape ({shape} expected)")
    return value


def load_lab(path) -> Lab:
    """Read and check a lab file.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    Lab

    Raises
    ------
    AccelcalError
        One line naming the file, the entry and what is wrong: a missing
        or unknown key, two uncertainty forms, a unit that does not fit the
        quantity, a negative or non-finite number, a duplicate quantity, a
        correlation outside [-1, 1] or naming an undeclared quantity. Due
        dates are not checked here (:meth:`Lab.check_due`).
    """
    import tomllib

    path = Path(path)
    name = path.name
    from accelcal.io.limits import read_bounded

    try:
        data = read_bounded(path, MAX_BYTES, "lab file")
    except AccelcalError as exc:
        raise AccelcalError(exc.message, parameter="lab") from None
    except OSError as exc:
        raise AccelcalError(f"cannot read lab file {path}: {exc.strerror or exc}",
                            parameter="lab") from None
    try:
        doc = tomllib.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise _fail(name, f"not a TOML file: {exc}") from None
    known = {"laboratory", "signatory", "customer", "environment", "standard", "correlation"}
    unknown = sorted(set(doc) - known)
    if unknown:
        raise _fail(name, f"unknown section(s) {', '.join(unknown)}; expected "
                    f"{', '.join(sorted(known))}")
    lab_doc = _section(doc, "laboratory", name)
    if "name" not in lab_doc:
        raise _fail(f"{name} [laboratory]", "missing name")
    laboratory = Laboratory(_text(name, lab_doc, "name"), _text(name, lab_doc, "address"),
                            _text(name, lab_doc, "accreditation"))
    signatories = []
    for i, s in enumerate(_section(doc, "signatory", name, kind=list, required=False) or []):
        where = f"{name} [[signatory]] {i + 1}"
        if not isinstance(s, dict) or "name" not in s:
            raise _fail(where, "missing name")
        signatories.append(Signatory(_text(where, s, "name"), _text(where, s, "role")))
    customer = _section(doc, "customer", name, required=False)
    environment = _section(doc, "environment", name, required=False) or {}
    standards: dict[str, Standard] = {}
    entries = _section(doc, "standard", name, kind=list, required=False) or []
    for i, entry in enumerate(entries):
        where = f"{name} [[standard]] {i + 1}"
        if not isinstance(entry, dict):
            raise _fail(where, "not a table")
        std = _standard(where, entry)
        if std.quantity in standards:
            raise _fail(where, f"quantity {std.quantity} is declared twice")
        standards[std.quantity] = std
    correlations = {}
    for i, entry in enumerate(_section(doc, "correlation", name, kind=list,
                                       required=False) or []):
        where = f"{name} [[correlation]] {i + 1}"
        if not isinstance(entry, dict) or "quantities" not in entry or "r" not in entry:
            raise _fail(where, "needs quantities = [a, b] and r")
        pair = entry["quantities"]
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(q, str) for q in pair) or pair[0] == pair[1]):
            raise _fail(where, f"quantities = {pair!r}: name two different quantities")
        for q in pair:
            if q not in standards:
                raise _fail(where, f"{q!r} is not a declared standard")
        r = _number(where, entry, "r")
        if not -1.0 <= r <= 1.0:
            raise _fail(where, f"r = {r} is outside [-1, 1]")
        key = tuple(pair)
        if key in correlations or key[::-1] in correlations:
            raise _fail(where, f"correlation of {pair[0]} and {pair[1]} is declared twice")
        correlations[key] = r
    return Lab(laboratory, tuple(signatories), dict(environment),
               dict(customer) if customer is not None else None, standards, correlations,
               hashlib.sha256(data).hexdigest(), path)
