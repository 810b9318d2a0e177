"""Repeatability over several calibrations of a serial, and the shift between two.

Both read calibration records (:class:`accelcal.io.calibration_record.CalibrationRecord`:
from files or from the store) and compare each coefficient in its
engineering unit (:mod:`accelcal.engineering`: a bias in ug, converted from
an output unit with the same record's scale factor; a misalignment in urad;
...); a scale factor is compared relatively, in ppm.

Repeatability (IEEE 1293: the spread of results under the same conditions;
over days and turn-ons, the long-term repeatability): for each coefficient
present in at least three records, the sample standard deviation of its N
values, its standard uncertainty ``s / sqrt(2 (N-1))`` and 95 % chi-square
interval (:func:`~accelcal.methods.acceptance.turnon.sd_interval`), beside
the RMS of the records' own standard uncertainties (a spread well above it
is the sensor's, not the calibrations'). A noise record of the serial
(method ``noise/...``) is not pooled: the bias instability B of the latest
one is given beside, as the in-run stability (IEEE 1293; Allan deviation,
DOMAIN section 7).

Before/after an environment: for each coefficient of both records the
shift ``d = x_after - x_before``, its standard uncertainty ``u = sqrt(u_1^2
+ u_2^2 - 2 r u_1 u_2)`` (r the correlation between the two calibrations'
errors where known, e.g. from a shared reference or rig error; 0 for two
independent calibrations), the
normalised error ``E_n = d / (k u)`` with k = 2 (ISO 13528: ``|E_n| > 1``,
the shift exceeds what the uncertainties allow), and a test of ``d = 0``:
Welch's t with the Welch-Satterthwaite degrees of freedom ``nu = u^4 /
(u_1^4 / nu_1 + u_2^4 / nu_2)`` when both records state their dof, else z
(normal), with its two-sided p-value.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, repeatability and the shift after an environment.
.. [ISO13528] ISO 13528:2015, Statistical methods for use in proficiency
   testing, 9.7 (the E_n number).
.. [Welch1947] B. L. Welch, The generalization of Student's problem when
   several different population variances are involved, Biometrika 34, 1947.
.. [GUM] JCGM 100:2008, G.4 (Welch-Satterthwaite).
"""

import math

import numpy as np

from accelcal.engineering import QUANTITIES, engineering
from accelcal.errors import AccelcalError
from accelcal.method_ids import canonical
from accelcal.validation import shown

MIN_RECORDS = 3
"""Fewest records a repeatability is computed from."""
EN_K = 2.0
"""Coverage factor of the E_n number."""
_SCALE = ("K1", "K_I")


def _scale_factor(record):
    for name in _SCALE:
        if name in record.names:
            return float(np.real(record.estimates[record.names.index(name)]))
    return None


def coefficients(record) -> dict:
    """Coefficient name -> ``(value, std, unit)`` in engineering units (module docs).

    A scale factor stays in its own unit (compared relatively by the
    callers); a combination (``K0+Kpp``) is converted as its plain
    coefficient (``K0``); a coefficient with no engineering unit stays as recorded;
    complex coefficients are left out.
    """
    if record.is_complex:
        return {}
    k1 = _scale_factor(record)
    std = record.std
    out = {}
    for name, value, s in zip(record.names, record.estimates, std, strict=True):
        unit = record.units[name]
        if name in _SCALE:
            out[name] = (float(value), float(s), unit)
            continue
        eng = engineering(record.plain.get(name, name), float(value), float(s), unit,
                          scale_factor=k1)
        out[name] = ((eng[0].estimate, eng[0].std, eng[0].unit) if eng
                     else (float(value), float(s), unit))
    return out


def _label(name: str, what: str) -> str:
    kind = QUANTITIES.get(name)
    if kind == "bias":
        return f"bias {what} ({name})"
    if kind == "scale":
        return f"scale-factor {what} ({name})"
    return f"{name} {what}"


def repeatability(records) -> list[dict]:
    """Rows of the repeatability of each coefficient over ``records`` of one serial.

    Returns
    -------
    list of dict
        ``quantity, estimate, std, unit, low, high, n, mean, within``:
        the standard deviation (``estimate``), its standard uncertainty, the
        95 % interval, the number of records, the mean value and the RMS of
        the records' standard uncertainties.

    Raises
    ------
    AccelcalError
        For fewer than three records, or records of more than one serial.
    """
    from accelcal.methods.acceptance.turnon import sd_interval

    records = list(records)
    serials = sorted({r.serial for r in records})
    if len(serials) > 1:
        raise AccelcalError(f"the records are of {len(serials)} serials "
                            f"({', '.join(map(shown, serials[:3]))}): give one serial's")
    noise = [r for r in records if canonical(r.method).startswith("noise")]
    records = [r for r in records if not canonical(r.method).startswith("noise")]
    if len(records) < MIN_RECORDS:
        raise AccelcalError(f"{len(records)} calibration record(s): a repeatability needs at "
                            f"least {MIN_RECORDS}")
    values: dict[str, list] = {}
    for rec in records:
        for name, v in coefficients(rec).items():
            values.setdefault(name, []).append(v)
    rows = []
    for name, vals in values.items():
        units = {v[2] for v in vals}
        if len(vals) < MIN_RECORDS or len(units) != 1:
            continue
        x, u = np.array([v[0] for v in vals]), np.array([v[1] for v in vals])
        unit = units.pop()
        if name in _SCALE:
            x, u, unit = (x / x.mean() - 1.0) * 1e6, u / abs(x.mean()) * 1e6, "ppm"
        s, n = float(np.std(x, ddof=1)), x.size
        low, high = sd_interval(s, n)
        rows.append({"quantity": _label(name, "repeatability"), "estimate": s,
                     "std": s / math.sqrt(2 * (n - 1)), "unit": unit, "low": low, "high": high,
                     "n": n, "mean": float(x.mean()) if name not in _SCALE else 0.0,
                     "within": float(np.sqrt(np.mean(u**2)))})
    if not rows:
        raise AccelcalError("no coefficient is in at least three of the records with one unit")
    return rows + _in_run(noise)


def _in_run(noise) -> list[dict]:
    """The in-run stability row (B of the latest noise record, ug), or none."""
    from accelcal.units import UNIT_SIZES, convert

    latest = max(noise, key=lambda r: r.date, default=None)
    if latest is None or "B" not in latest.names:
        return []
    i = latest.names.index("B")
    value, std, unit = float(np.real(latest.estimates[i])), float(latest.std[i]), latest.units["B"]
    if unit in UNIT_SIZES["acceleration"]:
        value, std, unit = float(convert(value, unit, "ug")), float(convert(std, unit, "ug")), "ug"
    return [{"quantity": "in-run stability (B)", "estimate": value, "std": std, "unit": unit,
             "low": math.nan, "high": math.nan, "n": 1, "mean": math.nan, "within": math.nan}]


def compare(before, after, *, correlation: float = 0.0) -> list[dict]:
    """Rows of the shift of each coefficient from ``before`` to ``after`` (module docs).

    ``correlation`` (r, in [-1, 1]) is that of the two records' errors, the
    same for every coefficient; 0 for independent calibrations.

    Returns
    -------
    list of dict
        ``quantity, before, after, estimate (the shift), std, unit, En,
        statistic ("z" or "t"), value, dof (None for z), p, exceeds`` (``|E_n| > 1``);
        a scale factor's shift in ppm of its value before.

    Raises
    ------
    AccelcalError
        For records of different serials or different methods.
    """
    from scipy.special import ndtr, stdtr

    if before.serial != after.serial:
        raise AccelcalError(f"the records are of different serials ({shown(before.serial)} and "
                            f"{shown(after.serial)}): compare two calibrations of one serial")
    if canonical(before.method) != canonical(after.method):
        raise AccelcalError(f"the records are of different methods ({shown(before.method)} and "
                            f"{shown(after.method)}): compare two calibrations by one method")
    if not -1.0 <= correlation <= 1.0:
        raise AccelcalError(f"the correlation must be in [-1, 1], not {correlation:g}",
                            parameter="correlation")
    one, two = coefficients(before), coefficients(after)
    rows = []
    for name in (n for n in one if n in two):
        (x1, u1, unit1), (x2, u2, unit2) = one[name], two[name]
        if unit1 != unit2:
            continue
        unit = unit1
        if name in _SCALE:
            x2, u1, u2, x1, unit = ((x2 / x1 - 1.0) * 1e6, u1 / abs(x1) * 1e6,
                                    u2 / abs(x1) * 1e6, 0.0, "ppm")
        d = x2 - x1
        u = math.sqrt(max(u1**2 + u2**2 - 2.0 * correlation * u1 * u2, 0.0))
        if before.dof and after.dof and u > 0:
            dof = u**4 / (u1**4 / before.dof + u2**4 / after.dof)
            stat, p = "t", float(2 * stdtr(dof, -abs(d) / u))
        else:
            dof, stat = None, "z"
            p = float(2 * ndtr(-abs(d) / u)) if u > 0 else (0.0 if d else 1.0)
        en = d / (EN_K * u) if u > 0 else math.copysign(math.inf, d) if d else 0.0
        rows.append({"quantity": name, "before": x1, "after": x2, "estimate": d, "std": u,
                     "unit": unit, "En": en, "statistic": stat,
                     "value": d / u if u > 0 else math.nan, "dof": dof, "p": p,
                     "exceeds": abs(en) > 1.0})
    if not rows:
        raise AccelcalError("the records have no coefficient in common (with one unit)")
    return rows
