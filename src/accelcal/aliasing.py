"""Unestimated terms: how much they move each reported row, their priors, their Type B share.

A reduction estimates some terms of the error model and takes the others
as zero. For a linear (or linearised) reduction ``x_hat = L y`` of data
``y = X x + Z z + e``, the unestimated terms ``z`` move the estimates by
``A z`` with the *alias matrix*

    A = L Z,   for weighted least squares  A = (X' W X)^-1 X' W Z   [1]_,

one column per unestimated term, one row per reported row, in the row's
unit per unit of the term. :func:`alias_matrix` computes it for any linear
estimator (the estimator applied to the columns of ``Z`` as if they were
data), so every method (least squares, Fourier relations, per-plateau
fits) uses the same code.

What a column of ``A`` means depends on the design:

- the design cannot separate the term from the estimated ones (``[X Z]``
  rank deficient in that direction, :mod:`accelcal.identifiability`): the
  row estimates a combination, and is named after it (``K0+Kpp``,
  :func:`accelcal.identifiability.combination_name`);
- the design could separate it but the reduction does not estimate it: a
  :class:`Prior` (a standard uncertainty, or a bound with a distribution,
  from the user or the embedded default) is propagated as a Type B
  contribution ``A[:, j] u_j^2 A[:, j]'`` to the covariance [2]_, kept
  itemised as :class:`Contribution` s so that a budget can read every
  input's share; without a prior the :class:`Alias` entries still state
  which rows the term would move and by how much per unit.

Degrees of freedom of a row that combines a Type A variance (``nu_A``
residual dof) with Type B priors follow Welch-Satterthwaite [2]_
(:func:`welch_satterthwaite`).

References
----------
.. [1] Montgomery D. C., Design and Analysis of Experiments, 8th ed.,
   Wiley, 2013, sec. 10.3 (the alias matrix of an under-specified model).
.. [2] JCGM 100:2008 (GUM), secs. 4.3 (Type B evaluation; a rectangular
   distribution of half-width a has u = a / sqrt 3), 5.1.2 (law of
   propagation), G.4.1 (Welch-Satterthwaite).
"""

import math
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import combination_name, inseparable
from accelcal.terms import TERMS

DISTRIBUTIONS = ("normal", "rectangular", "two-point")
"""How a prior's ``value`` reads: a standard uncertainty, the half-width of a bound
(uniform within it), or the magnitude of a value known but for its sign (+-a with
equal odds: standard uncertainty a)."""

SOURCES = ("user", "default", "estimate")
"""Where a prior came from: given by the user, the embedded default accelerometer's, or
the reduction's own estimate of the term (e.g. the magnitude of K0' whose sign at a
position is unknown)."""

ALIAS_ATOL = 1e-9
"""An alias-matrix entry below this (row unit per term unit) is no alias."""

DEFAULT_PRIOR_FACTOR = 2.0
"""The embedded default prior of a term: a rectangular bound of this many times the
default accelerometer's magnitude (:func:`accelcal.default_model`)."""


@dataclass(frozen=True)
class Prior:
    """What is known of a term the reduction takes as zero.

    Attributes
    ----------
    name : str
        The term (an error-model coefficient, e.g. ``"K0_asym"``).
    value : float
        A standard uncertainty (``"normal"``), the half-width of a bound
        (``"rectangular"``) or the magnitude of a value of unknown sign
        (``"two-point"``), in ``unit``.
    unit : str
        Unit of the term.
    distribution : {"normal", "rectangular", "two-point"}
    dof : float
        Degrees of freedom of the standard uncertainty (``inf``: exactly known).
    source : {"user", "default", "estimate"}
    """

    name: str
    value: float
    unit: str = ""
    distribution: str = "rectangular"
    dof: float = math.inf
    source: str = "user"

    def __post_init__(self) -> None:
        value = float(self.value)
        if not math.isfinite(value) or value < 0:
            raise ValueError(f"prior of {self.name}: {value} is not a finite non-negative number")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"prior of {self.name}: distribution {self.distribution!r} is not "
                             f"one of {', '.join(DISTRIBUTIONS)}")
        if self.source not in SOURCES:
            raise ValueError(f"prior of {self.name}: source {self.source!r} is not one of "
                             f"{', '.join(SOURCES)}")
        object.__setattr__(self, "value", value)

    @property
    def standard(self) -> float:
        """Standard uncertainty: a / sqrt 3 for a bound of half-width a (GUM 4.3.7), a for +-a."""
        return self.value / math.sqrt(3.0) if self.distribution == "rectangular" else self.value

    def draw(self, rng, size) -> np.ndarray:
        """Values of the term drawn from the prior (a Monte Carlo trial's): GUM-S1 6.4.

        Uniform within ``+-value`` (rectangular), ``N(0, value^2)`` (normal),
        ``+-value`` with equal odds (two-point).
        """
        if self.distribution == "rectangular":
            return rng.uniform(-self.value, self.value, size)
        if self.distribution == "normal":
            return self.value * rng.standard_normal(size)
        return self.value * rng.choice((-1.0, 1.0), size)

    def as_dict(self) -> dict:
        """JSON-ready form."""
        return {"name": self.name, "value": self.value, "unit": self.unit,
                "distribution": self.distribution, "standard": self.standard,
                "dof": None if math.isinf(self.dof) else self.dof, "source": self.source}


@dataclass(frozen=True)
class Alias:
    """One entry of an alias matrix: how much a row moves per unit of an unestimated term.

    Attributes
    ----------
    row : str
        The reported row's name.
    term : str
        The unestimated term.
    sensitivity : float
        d(row) / d(term), row unit per term unit.
    unit : str
        Unit of the sensitivity, ``"<row unit> per <term unit>"``.
    sensor : int
        Index of the sensor.
    """

    row: str
    term: str
    sensitivity: float
    unit: str = ""
    sensor: int = 0

    def as_dict(self) -> dict:
        """JSON-ready form."""
        return {"row": self.row, "term": self.term, "sensitivity": self.sensitivity,
                "unit": self.unit, "sensor": self.sensor}


@dataclass(frozen=True)
class Contribution:
    """One Type B input's contribution to one row: ``|sensitivity| u``, itemised.

    Attributes
    ----------
    row : str
        The reported row's name.
    input : str
        The input quantity (the unestimated term's name).
    sensitivity : float
        Sensitivity coefficient, row unit per input unit.
    u : float
        Standard uncertainty of the input, its unit.
    contribution : float
        ``|sensitivity| u``, row unit.
    dof : float
        Degrees of freedom of ``u`` (``inf``: exactly known).
    unit : str
        Unit of the contribution (the row's).
    source : {"user", "default", "estimate"}
        Where the prior came from.
    sensor : int
        Index of the sensor.
    """

    row: str
    input: str
    sensitivity: float
    u: float
    contribution: float
    dof: float = math.inf
    unit: str = ""
    source: str = "user"
    sensor: int = 0

    def as_dict(self) -> dict:
        """JSON-ready form (``dof`` null when infinite)."""
        return {"row": self.row, "input": self.input, "sensitivity": self.sensitivity,
                "u": self.u, "contribution": self.contribution,
                "dof": None if math.isinf(self.dof) else self.dof, "unit": self.unit,
                "source": self.source, "sensor": self.sensor}


def alias_matrix(design, unestimated, weights=None) -> np.ndarray:
    """``A = (X' W X)^-1 X' W Z`` for weighted least squares, by a least-squares solve.

    Parameters
    ----------
    design : array_like, shape (n, p)
        The estimated terms' columns ``X``.
    unestimated : array_like, shape (n, q)
        The unestimated terms' columns ``Z``, in the same data unit per term unit.
    weights : array_like, shape (n,), optional
        Observation weights ``W`` (inverse variances); default equal.

    Returns
    -------
    numpy.ndarray, shape (p, q)

    References
    ----------
    .. [1] Montgomery D. C., Design and Analysis of Experiments, 8th ed., sec. 10.3.
    """
    x = np.asarray(design, dtype=float)
    z = np.asarray(unestimated, dtype=float).reshape(x.shape[0], -1)
    if weights is not None:
        w = np.sqrt(np.asarray(weights, dtype=float))[:, None]
        x, z = x * w, z * w
    return np.linalg.lstsq(x, z, rcond=None)[0]


def aliases(matrix, rows, terms, *, row_units=None, term_units=None,
            sensor: int = 0) -> tuple[Alias, ...]:
    """The non-negligible entries of an alias matrix as typed data (row by row).

    Entries below :data:`ALIAS_ATOL` are dropped.
    """
    a = np.asarray(matrix, dtype=float).reshape(len(rows), len(terms))
    row_units, term_units = row_units or {}, term_units or {}
    out = []
    for i, row in enumerate(rows):
        for j, term in enumerate(terms):
            if abs(a[i, j]) > ALIAS_ATOL:
                unit = f"{row_units.get(row, '')} per {term_units.get(term, '')}"
                out.append(Alias(row, term, float(a[i, j]), unit.strip(), sensor))
    return tuple(out)


def propagate(matrix, rows, terms, priors, *, row_units=None,
              sensor: int = 0) -> tuple[np.ndarray, tuple[Contribution, ...]]:
    """Type B covariance of the rows from the priors of the unestimated terms.

    Parameters
    ----------
    matrix : array_like, shape (p, q)
        Alias matrix (:func:`alias_matrix`), rows by terms.
    rows, terms : sequence of str
        Names of its rows and columns.
    priors : dict
        Term name -> :class:`Prior`; terms without a prior add nothing.
    row_units : dict, optional
        Unit of each row (for the contributions).
    sensor : int

    Returns
    -------
    covariance : numpy.ndarray, shape (p, p)
        ``sum_j A[:, j] u_j^2 A[:, j]'`` over the terms with a prior (the
        terms' priors independent).
    contributions : tuple of Contribution
        One per row and prior term with a non-negligible sensitivity.

    References
    ----------
    .. [1] JCGM 100:2008 (GUM), sec. 5.1.2, eq. (10).
    """
    a = np.asarray(matrix, dtype=float).reshape(len(rows), len(terms))
    cov = np.zeros((len(rows), len(rows)))
    out = []
    for j, term in enumerate(terms):
        prior = priors.get(term)
        if prior is None:
            continue
        u = prior.standard
        cov += np.outer(a[:, j], a[:, j]) * u**2
        for i, row in enumerate(rows):
            if abs(a[i, j]) > ALIAS_ATOL:
                out.append(Contribution(row, term, float(a[i, j]), u, abs(float(a[i, j])) * u,
                                        prior.dof, (row_units or {}).get(row, ""),
                                        prior.source, sensor))
    return cov, tuple(out)


def welch_satterthwaite(variance_a: float, dof_a: float, contributions) -> float:
    """Effective degrees of freedom of ``u_c^2 = u_A^2 + sum c_i^2`` (GUM G.4.1).

    ``nu_eff = u_c^4 / (u_A^4 / nu_A + sum c_i^4 / nu_i)``; a term with
    infinite (or zero, i.e. unstated, for the Type A part) dof adds nothing
    to the denominator; ``inf`` when nothing does.

    References
    ----------
    .. [1] JCGM 100:2008 (GUM), annex G.4.1, eq. (G.2b).
    """
    contributions = list(contributions)
    total = variance_a + sum(c.contribution**2 for c in contributions)
    denom = (variance_a**2 / dof_a) if dof_a and math.isfinite(dof_a) else 0.0
    denom += sum(c.contribution**4 / c.dof for c in contributions
                 if math.isfinite(c.dof) and c.dof > 0)
    return math.inf if denom == 0.0 else total**2 / denom


def default_priors(terms, output_unit: str = "V") -> dict:
    """The embedded default priors of ``terms``: bounds from the default accelerometer.

    Each term gets a rectangular bound of :data:`DEFAULT_PRIOR_FACTOR` times
    the magnitude the embedded default accelerometer
    (:func:`accelcal.default_model`) gives it, source ``"default"``; a term
    the default model sets to zero gets no prior.
    """
    from accelcal.defaults import default_model
    from accelcal.terms import term_unit

    model = default_model()
    out = {}
    for t in terms:
        value = abs(float(getattr(model, t, 0.0) or 0.0))
        if value > 0.0:
            out[t] = Prior(t, DEFAULT_PRIOR_FACTOR * value, term_unit(t, output_unit),
                           "rectangular", math.inf, "default")
    return out

def priors_of(priors, left, allowed, what: str) -> dict:
    """Term -> :class:`Prior` of the terms ``left`` out of a fit, from a ``priors`` argument.

    Parameters
    ----------
    priors : {"default", "none"} or dict or None
        ``"default"``: :func:`default_priors`; ``"none"`` or None: no prior;
        a dict maps a term to a :class:`Prior` or a number (a standard
        uncertainty, normal, in the term's unit, from the user).
    left : sequence of str
        The terms the fit leaves out; a prior of any other term is not used.
    allowed : collection of str
        The terms a prior may name (the model's, for this method).
    what : str
        What ``allowed`` is, for the refusal (``"a term of the shaker model"``).

    Raises
    ------
    AccelcalError
        For another string, or a prior of a term not in ``allowed`` or not a number.
    """
    if priors is None or (isinstance(priors, str) and priors == "none"):
        return {}
    if isinstance(priors, str):
        if priors != "default":
            raise AccelcalError(f"priors {priors[:40]!r} is not one of 'default', 'none' or "
                                "a dict of priors", parameter="priors")
        return default_priors(left)
    chosen = {}
    for name, p in dict(priors).items():
        if name not in allowed:
            raise AccelcalError(f"prior of {str(name)[:40]!r}: not {what}", parameter="priors")
        if isinstance(p, Prior):
            chosen[name] = p
            continue
        try:  # a number: a standard uncertainty (normal) in the term's unit, from the user
            chosen[name] = Prior(name, float(p), TERMS[name].unit, "normal")
        except (TypeError, ValueError) as exc:
            raise AccelcalError(f"prior of {name}: {exc}", parameter="priors") from None
    return {t: p for t, p in chosen.items() if t in left}


def alias_text(entries) -> list[str]:
    """One sentence per unestimated term without a prior: the rows it moves, per unit."""
    by_term: dict[str, list[Alias]] = {}
    for e in entries:
        by_term.setdefault(e.term, []).append(e)
    return [f"{term} taken as zero, no prior: it would move " + ", ".join(
        f"{e.row} by {e.sensitivity:.4g} {e.unit}".rstrip() for e in group)
        for term, group in by_term.items()]


@dataclass(frozen=True)
class Unestimated:
    """The terms a linear fit takes as zero and what they do to its rows.

    Attributes
    ----------
    terms : tuple of str
        The terms left out (neither fitted nor held) that the design sees.
    named : tuple of str
        Those the design cannot separate: they are in the rows' names.
    labels : dict
        Plain name -> combination name, for the rows that estimate one.
    covariance : numpy.ndarray, shape (p, p)
        Type B covariance of the fitted rows from the priors.
    contributions : tuple of Contribution
    aliases : tuple of Alias
        Rows moved by the separable terms, row unit per term unit.
    priors : tuple of Prior
        The priors propagated.
    """

    terms: tuple[str, ...]
    named: tuple[str, ...]
    labels: dict
    covariance: np.ndarray
    contributions: tuple[Contribution, ...]
    aliases: tuple[Alias, ...]
    priors: tuple[Prior, ...]


def unestimated(design, terms, columns: dict, *, sigma, identified,
                priors: dict) -> Unestimated:
    """Alias matrix, names and Type B contributions of the terms a linear fit leaves out.

    For a fit whose design columns and the left-out terms' columns are both
    known (the VRE's closed forms, the shaker's regressors): a zero column
    moves nothing; a column in the span of the design names the rows
    (:func:`accelcal.identifiability.combination_name`); a separable one is
    propagated by its prior (:func:`propagate`) and listed in the aliases.

    Parameters
    ----------
    design : numpy.ndarray, shape (n, p)
        The fitted terms' columns, data unit per term unit.
    terms : tuple of str
        The fitted terms.
    columns : dict of str to numpy.ndarray
        Column (n,) of every term left out (neither fitted nor held), same unit.
    sigma : numpy.ndarray or None
        Standard uncertainties of the data (the fit's weights), or None
        (unweighted, or the columns already whitened).
    identified : array_like of bool, shape (p,)
        Which fitted terms the design identifies (others get no label or contribution).
    priors : dict
        Term -> :class:`Prior`.

    References
    ----------
    .. [1] Montgomery D. C., Design and Analysis of Experiments, 8th ed., sec. 10.3.
    .. [2] JCGM 100:2008 (GUM), sec. 5.1.2.

    Returns
    -------
    Unestimated
    """
    p = len(terms)
    seen = tuple(t for t, col in columns.items() if np.any(np.asarray(col) != 0.0))
    if not seen:
        return Unestimated((), (), {}, np.zeros((p, p)), (), (), ())
    z = np.stack([np.asarray(columns[t], dtype=float) for t in seen], axis=1)
    weights = None if sigma is None else 1.0 / np.asarray(sigma, dtype=float) ** 2
    matrix = alias_matrix(design, z, weights)  # (p, q): row per unit of each term
    matrix[~np.asarray(identified, dtype=bool)] = 0.0
    named = inseparable(design, z, seen, sigma=sigma)
    labels = {}
    for i, t in enumerate(terms):
        name = combination_name(t, {u: matrix[i, j] for j, u in enumerate(seen) if u in named})
        if name != t:
            labels[t] = name
    rows = tuple(labels.get(t, t) for t in terms)
    units = {labels.get(t, t): TERMS[t].unit for t in terms}
    sep = [j for j, u in enumerate(seen) if u not in named]
    sep_terms = tuple(seen[j] for j in sep)
    used = {u: priors[u] for u in sep_terms if u in priors}
    cov, parts = propagate(matrix[:, sep], rows, sep_terms, used, row_units=units)
    entries = aliases(matrix[:, sep], rows, sep_terms, row_units=units,
                      term_units={u: TERMS[u].unit for u in sep_terms})
    return Unestimated(seen, named, labels, cov, parts, entries, tuple(used.values()))
