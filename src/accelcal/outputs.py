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


def reduction_rows(reduction, *, engineering: bool = True) -> list[dict]:
    """One row per sensor and coefficient, then one per fixed coefficient.

    Keys: ``sensor, coefficient, estimate, std, unit, status, dof, plain``
    (``coefficient`` is the row's name, a combination name such as
    ``K0+Kpp`` where the row estimates one; ``plain`` the coefficient's own
    name); with
    ``engineering`` also ``eng_estimate, eng_std, eng_unit`` (the first
    engineering unit, or NaN and '' where none applies) and ``engineering``
    (every engineering unit: a list of ``{"estimate", "std", "unit"}``).
    Values not determined are NaN.
    """
    rows = []
    for k, (name, est) in enumerate(zip(reduction.sensor_names, reduction.sensors, strict=True)):
        k1 = reduction.scale_factor(k)
        for c, v, s in zip(est.names, est.values, est.std, strict=True):
            unit = est.units.get(c, "")
            row = {"sensor": name, "coefficient": est.label(c), "estimate": float(v),
                   "std": float(s), "unit": unit, "status": reduction.status(c, k),
                   "dof": int(est.dof), "plain": c}
            if engineering:
                row.update(_engineering_columns(reduction, c, float(v), float(s), unit, k1, k))
            rows.append(row)
        for c, v in reduction.fixed.items():
            unit = _fixed_unit(c, est)
            row = {"sensor": name, "coefficient": c, "estimate": float(v), "std": 0.0,
                   "unit": unit, "status": "fixed", "dof": int(est.dof), "plain": c}
            if engineering:
                row.update(_engineering_columns(reduction, c, float(v), 0.0, unit, k1, k))
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


def _estimate_dict(est, name: str | None = None) -> dict:
    out = {
        "coefficients": [
            {"name": est.label(c), "unit": est.units.get(c, ""), "estimate": _num(v),
             "std": _num(s), **({"plain": c} if est.label(c) != c else {})}
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
    the unestimated terms) and ``priors`` (:mod:`accelcal.aliasing`).
    """
    rows = reduction_rows(reduction)
    sensors = []
    for name, est in zip(reduction.sensor_names, reduction.sensors, strict=True):
        d = _estimate_dict(est, name)
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


def describe(reduction) -> list[str]:
    """Sentences for people: assumptions, fixed terms, identifiability, combinations, notes.

    Built from the fields (the assumptions' ``text``), in that order, without
    repeats; calibration records and reports carry these.
    """
    from accelcal.formatting import format_std, format_value

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
