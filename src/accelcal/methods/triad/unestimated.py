"""The triad's unestimated terms: each axis's pendulous error terms, aliased and bounded.

The triad model (bias, scale factor, triangular non-orthogonality, optional
quadratic) leaves out the terms a pendulous accelerometer axis also has
(:mod:`accelcal.rigs.triad_axes`): K2 a_i², K3 a_i³, the cross-coupling
Kio a_i a_o, Kip a_i a_p, Kop a_o a_p, the odd-input Koo a_o², Kpp a_p²
and the asymmetry ``sgn(a_i)(K0' + K1' a_i)/2``. On static positions at
1 g they move the interval means, and so the rows: K2 g² and the odd-input
terms look like a bias, K3 g³ like a scale factor, and so on, by amounts
the positions decide.

:func:`with_type_b` takes the alias matrix by central differences of the
reduction of the interval means (two more reductions per term and axis:
ms each, on a few dozen means), with each term's change of the means per
unit term taken at the positions' specific force (known orientations:
``g up``; unknown: the calibrated means) in each axis's IA, OA, PA frame;
bounds each term by a prior (the embedded default accelerometer's, like
the tumble: twice its magnitude, rectangular) and adds ``A u² A'`` to the
covariance, itemised in ``Reduction.type_b``; terms without a prior are
listed in ``Reduction.aliases``. At a position where an axis's a_i is zero
(within :data:`ZERO_A_I`), the sign of K0'/2 there is unknown: a term
``K0_asym@<label>`` of its own, two-point.

References
----------
.. [Guan2021] Guan et al., the error model of a pendulous accelerometer, eqs. (1)-(3).
.. [Montgomery] Montgomery D. C., Design and Analysis of Experiments, 8th
   ed., Wiley, 2013, sec. 10.3 (alias matrix).
.. [GUM] JCGM 100:2008, secs. 4.3.7, 5.1.2.
"""

import dataclasses

import numpy as np

from accelcal.aliasing import aliases, default_priors, propagate
from accelcal.errors import AccelcalError
from accelcal.methods.triad.common import calibration_of
from accelcal.terms import term_unit

TERMS = ("K2", "K3", "Koo", "Kpp", "Kio", "Kip", "Kop", "K0_asym", "K1_asym")
"""Terms of each axis's pendulous error model the triad model leaves out (K4 too, but the
default accelerometer's is zero: listed only when given)."""

ZERO_A_I = 1e-4
"""|a_i| (g) below which the sign of an axis's a_i, and so that of K0'/2, is unknown."""

STEP = 1e-3
"""Perturbation of a term (g/g^n) for the central differences: the known-orientation
reduction is linear in the means, the gravity-norm one smooth (second-order error
~STEP^2 relative)."""


def with_type_b(red, means, reduce_again, *, gravity: float, up=None, priors="default",
                labels=None):
    """``red`` with each axis's unestimated pendulous terms as Type B.

    Parameters
    ----------
    red : Reduction
        A triad reduction of ``means``.
    means : array_like, shape (n, 3)
        The interval means it reduced, input unit.
    reduce_again : callable
        ``means -> Reduction``: the same reduction with the same options.
    gravity : float
        m/s^2 per g.
    up : array_like, shape (n, 3), optional
        Known orientations (fixture frame); None: the calibrated means give
        each position's specific force.
    priors : {"default", "none"} or dict
        ``"default"``: the embedded default priors; ``"none"``: nothing
        propagated, every term's aliases listed; a dict maps a term
        (``"K2"``: every axis) or an axis's term (``"K2[x]"``) to a
        :class:`~accelcal.aliasing.Prior` or a number (a standard
        uncertainty, normal, in the term's unit g/g^n); the terms it leaves
        out are listed as aliases.
    labels : sequence of str, optional
        Position labels, for the ``K0_asym@`` terms (default P1...).

    Returns
    -------
    Reduction
    """
    given = check_priors(priors)
    means = np.asarray(means, dtype=float)
    names, columns, pri = term_columns(red, means, gravity=gravity, up=up, labels=labels,
                                       bound=priors == "default")
    if given:
        pri = given
    est = red.sensors[0]
    a = np.column_stack([
        (reduce_again(means + STEP * c).sensors[0].values
         - reduce_again(means - STEP * c).sensors[0].values) / (2 * STEP) for c in columns])
    rows = tuple(est.label(t) for t in est.names)
    units = {est.label(t): est.units[t] for t in est.names}
    used = {full: pri.get(full, pri.get(term)) for full, term in names
            if pri.get(full, pri.get(term)) is not None}
    used = {k: dataclasses.replace(p, name=k) for k, p in used.items()}
    full_names = tuple(full for full, _ in names)
    cov, parts = propagate(a, rows, full_names, used, row_units=units)
    free = [i for i, full in enumerate(full_names) if full not in used]
    entries = aliases(a[:, free], rows, tuple(full_names[i] for i in free), row_units=units,
                      term_units={full_names[i]: term_unit(names[i][1], "g") for i in free})
    sensor = dataclasses.replace(est, covariance=est.covariance + cov)
    covariance = red.covariance
    if covariance is not None and np.ndim(covariance) == 2 and \
            covariance.shape[0] >= cov.shape[0]:
        covariance = np.array(covariance, dtype=float)
        covariance[:cov.shape[0], :cov.shape[0]] += cov
    note = _note(priors, given)
    return dataclasses.replace(red, sensors=(sensor, *red.sensors[1:]), covariance=covariance,
                               type_b=(*red.type_b, *parts), aliases=(*red.aliases, *entries),
                               priors=(*red.priors, *used.values()),
                               notes=(*red.notes, note))


SUM_NOTE = ("an axis's K2 + Koo + Kpp reads as its bias (a_i^2 + a_o^2 + a_p^2 = 1 at every "
            "static position: no set of positions separates the sum from b; the terms' "
            "contrasts move the rows by amounts the positions decide)")
"""Why the even terms alias into the biases (docs/triad.md)."""


def _note(priors, given) -> str:
    """What ``with_type_b`` did with the pendulous terms, in words."""
    if priors == "none":
        return ("priors none: the pendulous terms' aliases listed (the rows each would move, "
                "per unit term, if the axes are pendulous accelerometers), no Type B "
                f"propagated; {SUM_NOTE}")
    which = given or default_priors(TERMS, "g")
    source = "given" if given else "embedded default"
    bounds = ", ".join(f"{p.name} {'+-' if p.distribution == 'rectangular' else 'u '}"
                       f"{p.value:.3g} {p.unit}" for p in which.values())
    return (f"each axis's pendulous terms the triad model leaves out ({', '.join(TERMS)}) "
            f"bounded by the {source} priors ({bounds}; K0'/2 of unknown sign where an axis's "
            "a_i = 0) and propagated as Type B to the rows they move"
            + ("; the terms without a prior listed as aliases" if given else "")
            + f"; {SUM_NOTE}")


PRIOR_CHOICES = ("default", "none")
"""The named ``priors`` of :func:`with_type_b`; a mapping (or, on the command line, a
JSON file or ``TERM=U,...``) gives the user's own."""


def check_priors(priors) -> dict:
    """Name -> Prior of a ``priors`` mapping; ``{}`` for ``"default"`` or ``"none"``.

    A name is a term of :data:`TERMS` (every axis) or an axis's term
    (``"K2[x]"``); a number is a standard uncertainty (normal) in the term's
    unit (g/g^n), from the user.

    Raises
    ------
    AccelcalError
        For another string, an unknown term or a value that is not a
        finite non-negative number.
    """
    from accelcal.aliasing import Prior

    if isinstance(priors, str):
        if priors not in PRIOR_CHOICES:
            raise AccelcalError(f"priors {priors[:40]!r} is not one of default, none or a "
                                "mapping of term to prior", parameter="priors")
        return {}
    try:
        items = dict(priors).items()
    except (TypeError, ValueError):
        raise AccelcalError(f"priors {str(priors)[:40]!r} is not one of default, none or a "
                            "mapping of term to prior", parameter="priors") from None
    out = {}
    for name, p in items:
        term, _, axis = str(name).partition("[")
        if term not in TERMS or axis not in ("", "x]", "y]", "z]"):
            raise AccelcalError(f"prior of {str(name)[:40]!r}: not a pendulous term the triad "
                                f"leaves out ({', '.join(TERMS)}, or e.g. K2[x] for one axis)",
                                parameter="priors")
        try:
            out[name] = p if isinstance(p, Prior) else \
                Prior(name, float(p), term_unit(term, "g"), "normal")
        except (TypeError, ValueError) as exc:
            raise AccelcalError(f"prior of {name}: {exc}", parameter="priors") from None
    if not out:
        raise AccelcalError("priors: an empty mapping; give default, none or term priors",
                            parameter="priors")
    return out


def parse_priors(text: str):
    """``--priors`` text: ``default``, ``none``, a JSON file or ``TERM=U,...``.

    The file holds an object mapping a term (or an axis's term, ``K2[x]``)
    to a standard uncertainty (normal, g/g^n) or to ``{"value": a,
    "distribution": "rectangular"|"normal"|"two-point"}``; ``TERM=U`` items
    are standard uncertainties, as the tumble's.
    """
    import json
    from pathlib import Path

    from accelcal.aliasing import Prior
    from accelcal.validation import one_line, shown_path

    text = text.strip()
    if text in PRIOR_CHOICES:
        return text
    path = Path(text)
    if path.suffix.lower() == ".json" or path.is_file():
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise AccelcalError(f"cannot read {shown_path(path)} as a JSON priors file: "
                                f"{one_line(exc, 80)}", parameter="priors") from None
        if not isinstance(doc, dict):
            raise AccelcalError(f"{shown_path(path)}: a priors file holds an object of term: "
                                "prior",
                                parameter="priors")
        out = {}
        for name, item in doc.items():
            p = item
            if isinstance(item, dict):
                term = str(name).partition("[")[0]
                try:
                    p = Prior(str(name), float(item["value"]), term_unit(term, "g"),
                              str(item.get("distribution", "rectangular")))
                except (KeyError, TypeError, ValueError) as exc:
                    raise AccelcalError(f"{shown_path(path)}: prior of {str(name)[:40]!r}: "
                                        f"{one_line(exc, 80)}", parameter="priors") from None
            out[str(name)] = p
        check_priors(out)
        return out
    if "=" not in text:
        raise AccelcalError(f"{text[:40]!r} is not default, none, a JSON priors file or "
                            "TERM=U,... (standard uncertainties in g/g^n)", parameter="priors")
    from accelcal.methods.tumble.unestimated import parse_priors as parse_items

    out = parse_items(text)
    check_priors(out)
    return out


def term_columns(red, means, *, gravity: float, up=None, labels=None, bound: bool = True):
    """Every axis's unestimated terms: names, change of the means per unit term, priors.

    Parameters
    ----------
    red : Reduction
        The triad reduction (its calibration gives the axes' frames).
    means : numpy.ndarray, shape (n, 3)
    gravity : float
    up : array_like, optional
        Known orientations; None: the calibrated means give the specific force.
    labels : sequence of str, optional
    bound : bool
        Give each term its embedded default prior (and each ``K0_asym@`` one).

    Returns
    -------
    names : list of (str, str)
        ``(row name, term)``, e.g. ``("K2[x]", "K2")``.
    columns : list of numpy.ndarray, shape (n, 3)
        Input unit per unit term (g/g^n).
    priors : dict
        Row name or term -> Prior.
    """
    from accelcal.rigs.triad_axes import axis_frames

    n = means.shape[0]
    labels = list(labels) if labels is not None else [f"P{j + 1}" for j in range(n)]
    cal = calibration_of(red)
    if up is not None:
        force = gravity * np.asarray(up, dtype=float)
        if cal.rotation is not None:
            force = force @ cal.rotation
    else:
        force = cal.apply(means)
    ia, oa, pa, norm = axis_frames(cal.t)
    a_i, a_o, a_p = (force @ m.T / gravity for m in (ia, oa, pa))  # (n, 3), g
    pri = default_priors(TERMS, "g") if bound else {}
    asym = default_priors(("K0_asym",), "g").get("K0_asym")
    columns, names = [], []
    per_g = gravity * norm / cal.scale  # input unit per g of each axis's indicated error
    for i, axis in enumerate("xyz"):
        regress = _regressors(a_i[:, i], a_o[:, i], a_p[:, i])
        for term in TERMS:
            col = np.zeros((n, 3))
            col[:, i] = per_g[i] * regress[term]
            columns.append(col)
            names.append((f"{term}[{axis}]", term))
        for j in np.flatnonzero(np.abs(a_i[:, i]) < ZERO_A_I):
            name = f"K0_asym@{labels[j]}[{axis}]"
            col = np.zeros((n, 3))
            col[j, i] = 0.5 * per_g[i]
            columns.append(col)
            names.append((name, "K0_asym"))
            if bound and asym is not None:
                pri[name] = dataclasses.replace(asym, name=name)  # +-K0': still within +-a
    return names, columns, pri


def _regressors(a_i, a_o, a_p) -> dict:
    """Each term's indicated error per unit term, g, at the positions' inputs (g)."""
    return {"K2": a_i**2, "K3": a_i**3, "Koo": a_o**2, "Kpp": a_p**2, "Kio": a_i * a_o,
            "Kip": a_i * a_p, "Kop": a_o * a_p, "K0_asym": 0.5 * np.sign(a_i),
            "K1_asym": 0.5 * np.sign(a_i) * a_i}
