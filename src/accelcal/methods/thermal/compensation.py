"""The compensation model (JSON) and its application to a recording with a temperature column.

A compensation model holds the bias and scale-factor polynomials of one
accelerometer about a reference temperature, the range they are valid over
and their units. Applied to an output E (output unit) read at sensor
temperature T (degC), it gives the indicated acceleration along the input
axis ::

    a_i = E / K1(T) - K0(T),   K1(T) = K1 (1 + sum_k K1_Tk dT^k),
                               K0(T) = K0 + sum_k K0_Tk dT^k,  dT = T - T0    # Eq. (5) [DOMAIN]

(the first-order inverse of the model along IA: nonlinearity and cross-axis
terms are not compensated). File (``format_version`` 1)::

    {"format_version": 1, "kind": "accelcal.ThermalCompensation",
     "output_unit": "V", "reference_degC": 25.0, "valid_range_degC": [-40.0, 70.0],
     "units": {"K0": "g", "K0_T1": "g/degC", "K1": "V/g", "K1_T1": "1/degC", ...},
     "coefficients": {"K0": ..., "K0_T1": ..., "K1": ..., "K1_T1": ...},
     "equation": "...", "description": "..."}

References
----------
.. [DOMAIN] accelcal domain notes, section 8 (the compensation model).
.. [IEEE1293] IEEE Std 1293-2018, thermal sensitivity of bias and scale factor.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.terms import TEMPERATURE_TERMS, TemperatureTerms, check_temperature, term_unit
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import is_finite_number, shown

KIND = "accelcal.ThermalCompensation"
FORMAT_VERSION = 1
EQUATION = ("a_i [g] = E / (K1 (1 + sum_k K1_Tk dT^k)) - (K0 + sum_k K0_Tk dT^k), "
            "dT = T - T0 [degC]")
_KEYS = ("format_version", "kind", "output_unit", "reference_degC", "valid_range_degC",
         "coefficients")
_OPTIONAL = ("units", "equation", "description")
_NAMES = ("K0", "K1", *(n for n in TEMPERATURE_TERMS if n[:2] in ("K0", "K1")))


@dataclass(frozen=True)
class Compensation:
    """Bias and scale-factor polynomials, reference temperature and valid range.

    Attributes
    ----------
    output_unit : str
    reference : float
        T0, degC.
    valid_range : tuple of float
        ``(low, high)``, degC.
    coefficients : dict
        ``K0`` (g), ``K1`` (output unit per g), ``K0_Tk`` (g/degC^k),
        ``K1_Tk`` (relative, 1/degC^k).
    description : str
    """

    output_unit: str
    reference: float
    valid_range: tuple
    coefficients: dict = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        c = dict(self.coefficients)
        if self.output_unit not in OUTPUT_UNITS:
            raise AccelcalError(f"output_unit {shown(self.output_unit)} is not one of "
                                f"{', '.join(OUTPUT_UNITS)}")
        if "K0" not in c or "K1" not in c or c["K1"] == 0:
            raise AccelcalError("a compensation needs K0 and a non-zero K1")
        # the shared validation of names, values, reference and range
        terms = TemperatureTerms(self.reference, {k: v for k, v in c.items()
                                                  if k not in ("K0", "K1")}, self.valid_range)
        if terms.valid_range is None:
            raise AccelcalError("a compensation needs its valid range (low, high), degC")
        object.__setattr__(self, "_terms", terms)
        object.__setattr__(self, "reference", terms.reference)
        object.__setattr__(self, "valid_range", terms.valid_range)
        object.__setattr__(self, "coefficients", {n: float(c[n]) for n in _NAMES if n in c})

    @classmethod
    def from_model(cls, model, description: str = "") -> "Compensation":
        """The bias and scale-factor part of an ErrorModel with temperature terms and a range."""
        tt = model.temperature
        if tt is None or tt.valid_range is None:
            raise AccelcalError("the model has no temperature terms with a valid range; a "
                                "compensation needs both (a thermal reduction's model has "
                                "them)", parameter="model")
        c = {"K0": model.K0, "K1": model.K1,
             **{n: v for n, v in tt.coefficients if n[:2] in ("K0", "K1")}}
        return cls(model.output_unit, tt.reference, tt.valid_range, c, description)

    def units(self) -> dict:
        """The unit of each coefficient."""
        return {n: (term_unit(n, self.output_unit) if n in ("K0", "K1")
                    else TEMPERATURE_TERMS[n].unit) for n in self.coefficients}

    def outside(self, temperature) -> np.ndarray:
        """Boolean mask of temperatures outside the valid range."""
        t = check_temperature(temperature)
        return (t < self.valid_range[0]) | (t > self.valid_range[1])

    def apply(self, output, temperature, *, allow_extrapolation: bool = False):
        """Eq. (5): ``(a_i in g, extrapolated mask)`` for outputs at sensor temperatures.

        Raises
        ------
        AccelcalError
            For a temperature outside the valid range unless
            ``allow_extrapolation`` (then the rows are flagged).
        """
        t = check_temperature(temperature)
        out = self.outside(t)
        if out.any() and not allow_extrapolation:
            k = int(np.flatnonzero(out)[0])
            raise AccelcalError(
                f"temperature {t.flat[k]:.6g} degC (row {k}) is outside the compensation's "
                f"valid range {self.valid_range[0]:g} to {self.valid_range[1]:g} degC; allow "
                "extrapolation explicitly to compensate anyway (the rows are then flagged)",
                parameter="allow_extrapolation")
        free = TemperatureTerms(self.reference, self._terms.coefficients)  # range checked above
        c = self.coefficients
        k1 = c["K1"] * (1.0 + free.change("K1", t))  # Eq. (5) [DOMAIN]
        k0 = c["K0"] + free.change("K0", t)
        return np.asarray(output, dtype=float) / k1 - k0, out

    def to_dict(self) -> dict:
        """The JSON-ready contents of a compensation file."""
        data = {"format_version": FORMAT_VERSION, "kind": KIND, "output_unit": self.output_unit,
                "reference_degC": self.reference, "valid_range_degC": list(self.valid_range),
                "units": self.units(), "coefficients": dict(self.coefficients),
                "equation": EQUATION}
        if self.description:
            data["description"] = self.description
        return data

    def save(self, path) -> None:
        """Write the compensation file atomically."""
        import json

        from accelcal.io.atomic import write_text_atomic

        write_text_atomic(path, json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")

    @classmethod
    def from_dict(cls, data, *, source: str = "<dict>") -> "Compensation":
        """Validate decoded contents; an ErrorModel file with temperature terms is accepted too."""
        from accelcal.io.model_file import KIND as MODEL_KIND

        def fail(msg):
            return AccelcalError(f"{source}: {msg}")

        if isinstance(data, dict) and data.get("kind") == MODEL_KIND:
            from accelcal.model import ErrorModel

            return cls.from_model(ErrorModel.from_dict(data, source=source))
        if not isinstance(data, dict):
            raise fail("expected a JSON object")
        if data.get("kind") != KIND:
            raise fail(f"kind is {shown(data.get('kind'))}, expected {KIND!r} (or an error "
                       "model with temperature terms)")
        unknown = sorted(set(data) - set(_KEYS) - set(_OPTIONAL))
        missing = [k for k in _KEYS if k not in data]
        if unknown or missing:
            raise fail(f"unknown key(s) {', '.join(map(shown, unknown))}" if unknown else
                       f"missing key(s) {', '.join(missing)}")
        if data["format_version"] != FORMAT_VERSION or isinstance(data["format_version"], bool):
            raise fail(f"format_version {shown(data['format_version'])} is not supported "
                       f"(this accelcal reads {FORMAT_VERSION})")
        coefficients, span = data["coefficients"], data["valid_range_degC"]
        if not isinstance(coefficients, dict) or not all(
                n in _NAMES and is_finite_number(v) for n, v in coefficients.items()):
            raise fail(f"coefficients must map names among {', '.join(_NAMES)} to finite "
                       "numbers")
        if not (isinstance(span, list) and len(span) == 2 and all(map(is_finite_number, span))):
            raise fail("valid_range_degC must be [low, high] in degC")
        if not is_finite_number(data["reference_degC"]):
            raise fail("reference_degC must be a finite number")
        try:
            comp = cls(data["output_unit"], data["reference_degC"], tuple(span), coefficients,
                       data.get("description", "") if isinstance(data.get("description", ""),
                                                                 str) else "")
        except AccelcalError as exc:
            raise fail(exc.message) from None
        units = data.get("units", {})
        wrong = [n for n, u in (units.items() if isinstance(units, dict) else [(None, None)])
                 if comp.units().get(n) != u]
        if wrong:
            raise fail(f"units.{wrong[0]} is not {comp.units().get(wrong[0])!r} (or units is "
                       "not an object): convert the value")
        return comp

    @classmethod
    def load(cls, path) -> "Compensation":
        """Read and validate a compensation (or model) file."""
        from accelcal.io.limits import MAX_JSON_BYTES, load_json, read_bounded

        try:
            text = read_bounded(path, MAX_JSON_BYTES, "compensation file").decode("utf-8")
        except FileNotFoundError:
            raise AccelcalError(f"compensation file {path} not found", parameter="model"
                                ) from None
        except UnicodeDecodeError:
            raise AccelcalError(f"{path}: not UTF-8 text", parameter="model") from None
        except OSError as exc:
            raise AccelcalError(f"cannot read {path}: {exc.strerror or exc}",
                                parameter="model") from None
        return cls.from_dict(load_json(text, str(path)), source=str(path))


def compensate_stream(blocks, out, comp: Compensation, *, names, offset: float = 0.0,
                      allow_extrapolation: bool = False) -> int:
    """Write the compensated recording, block by block: one row per input row, in order.

    Parameters
    ----------
    blocks : iterable of accelcal.io.recordings.Block
        Values ``(rows, 2)``: the output and the temperature (in its unit).
    out : path-like
        CSV written atomically (nothing is left when a block is refused).
    comp : Compensation
    names : tuple of str
        Names of the output and temperature columns in the output file.
    offset : float
        Added to the temperature to give degC (-273.15 for K).
    allow_extrapolation : bool
        Compensate outside the valid range too, flagging the rows.

    Returns
    -------
    int
        Rows written.

    Columns: ``time_s`` (when the recording has a time), the output, the
    temperature in degC, ``a_i_g`` (Eq. (5)) and ``extrapolated`` (0 or 1).
    """
    from accelcal.io.atomic import atomic_path
    from accelcal.io.records import write_rows

    rows = 0
    with atomic_path(out) as tmp, open(tmp, "wb") as fh:
        header = None
        for block in blocks:
            temp = block.values[:, 1] + offset
            try:
                a, flag = comp.apply(block.values[:, 0], temp,
                                     allow_extrapolation=allow_extrapolation)
            except AccelcalError as exc:
                k = int(np.flatnonzero(comp.outside(temp))[0]) if exc.parameter == \
                    "allow_extrapolation" else None
                if k is None:
                    raise
                raise AccelcalError(exc.message.replace(f"(row {k})",
                                                        f"(data row {block.start + k})"),
                                    parameter=exc.parameter) from None
            cols = [block.values[:, 0], temp, a, flag.astype(float)]
            if header is None:
                header = ([] if block.time is None else ["time_s"]) + [
                    names[0], f"{names[1]}_degC", "a_i_g", "extrapolated"]
                fh.write((",".join(header) + "\n").encode())
            if block.time is not None:
                cols.insert(0, block.time)
            write_rows(fh, header, cols)
            rows += block.values.shape[0]
    return rows
