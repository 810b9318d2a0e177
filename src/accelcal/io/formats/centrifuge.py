"""Centrifuge records: files of kind ``centrifuge`` and their data type :class:`CentrifugeRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``centrifuge`` holds
the readings of a precision centrifuge test (IEEE Std 836), one row per
reading (each reading the output averaged over whole revolutions). Columns:

``step`` (-)
    Index of the (position, level) step the reading belongs to.
``position`` (-)
    Index of the sensor's position on the arm in the metadata ``positions``.
``level`` (g)
    Nominal centripetal level of the step, ``Omega^2 R0 / g_n``.
``rate_rad_s`` (rad/s; unit field ``-``: record units have no rad/s)
    Measured spin rate of the reading.
``output`` (output unit)
    The accelerometer's output.
``spinup`` (-), optional
    1 for readings taken while the rate was still changing (spin-up or
    spin-down at the start or end of a step): the reductions exclude them.
    A spin-up reading between steady readings of one step is refused.

Metadata: ``radius_m`` (nominal radius R0 of the sensor's reference point,
m), ``output_unit``, ``positions`` (a list of ``{"name": ...}`` for the
named positions, or ``{"name": ..., "angles_deg": [yaw, pitch, roll]}``),
optional ``survey`` (rig errors measured by a survey: name ->
``{"value": v, "sd": u}``; names ``radius_error``, ``arm_stretch``,
``proof_mass_offset``, ``misalignment``), optional ``simulation`` (the true
rig and model of a simulated file) and the laboratory fields
(:mod:`accelcal.io.lab_metadata`).

:meth:`CentrifugeRecord.steps` averages the steady readings of each step
(O(n)) and checks the steps: one position and level each, no spin-up
inside, rates that agree with the radius and the level.

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
"""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.units import OUTPUT_UNITS, STANDARD_GRAVITY
from accelcal.validation import check_label, is_finite_number, shown

KIND = "centrifuge"

IMPORT = ImportLayout()
"""How ``accelcal import`` makes this kind from a recording."""

COLUMNS = ("step", "position", "level", "rate_rad_s", "output")
_RESERVED = ("format_version", "kind", "units", "radius_m", "output_unit", "positions", "survey")

MAX_OUTPUT = 1e9
"""Largest magnitude of an output (any output unit)."""
MAX_LEVEL = 1e5
"""Largest level, g (shock-test levels; precision centrifuges reach about 200 g)."""
MAX_RATE = 1e4
"""Largest rate, rad/s (about 95,000 rpm)."""
MAX_RADIUS = 100.0
"""Largest arm radius, m."""
MIN_RADIUS = 0.01
"""Smallest arm radius, m (a precision centrifuge's arm is about 0.5-3 m)."""
MIN_SD = 1e-15
"""Smallest non-zero standard uncertainty of a rig error (SI units): far below any survey,
and large enough that its inverse square (a weight) is a normal float."""
MAX_POSITIONS = 1000
MAX_STEPS = 2**31 - 1
RATE_TOLERANCE = 0.02
"""Largest relative disagreement of ``Omega^2 R0 / g_n`` with a step's level: rig errors
are parts in 1e4; 2 % means a wrong radius, wrong levels or a wrong rate unit."""
SURVEY_NAMES = ("radius_error", "arm_stretch", "proof_mass_offset", "misalignment")


class StepMeans(NamedTuple):
    """The steady readings of each step, averaged (arrays of shape ``(S,)``)."""

    position: np.ndarray
    """Position index of each step."""
    level: np.ndarray
    """Nominal level, g."""
    rate2: np.ndarray
    """Mean of the squared rate over the steady readings, (rad/s)^2."""
    output: np.ndarray
    """Mean output, output unit."""
    count: np.ndarray
    """Number of steady readings averaged."""
    step: np.ndarray
    """The step numbers, in increasing order."""


@dataclass(frozen=True)
class CentrifugeRecord:
    """The readings of a centrifuge test.

    Attributes
    ----------
    step, position, level, rate, output, spinup : numpy.ndarray, shape (n,)
        Columns (``rate`` is ``rate_rad_s``; ``spinup`` 0 or 1).
    positions : tuple of dict
        ``{"name": str}`` or ``{"name": str, "angles_deg": [3 floats]}``.
    radius_m : float
        Nominal radius R0, m.
    output_unit : str
    survey : dict
        Rig errors from a survey: name -> ``{"value", "sd"}``.
    metadata : dict
        Other metadata (``simulation``, laboratory fields, ...).
    """

    step: np.ndarray
    position: np.ndarray
    level: np.ndarray
    rate: np.ndarray
    output: np.ndarray
    spinup: np.ndarray
    positions: tuple
    radius_m: float
    output_unit: str
    survey: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        arrays = [np.array(getattr(self, n), dtype=float).reshape(-1) for n in
                  ("step", "position", "level", "rate", "output", "spinup")]
        if len({a.size for a in arrays}) != 1:
            raise AccelcalError("a centrifuge record needs columns of equal length")
        for name, a in zip(("step", "position", "level", "rate", "output", "spinup"), arrays,
                           strict=True):
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "positions", tuple(dict(p) for p in self.positions))

    @property
    def position_names(self) -> tuple[str, ...]:
        """Names of the positions."""
        return tuple(p["name"] for p in self.positions)

    def steps(self) -> StepMeans:
        """Average the steady readings of each step (O(n)); see the module notes.

        Raises
        ------
        AccelcalError
            For no readings, a step whose rows disagree on position or level, a
            step without steady readings, a spin-up reading between steady
            readings of one step, or a step whose rate disagrees with the
            radius and its level by more than :data:`RATE_TOLERANCE`.
        """
        if self.step.size == 0:
            raise AccelcalError("the centrifuge record has no readings")
        steps, inv = np.unique(self.step, return_inverse=True)
        first = np.full(steps.size, self.step.size)
        np.minimum.at(first, inv, np.arange(self.step.size))
        for col, what in ((self.position, "position"), (self.level, "level")):
            bad = np.flatnonzero(col != col[first][inv])
            if bad.size:
                raise AccelcalError(
                    f"step {int(self.step[bad[0]])} has readings at different {what}s (row "
                    f"{int(bad[0])}); give each (position, level) step its own step number")
        steady = self.spinup == 0
        count = np.bincount(inv, weights=steady, minlength=steps.size)
        if (count == 0).any():
            s = int(steps[np.flatnonzero(count == 0)[0]])
            raise AccelcalError(f"step {s} has no steady reading (every one is marked spinup); "
                                "record readings after the rate has settled")
        rows = np.arange(self.step.size)
        lo = np.full(steps.size, self.step.size)
        hi = np.full(steps.size, -1)
        np.minimum.at(lo, inv[steady], rows[steady])
        np.maximum.at(hi, inv[steady], rows[steady])
        inside = ~steady & (rows > lo[inv]) & (rows < hi[inv])
        if inside.any():
            r = int(np.flatnonzero(inside)[0])
            raise AccelcalError(
                f"step {int(self.step[r])}: a spin-up reading (row {r}) lies between steady "
                "readings: the rate changed during the step; split it into two steps or drop "
                "the step")
        w = steady.astype(float)
        rate2 = np.bincount(inv, weights=w * self.rate**2, minlength=steps.size) / count
        out = np.bincount(inv, weights=w * self.output, minlength=steps.size) / count
        level = self.level[first]
        implied = rate2 * self.radius_m / STANDARD_GRAVITY
        off = np.abs(implied - level) > RATE_TOLERANCE * np.maximum(level, 1.0)
        if off.any():
            k = int(np.flatnonzero(off)[0])
            raise AccelcalError(
                f"step {int(steps[k])}: rate {np.sqrt(rate2[k]):.6g} rad/s at radius "
                f"{self.radius_m:g} m gives {implied[k]:.6g} g, not the stated level "
                f"{level[k]:.6g} g; check the radius, the levels and the rate unit (rad/s)")
        return StepMeans(self.position[first].astype(int), level, rate2, out,
                         count.astype(int), steps.astype(int))


def write(path, data: CentrifugeRecord) -> None:
    """Write a centrifuge record file (atomically; CSV, or Parquet for ``.parquet``)."""
    meta = {
        "units": {"step": "-", "position": "-", "level": "g", "rate_rad_s": "-",
                  "output": data.output_unit, "spinup": "-"},
        "radius_m": data.radius_m, "output_unit": data.output_unit,
        "positions": [dict(p) for p in data.positions],
        **({"survey": data.survey} if data.survey else {}),
        **{k: v for k, v in data.metadata.items() if k not in _RESERVED},
    }
    columns = {"step": data.step, "position": data.position, "level": data.level,
               "rate_rad_s": data.rate, "output": data.output, "spinup": data.spinup}
    write_record(path, KIND, meta, columns)


def read(path) -> CentrifugeRecord:
    """Read and validate a centrifuge record file.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; bad
        ``radius_m``, ``output_unit``, ``positions`` or ``survey``;
        values beyond physical limits; non-integer steps, positions out of
        range, ``spinup`` other than 0/1; malformed laboratory metadata.
    """
    meta, cols = read_record(path, KIND, required_metadata=("radius_m", "output_unit",
                                                            "positions"),
                             required_columns=COLUMNS)
    radius = meta["radius_m"]
    if not (is_finite_number(radius) and MIN_RADIUS <= radius <= MAX_RADIUS):
        raise AccelcalError(f"{path}: metadata radius_m {shown(radius)} is not a radius in m "
                            f"({MIN_RADIUS:g} <= R <= {MAX_RADIUS:g})")
    if meta["output_unit"] not in OUTPUT_UNITS:
        raise AccelcalError(f"{path}: metadata output_unit {shown(meta['output_unit'])} is not "
                            f"one of {', '.join(OUTPUT_UNITS)}")
    positions = check_positions(meta["positions"], f"{path}: metadata positions")
    survey = check_survey(meta.get("survey", {}), f"{path}: metadata survey")
    check_lab_metadata(meta, path)
    spinup = cols.get("spinup", np.zeros_like(cols["step"]))
    limits = (("output", cols["output"], MAX_OUTPUT), ("level", cols["level"], MAX_LEVEL),
              ("rate_rad_s", cols["rate_rad_s"], MAX_RATE))
    for name, values, limit in limits:
        big = np.flatnonzero(~(np.abs(values) <= limit))
        if big.size:
            raise AccelcalError(f"{path}: column {name} row {int(big[0])} = "
                                f"{values[big[0]]:.6g} is beyond any physical value (up to "
                                f"{limit:g}); is the file corrupt?")
    for name, values, top in (("step", cols["step"], MAX_STEPS),
                              ("position", cols["position"], len(positions) - 1),
                              ("spinup", spinup, 1)):
        bad = np.flatnonzero((values != np.round(values)) | (values < 0) | (values > top))
        if bad.size:
            raise AccelcalError(f"{path}: column {name} row {int(bad[0])} = "
                                f"{values[bad[0]]:.6g} is not an integer from 0 to {top}")
    if (cols["level"] < 0).any():
        raise AccelcalError(f"{path}: column level has negative values; levels are >= 0 g")
    return CentrifugeRecord(
        step=cols["step"], position=cols["position"], level=cols["level"],
        rate=cols["rate_rad_s"], output=cols["output"], spinup=spinup, positions=positions,
        radius_m=float(radius), output_unit=meta["output_unit"], survey=survey,
        metadata={k: v for k, v in meta.items() if k not in _RESERVED})


def check_positions(value, where: str, parameter: str | None = None) -> tuple[dict, ...]:
    """A positions list: each ``{"name"}`` or ``{"name", "angles_deg"}``, names unique."""
    if not isinstance(value, list) or not 0 < len(value) <= MAX_POSITIONS:
        raise AccelcalError(f"{where} must be a list of 1 to {MAX_POSITIONS} positions",
                            parameter=parameter)
    out = []
    for k, p in enumerate(value):
        if not isinstance(p, dict) or set(p) - {"name", "angles_deg"} or "name" not in p:
            raise AccelcalError(f"{where}[{k}] {shown(p)} must be {{\"name\": ...}} with "
                                "optional \"angles_deg\": [yaw, pitch, roll]", parameter=parameter)
        check_label(p["name"], f"{where}[{k}] name")
        item = {"name": p["name"]}
        if "angles_deg" in p:
            a = p["angles_deg"]
            if not (isinstance(a, list) and len(a) == 3 and all(is_finite_number(x)
                                                                and abs(x) <= 720 for x in a)):
                raise AccelcalError(f"{where}[{k}] angles_deg {shown(a)} must be three "
                                    "angles within +-720 deg", parameter=parameter)
            item["angles_deg"] = [float(x) for x in a]
        out.append(item)
    names = [p["name"] for p in out]
    if len(set(names)) != len(names):
        raise AccelcalError(f"{where} repeat a name; give each position its own",
                            parameter=parameter)
    return tuple(out)


def check_survey(value, where: str) -> dict:
    """A survey: name -> ``{"value", "sd"}`` (finite, SD >= 0; names :data:`SURVEY_NAMES`)."""
    if not isinstance(value, dict):
        raise AccelcalError(f"{where} must be an object name -> {{\"value\", \"sd\"}}")
    out = {}
    for name, item in value.items():
        if name not in SURVEY_NAMES:
            raise AccelcalError(f"{where}: {shown(name)} is not one of {', '.join(SURVEY_NAMES)}")
        if not (isinstance(item, dict) and set(item) == {"value", "sd"}
                and is_finite_number(item["value"]) and is_finite_number(item["sd"])
                and (item["sd"] == 0 or MIN_SD <= item["sd"] <= 1.0)
                and abs(item["value"]) <= 1.0):
            raise AccelcalError(f"{where}: {name} {shown(item)} must be {{\"value\": v, "
                                f"\"sd\": u}} with |v| <= 1 and u 0 or {MIN_SD:g} to 1 (SI "
                                "units)")
        out[name] = {"value": float(item["value"]), "sd": float(item["sd"])}
    return out
