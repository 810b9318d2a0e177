"""A :class:`~accelcal.results.Reduction` as rows and as JSON: one code path for all methods.

Rows (:func:`reduction_rows`) feed the command line's table, CSV and JSON
output and ``Reduction.to_frame()``; :func:`to_dict` is the complete JSON
form. Both read only the Reduction's fields. Numbers keep full precision;
engineering units (:mod:`accelcal.engineering`) come beside the raw unit
with explicit unit fields.
"""

import math

import numpy as np

from accelcal.engineering import engineering


def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


COMPLEX_KEYS = ("real", "imag", "real_std", "imag_std", "magnitude", "magnitude_std",
                "phase_deg", "phase_std_deg")
"""Keys a complex coefficient's row adds (after ``estimate`` and ``std``, its magnitude's)."""


def complex_columns(est) -> list[dict]:
    """The table columns of each coefficient of a complex estimate.

    ``estimate`` and ``std`` are the magnitude and its standard uncertainty
    (so every table, CSV file and store column that reads ``estimate`` and
    ``std`` shows the magnitude); then :data:`COMPLEX_KEYS`: real and
    imaginary parts with their standard uncertainties (square roots of the
    2x2 block's diagonal), magnitude and phase (degrees, in (-180, 180])
    with their first-order standard uncertainties (:func:`accelcal.polar.polar`).
    NaN where not determined.
    """
    pol = est.polar()
    var = np.diag(est.covariance)
    columns = zip(pol.magnitude, pol.magnitude_std, est.values.real, est.values.imag,
                  np.sqrt(var[0::2]), np.sqrt(var[1::2]), np.degrees(pol.phase),
                  np.degrees(pol.phase_std), strict=True)
    return [{"estimate": float(m), "std": float(ms), "real": float(re), "imag": float(im),
             "real_std": float(rs), "imag_std": float(is_), "magnitude": float(m),
             "magnitude_std": float(ms), "phase_deg": float(ph), "phase_std_deg": float(phs)}
            for m, ms, re, im, rs, is_, ph, phs in columns]


def reduction_rows(reduction, *, engineering: bool = True) -> list[dict]:
    """One row per sensor and coefficient, then one per fixed coefficient.

    Keys: ``sensor, coefficient, estimate, std, unit, status, dof, plain``
    (``coefficient`` is the row's name, a combination name such as
    ``K0+Kpp`` where the row estimates one; ``plain`` the coefficient's own
    name); with
    ``engineering`` also ``eng_estimate, eng_std, eng_unit`` (the first
    engineering unit, or NaN and '' where none applies) and ``engineering``
    (every engineering unit: a list of ``{"estimate", "std", "unit"}``).
    Values not determined are NaN. A complex coefficient's ``estimate`` and
    ``std`` are its magnitude's, its row adds :data:`COMPLEX_KEYS`
    (:func:`complex_columns`), and it has no engineering units. Every row
    of a reduction with Type B contributions has ``coverage_under_priors``
    after ``plain``: what the row's stated 95 % interval covers with the
    unestimated terms following their priors
    (:meth:`~accelcal.results.Reduction.coverage_under_priors`; NaN for a
    row without Type B).
    """
    rows = []
    covered = coverage_columns(reduction)
    for k, (name, est) in enumerate(zip(reduction.sensor_names, reduction.sensors, strict=True)):
        k1 = reduction.scale_factor(k)
        if est.is_complex:
            rows += _complex_rows(reduction, k, name, est, engineering)
            continue
        for c, v, s in zip(est.names, est.values, est.std, strict=True):
            unit = est.units.get(c, "")
            row = {"sensor": name, "coefficient": est.label(c), "estimate": float(v),
                   "std": float(s), "unit": unit, "status": reduction.status(c, k),
                   "dof": int(est.dof), "plain": c, **covered(k, est.label(c))}
            if engineering:
                row.update(_engineering_columns(reduction, c, float(v), float(s), unit, k1, k))
            rows.append(row)
        for c, v in reduction.fixed.items():
            unit = _fixed_unit(c, est)
            row = {"sensor": name, "coefficient": c, "estimate": float(v), "std": 0.0,
                   "unit": unit, "status": "fixed", "dof": int(est.dof), "plain": c,
                   **covered(k, None)}
            if engineering:
                row.update(_engineering_columns(reduction, c, float(v), 0.0, unit, k1, k))
            rows.append(row)
    return rows


def coverage_columns(reduction):
    """``(sensor, row name) -> {"coverage_under_priors": p}`` for the rows of a reduction.

    Empty for every row of a reduction without Type B (no column); NaN for
    a row without Type B in a reduction with some.
    """
    if not reduction.type_b:
        return lambda k, row: {}
    found = {(rc.sensor, rc.row): rc.probability for rc in reduction.coverage_under_priors()}
    return lambda k, row: {"coverage_under_priors": found.get((k, row), math.nan)}


def _complex_rows(reduction, k, name, est, engineering) -> list[dict]:
    """The rows of a complex estimate (its fixed coefficients are real, as any)."""
    rows, covered = [], coverage_columns(reduction)
    for c, columns in zip(est.names, complex_columns(est), strict=True):
        row = {"sensor": name, "coefficient": c, "estimate": columns["estimate"],
               "std": columns["std"], "unit": est.units.get(c, ""),
               "status": reduction.status(c, k), "dof": int(est.dof),
               **{key: columns[key] for key in COMPLEX_KEYS}, **covered(k, None)}
        if engineering:
            row.update(eng_estimate=math.nan, eng_std=math.nan, eng_unit="", engineering=[])
        rows.append(row)
    for c, v in reduction.fixed.items():
        row = {"sensor": name, "coefficient": c, "estimate": float(v), "std": 0.0,
               "unit": _fixed_unit(c, est), "status": "fixed", "dof": int(est.dof),
               **covered(k, None)}
        if engineering:
            row.update(eng_estimate=math.nan, eng_std=math.nan, eng_unit="", engineering=[])
        rows.append(row)
    return rows


def _fixed_unit(name: str, est) -> str:
    from accelcal.model import TERMS

    if name in est.units:
        return est.units[name]
    return TERMS[name].unit if name in TERMS else ""


def _engineering_columns(reduction, name, value, std, unit, k1, sensor) -> dict:  # noqa: PLR0917
    eng = engineering(name, value, std, unit, scale_factor=k1,
                      nominal=reduction.nominal_of(name, sensor),
                      quantity=reduction.quantities.get(name))
    first = eng[0] if eng else None
    return {"eng_estimate": first.estimate if first else float("nan"),
            "eng_std": first.std if first else float("nan"),
            "eng_unit": first.unit if first else "",
            "engineering": [e.as_dict() for e in eng]}


def _matrix(a) -> list | None:
    if a is None:
        return None
    return [[_num(x) for x in row] for row in np.asarray(a)]


def _complex_num(x) -> dict | None:
    """A complex number as ``{"re": .., "im": ..}`` (None when not finite)."""
    x = complex(x)
    return {"re": x.real, "im": x.imag} if math.isfinite(x.real) and math.isfinite(x.imag) \
        else None


def _estimate_dict(est, name: str | None = None, covered=None) -> dict:
    if est.is_complex:
        out = {
            "complex": True,
            "coefficients": [
                {"name": est.label(c), "unit": est.units.get(c, ""), "estimate": _complex_num(v),
                 "std": _num(col["std"]), "magnitude": _num(col["magnitude"]),
                 "phase_deg": _num(col["phase_deg"]), "phase_std_deg": _num(col["phase_std_deg"]),
                 **({"plain": c} if est.label(c) != c else {})}
                for c, v, col in zip(est.names, est.values, complex_columns(est), strict=True)
            ],
            "covariance": _matrix(est.covariance),
            "dof": int(est.dof),
            "residual_sigma": _num(est.residual_sigma()),
        }
        return {"sensor": name, **out} if name is not None else out
    out = {
        "coefficients": [
            {"name": est.label(c), "unit": est.units.get(c, ""), "estimate": _num(v),
             "std": _num(s), **({"plain": c} if est.label(c) != c else {}),
             **{key: _num(p) for key, p in (covered or {}).get(est.label(c), {}).items()
                if math.isfinite(p)}}
            for c, v, s in zip(est.names, est.values, est.std, strict=True)
        ],
        "covariance": _matrix(est.covariance),
        "dof": int(est.dof),
        "residual_sigma": _num(est.residual_sigma()),
    }
    return {"sensor": name, **out} if name is not None else out


def to_dict(reduction) -> dict:
    """The whole reduction as JSON-ready data (NaN written as None).

    Keys: ``family, method, dof, sensors`` (per sensor ``sensor,
    coefficients, covariance, dof, residual_sigma`` and ``engineering`` rows),
    ``shared`` (or None), ``combinations``, ``identifiability`` (rank,
    condition numbers, identifiable, not identifiable, tolerance; or None),
    ``assumptions``, ``fixed``, ``provenance``, ``notes``, ``type_b`` (the
    itemised Type B contributions), ``aliases`` (the alias-matrix entries of
    the unestimated terms) and ``priors`` (:mod:`accelcal.aliasing`). A
    coefficient with Type B has ``coverage_under_priors``
    (:meth:`~accelcal.results.Reduction.coverage_under_priors`): derived from
    the other fields, it is not read back but computed again.

    A complex estimate has ``"complex": true``; each of its coefficients
    gives ``estimate`` as ``{"re": .., "im": ..}``, ``std`` (the
    magnitude's), ``magnitude``, ``phase_deg`` and ``phase_std_deg``, and its
    ``covariance`` is that of ``[Re x1, Im x1, Re x2, ...]`` (``2p x 2p``).
    :func:`from_dict` reads the form back.
    """
    rows = reduction_rows(reduction)
    sensors = []
    covered = coverage_columns(reduction)
    for k, (name, est) in enumerate(zip(reduction.sensor_names, reduction.sensors,
                                        strict=True)):
        d = _estimate_dict(est, name, {est.label(c): covered(k, est.label(c))
                                       for c in est.names})
        d["engineering"] = {r["plain"]: r["engineering"] for r in rows
                            if r["sensor"] == name and r["engineering"]}
        sensors.append(d)
    ident = reduction.identifiability
    return {
        "family": reduction.family,
        "method": reduction.method,
        "dof": int(reduction.dof),
        "sensors": sensors,
        "shared": _estimate_dict(reduction.shared) if reduction.shared is not None else None,
        "combinations": [{k: (_num(v) if isinstance(v, float) else v)
                          for k, v in c.as_dict().items()} for c in reduction.combinations],
        "identifiability": None if ident is None else {
            "rank": ident.rank, "parameters": len(ident.names),
            "condition_number": _num(ident.condition_number),
            "condition_number_identifiable": _num(ident.condition_number_identifiable),
            "identifiable": list(ident.identifiable),
            "not_identifiable": list(ident.unidentifiable),
            "tolerance": ident.tolerance,
        },
        "assumptions": [a.as_dict() for a in reduction.assumptions],
        "fixed": dict(reduction.fixed),
        "nominal": {k: list(v) if isinstance(v, tuple | list) else v
                    for k, v in reduction.nominal.items()},
        "provenance": dict(reduction.provenance),
        "notes": list(reduction.notes),
        "type_b": [c.as_dict() for c in reduction.type_b],
        "aliases": [a.as_dict() for a in reduction.aliases],
        "priors": [p.as_dict() for p in reduction.priors],
    }


def _fail(source: str, what: str):
    from accelcal.errors import AccelcalError

    return AccelcalError(f"{source}: {what}")


def _array(rows, source: str, what: str) -> np.ndarray:
    """A JSON list (of lists) of numbers or null as a float array (null -> NaN)."""
    try:
        return np.array(rows if rows is not None else [], dtype=float)
    except (TypeError, ValueError):
        raise _fail(source, f"{what} must be numbers or null") from None


def estimate_from_dict(data: dict, *, method: str = "", source: str = "<dict>", estimate):
    """An :class:`~accelcal.results.Estimate` from its :func:`to_dict` form.

    ``estimate`` is the class to build (:class:`~accelcal.results.Estimate`,
    passed in by :meth:`~accelcal.results.Reduction.from_dict`, so that this
    module, which :mod:`accelcal.results` calls, does not import it back).

    Values, units, covariance and dof are read back; the residuals are not
    in the JSON (only their ``residual_sigma``).

    Raises
    ------
    AccelcalError
        Naming ``source`` and what is malformed.
    """
    if not isinstance(data, dict) or not isinstance(data.get("coefficients"), list):
        raise _fail(source, "an estimate needs a list of 'coefficients'")
    complex_ = data.get("complex", False) is True
    names, units, values, labels = [], {}, [], {}
    for i, c in enumerate(data["coefficients"]):
        if not (isinstance(c, dict) and isinstance(c.get("name"), str)
                and isinstance(c.get("unit", ""), str) and isinstance(c.get("plain", ""), str)):
            raise _fail(source, f"coefficients[{i}] needs a name and a unit (strings)")
        plain = c.get("plain") or c["name"]  # a combination's row: its plain coefficient's name
        if plain != c["name"]:
            labels[plain] = c["name"]
        names.append(plain)
        units[plain] = c.get("unit", "")
        values.append(_value(c.get("estimate"), complex_, source, f"coefficients[{i}].estimate"))
    dof = data.get("dof", 0)
    if isinstance(dof, bool) or not isinstance(dof, int):
        raise _fail(source, "dof must be an integer")
    try:
        return estimate(tuple(names), np.array(values, dtype=complex if complex_ else float),
                        _array(data.get("covariance"), source, "covariance"), units,
                        method, dof=dof, labels=labels)
    except ValueError as exc:
        raise _fail(source, str(exc)) from None


def _value(x, complex_: bool, source: str, where: str) -> float | complex:
    """A JSON estimate: a number (null: NaN), or ``{"re", "im"}`` for a complex one."""
    if x is None:
        return complex(math.nan, math.nan) if complex_ else math.nan
    if complex_:
        if not (isinstance(x, dict) and set(x) == {"re", "im"}
                and all(_is_number(x[k]) for k in ("re", "im"))):
            raise _fail(source, f'{where} must be {{"re": number, "im": number}} or null')
        return complex(x["re"], x["im"])
    if not _is_number(x):
        raise _fail(source, f"{where} must be a number or null")
    return float(x)


def _is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def from_dict(data: dict, *, source: str = "<dict>", reduction, estimate, assumption):
    """A :class:`~accelcal.results.Reduction` from its :func:`to_dict` form (JSON read back).

    Read back: family, method, dof, every sensor's estimate (real or
    complex), the shared estimate, assumptions, fixed and nominal values,
    provenance, notes, and the Type B contributions, aliases and priors of
    the unestimated terms (:func:`type_b_from_dict`; a JSON written before
    they existed has none, and reads as before). Not read back, because the
    JSON holds only their summary: residuals, identifiability, combinations,
    observations and models; nor quantity overrides, which it does not
    hold. ``reduction``,
    ``estimate`` and ``assumption`` are the classes to build, passed in by
    :meth:`~accelcal.results.Reduction.from_dict` (this module does not
    import :mod:`accelcal.results`, which calls it).

    Raises
    ------
    AccelcalError
        Naming ``source`` and what is malformed.
    """
    if not isinstance(data, dict) or not isinstance(data.get("sensors"), list):
        raise _fail(source, "a reduction needs a list of 'sensors'")
    method = data.get("method")
    if not isinstance(method, str) or not isinstance(data.get("family"), str):
        raise _fail(source, "family and method must be strings")
    sensors = [estimate_from_dict(d, method=method, source=f"{source}: sensors[{i}]",
                                  estimate=estimate)
               for i, d in enumerate(data["sensors"])]
    shared = data.get("shared")
    try:
        return reduction(
            family=data["family"], method=method, sensors=tuple(sensors),
            sensor_names=tuple(str(d.get("sensor") or f"U{i + 1}")
                               for i, d in enumerate(data["sensors"])),
            shared=None if shared is None else estimate_from_dict(
                shared, method=method, source=f"{source}: shared", estimate=estimate),
            dof=int(data.get("dof", 0)),
            assumptions=tuple(
                assumption(a["name"], tuple(a["value"]) if isinstance(a["value"], list)
                           else a["value"], a.get("unit", ""), a.get("text", ""))
                for a in data.get("assumptions", [])),
            fixed=dict(data.get("fixed", {})),
            nominal={k: tuple(v) if isinstance(v, list) else v
                     for k, v in data.get("nominal", {}).items()},
            provenance=dict(data.get("provenance", {})), notes=tuple(data.get("notes", [])),
            **type_b_from_dict(data, source),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise _fail(source, f"not a reduction's JSON ({type(exc).__name__}: {exc})") from None


def type_b_from_dict(data: dict, source: str = "<dict>") -> dict:
    """``type_b``, ``aliases`` and ``priors`` of a reduction's JSON, as their classes.

    The inverse of the ``as_dict`` forms of :class:`~accelcal.aliasing.Contribution`,
    :class:`~accelcal.aliasing.Alias` and :class:`~accelcal.aliasing.Prior`
    (a null ``dof`` is infinite; ``standard`` is derived, not read). A key
    that is missing reads as empty.

    Raises
    ------
    AccelcalError
        Naming ``source`` and the malformed entry.
    """
    from accelcal.aliasing import Alias, Contribution, Prior

    def dof(d):
        x = d.get("dof")
        if x is None:
            return math.inf
        if not _is_number(x):
            raise TypeError("dof must be a number or null")
        return float(x)

    def number(d, key):
        if not _is_number(d[key]):
            raise TypeError(f"{key} must be a number")
        return float(d[key])

    def text(d, key, default=""):
        x = d.get(key, default)
        if not isinstance(x, str):
            raise TypeError(f"{key} must be a string")
        return x

    def sensor(d):
        x = d.get("sensor", 0)
        if isinstance(x, bool) or not isinstance(x, int):
            raise TypeError("sensor must be an integer")
        return x

    build = {
        "type_b": lambda d: Contribution(
            text(d, "row"), text(d, "input"), number(d, "sensitivity"), number(d, "u"),
            number(d, "contribution"), dof(d), text(d, "unit"), text(d, "source", "user"),
            sensor(d)),
        "aliases": lambda d: Alias(text(d, "row"), text(d, "term"), number(d, "sensitivity"),
                                   text(d, "unit"), sensor(d)),
        "priors": lambda d: Prior(text(d, "name"), number(d, "value"), text(d, "unit"),
                                  text(d, "distribution", "rectangular"), dof(d),
                                  text(d, "source", "user")),
    }
    out = {}
    for key, make in build.items():
        entries = data.get(key) or []
        if not isinstance(entries, list):
            raise _fail(source, f"{key} must be a list")
        items = []
        for i, d in enumerate(entries):
            try:
                if not isinstance(d, dict):
                    raise TypeError("not an object")
                items.append(make(d))
            except (KeyError, TypeError, ValueError) as exc:
                raise _fail(source, f"{key}[{i}]: {exc}") from None
        out[key] = tuple(items)
    return out


def describe(reduction) -> list[str]:
    """Sentences for people: assumptions, fixed terms, identifiability, combinations, notes.

    Built from the fields (the assumptions' ``text``), in that order, without
    repeats; calibration records and reports carry these. After the Type B
    lines, one per row whose stated 95 % interval covers outside 93-97 %
    with the unestimated terms following their priors
    (:func:`accelcal.interval.statements`).
    """
    from accelcal.formatting import format_std, format_value
    from accelcal.interval import statements

    lines = [a.text for a in reduction.assumptions if a.text]
    lines += [f"{name} held fixed at {value:.6g}" for name, value in reduction.fixed.items()]
    for k in range(reduction.n_sensors):
        lost = reduction.unidentified(k)
        if lost:
            who = f" ({reduction.sensor_names[k]})" if reduction.n_sensors > 1 else ""
            lines.append(f"not identifiable from this design{who}: {', '.join(lost)}")
    for c in reduction.combinations:
        lines.append(f"determined combination {c.label} = {format_value(c.value, c.std)} "
                     f"+- {format_std(c.std)} {c.unit}".rstrip())
    lines += _type_b_lines(reduction)
    lines += statements(reduction)
    lines += list(reduction.notes)
    return list(dict.fromkeys(lines))


_SOURCE_TEXT = {"user": "the user's prior", "default": "the default prior",
                "estimate": "a prior from the reduction's own estimate"}


def _type_b_lines(reduction) -> list[str]:
    """Type B contributions, by input, and the aliases of the terms without a prior."""
    from accelcal.aliasing import alias_text

    lines = []
    for p in reduction.priors:
        parts = [c for c in reduction.type_b if c.input == p.name]
        if parts:
            lines.append(
                f"{p.name} taken as zero, bounded by {_SOURCE_TEXT[p.source]} ({p.distribution}, "
                f"{'+-' if p.distribution == 'rectangular' else 'u = '}{p.value:.3g} {p.unit}), "
                "Type B: " + ", ".join(f"{c.row} +- {c.contribution:.3g} {c.unit}".rstrip()
                                       for c in parts))
    with_prior = {p.name for p in reduction.priors}
    lines += alias_text([a for a in reduction.aliases if a.term not in with_prior])
    return lines
