"""The GUM's arithmetic: input quantities, their standard uncertainties, a budget per result.

A budget is the table the law of propagation of uncertainty makes for one
result ``y = f(x_1, ..., x_n)`` [1]_: each input's estimate ``x_i``,
standard uncertainty ``u(x_i)``, distribution, sensitivity coefficient
``c_i = df/dx_i``, contribution ``|c_i| u(x_i)``, degrees of freedom and share
of the variance; then the combined standard uncertainty

    u_c^2 = sum_i c_i^2 u^2(x_i) + 2 sum_{i<j} c_i c_j r_ij u(x_i) u(x_j),   # Eq. (13) [GUM]

the effective degrees of freedom by Welch-Satterthwaite (eq. G.2b), the
coverage factor ``k`` (Student's t at 95.45 %, GUM G.3) and ``U = k u_c``.
The same table serves every method: what differs is where the sensitivity
coefficients come from (the method's measurement model, :mod:`accelcal.budget`).

A Type B input stated as an expanded uncertainty ``U`` with ``k`` gives
``u = U / k``; as bounds ``+-a`` it gives ``a / sqrt 3`` (rectangular),
``a / sqrt 6`` (triangular) or ``a / sqrt 2`` (U-shaped, e.g. a sinusoid's
value at a random phase) [1]_ (4.3.7, 4.3.9); judged reliable to a relative
``Delta u / u`` it has ``nu = (Delta u / u)^-2 / 2`` degrees of freedom (G.4.2).

References
----------
.. [1] JCGM 100:2008, Evaluation of measurement data - Guide to the
   expression of uncertainty in measurement (GUM), secs. 4.3, 5.1, 5.2,
   annex G.
"""

import math
from dataclasses import dataclass, field

COVERAGE = 0.9545
"""Coverage probability of the expanded uncertainty (k = 2 for a normal result)."""

DIVISORS = {"normal": 1.0, "rectangular": math.sqrt(3.0), "triangular": math.sqrt(6.0),
            "u-shaped": math.sqrt(2.0)}
"""Bounds +-a of each distribution over its standard uncertainty (GUM 4.3.7, 4.3.9)."""

DISTRIBUTIONS = (*DIVISORS, "student-t", "two-point")
"""How an input's uncertainty is distributed; ``student-t``: a Type A input with its dof;
``two-point``: ``+-u`` with equal probability (a term of unknown sign and known size)."""


def from_expanded(expanded: float, k: float) -> float:
    """Standard uncertainty ``U / k`` of an expanded uncertainty stated with its ``k``."""
    if not (math.isfinite(expanded) and expanded >= 0 and math.isfinite(k) and k > 0):
        raise ValueError(f"expanded uncertainty {expanded} with k = {k}: need U >= 0, k > 0")
    return expanded / k


def from_bounds(half_width: float, distribution: str = "rectangular") -> float:
    """Standard uncertainty of a quantity bounded by ``+-half_width`` (GUM 4.3.7, 4.3.9)."""
    if distribution not in DIVISORS:
        raise ValueError(f"distribution {distribution!r}: one of {', '.join(DIVISORS)}")
    if not (math.isfinite(half_width) and half_width >= 0):
        raise ValueError(f"bound {half_width}: need a finite half-width >= 0")
    return half_width / DIVISORS[distribution]


def dof_from_reliability(relative: float) -> float:
    """Degrees of freedom of a Type B ``u`` judged reliable to ``Delta u / u`` (GUM G.4.2)."""
    if not (math.isfinite(relative) and relative > 0):
        raise ValueError(f"relative reliability {relative}: need a finite value > 0")
    return 0.5 / relative**2  # Eq. (G.3) [GUM]


def coverage_factor(dof: float, coverage: float = COVERAGE) -> float:
    """``k``: Student's t quantile for ``dof`` at ``coverage`` (GUM G.3; normal when infinite)."""
    from scipy.stats import norm, t

    q = 0.5 + coverage / 2.0
    if not math.isfinite(dof):
        return float(norm.ppf(q))
    return float(t.ppf(q, max(dof, 1.0)))


@dataclass(frozen=True)
class Input:
    """An input quantity of a measurement model with its standard uncertainty.

    Attributes
    ----------
    quantity : str
        What it is (``"local_gravity"``, ``"Type A"``, ``"prior K3"``, ...).
    estimate : float
        Its best estimate, in ``unit``.
    u : float
        Standard uncertainty, in ``unit`` (>= 0, finite).
    unit : str
    distribution : str
        One of :data:`DISTRIBUTIONS`.
    dof : float
        Degrees of freedom (``inf`` for an exactly known ``u``).
    source : str
        Where it comes from (``"lab"``, ``"type A"``, ``"prior"``, ...).
    reference : str
        The standard's certificate, the prior's origin, ...
    components : tuple of float
        For a vector input (one independent error of this ``u`` per
        position): the sensitivity of each element; the term's sensitivity
        is then their root-sum-square. Empty for a scalar input.
    """

    quantity: str
    estimate: float
    u: float
    unit: str = ""
    distribution: str = "normal"
    dof: float = math.inf
    source: str = "lab"
    reference: str = ""
    components: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.u) and self.u >= 0):
            raise ValueError(f"{self.quantity}: standard uncertainty {self.u} is not finite >= 0")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"{self.quantity}: distribution {self.distribution!r}: one of "
                             f"{', '.join(DISTRIBUTIONS)}")
        if not (self.dof > 0):
            raise ValueError(f"{self.quantity}: degrees of freedom {self.dof} must be > 0")


@dataclass(frozen=True)
class Row:
    """One line of a budget: an input, its sensitivity and its share of the variance."""

    quantity: str
    estimate: float
    u: float
    unit: str
    distribution: str
    sensitivity: float
    contribution: float
    dof: float
    share: float
    source: str = "lab"
    reference: str = ""
    components: tuple[float, ...] = ()

    def as_dict(self) -> dict:
        """The row's JSON object (``dof`` is ``"inf"`` for an exactly known input).

        A vector input's per-element sensitivities (``components``) are not
        in it: its ``sensitivity`` is their root-sum-square.
        """
        return {"quantity": self.quantity, "estimate": self.estimate, "u": self.u,
                "unit": self.unit, "distribution": self.distribution,
                "sensitivity": self.sensitivity, "contribution": self.contribution,
                "dof": self.dof if math.isfinite(self.dof) else "inf", "share": self.share,
                "source": self.source, "reference": self.reference}


@dataclass(frozen=True)
class Budget:
    """The itemised uncertainty budget of one reported result.

    Attributes
    ----------
    coefficient : str
        The result's name (a row name of the reduction, e.g. ``"K1"``).
    estimate : float
        The result, in ``unit``.
    unit : str
    rows : tuple of Row
        Largest contribution first.
    u_c : float
        Combined standard uncertainty.
    nu_eff : float
        Effective degrees of freedom (Welch-Satterthwaite; ``inf`` possible).
    k : float
        Coverage factor at :data:`COVERAGE`.
    U : float
        Expanded uncertainty ``k u_c``.
    correlated : bool
        Whether input correlations enter ``u_c``.
    sensor : int
    serial : str
    notes : tuple of str
    check : accelcal.budget.mc.Check or None
        The Monte Carlo validation, when asked for.
    """

    coefficient: str
    estimate: float
    unit: str
    rows: tuple[Row, ...]
    u_c: float
    nu_eff: float
    k: float
    U: float
    correlated: bool = False
    sensor: int = 0
    serial: str = ""
    notes: tuple[str, ...] = field(default=())
    check: object = None

    def as_dict(self) -> dict:
        """The budget's JSON object.

        Keys ``coefficient, estimate, unit, u_c, nu_eff, k, U, correlated, rows``
        (``nu_eff`` is ``"inf"`` when infinite), and ``sensor, serial, notes``;
        ``check`` when a Monte Carlo validation was made.
        """
        out = {"coefficient": self.coefficient, "estimate": self.estimate, "unit": self.unit,
                "u_c": self.u_c,
                "nu_eff": self.nu_eff if math.isfinite(self.nu_eff) else "inf",
                "k": self.k, "U": self.U, "correlated": self.correlated,
                "sensor": self.sensor, "serial": self.serial, "notes": list(self.notes),
                "rows": [r.as_dict() for r in self.rows]}
        if self.check is not None:
            out["check"] = self.check.as_dict()
        return out


def combine(coefficient: str, estimate: float, unit: str, terms, *, correlation=None,
            coverage: float = COVERAGE, sensor: int = 0, serial: str = "",
            notes=()) -> Budget:
    """The budget of a result from its inputs and sensitivity coefficients.

    Parameters
    ----------
    coefficient, estimate, unit :
        The result.
    terms : iterable of (Input, float)
        Each input with its sensitivity coefficient ``c_i`` (result unit per
        input unit).
    correlation : dict, optional
        ``{(quantity_i, quantity_j): r_ij}`` correlation coefficients between
        inputs (either order); absent pairs are uncorrelated.
    coverage : float
        Coverage probability of ``U``.

    Returns
    -------
    Budget
        Rows sorted by contribution, largest first; ``share`` is each row's
        ``(c_i u_i)^2 / u_c^2`` (with correlations the cross terms make the
        shares sum to other than 1; ``correlated`` says so).

    References
    ----------
    .. [1] JCGM 100:2008 (GUM), eqs. (13), (G.2b); annex G.3.
    """
    terms = [(inp, float(c)) for inp, c in terms]
    pairs = {}
    for (a, b), r in (correlation or {}).items():
        if not (math.isfinite(r) and -1.0 <= r <= 1.0):
            raise ValueError(f"correlation of {a} and {b}: {r} is not in [-1, 1]")
        pairs[(a, b)] = pairs[(b, a)] = float(r)
    parts = [c * inp.u for inp, c in terms]
    variance = sum(p * p for p in parts)
    cross = 0.0
    for i in range(len(terms)):
        for j in range(i + 1, len(terms)):
            r = pairs.get((terms[i][0].quantity, terms[j][0].quantity), 0.0)
            cross += 2.0 * r * parts[i] * parts[j]
    variance += cross
    if variance < 0:  # only a wrong correlation matrix can do this
        raise ValueError(f"{coefficient}: the correlations make the variance negative")
    u_c = math.sqrt(variance)
    denom = sum(p**4 / inp.dof for (inp, _), p in zip(terms, parts, strict=True)
                if math.isfinite(inp.dof))
    nu_eff = math.inf if denom == 0.0 else variance**2 / denom  # Eq. (G.2b) [GUM]
    k = coverage_factor(nu_eff, coverage)
    rows = [Row(inp.quantity, inp.estimate, inp.u, inp.unit, inp.distribution, c, abs(p),
                inp.dof, (p * p / variance) if variance > 0 else 0.0, inp.source,
                inp.reference, tuple(inp.components))
            for (inp, c), p in zip(terms, parts, strict=True)]
    rows.sort(key=lambda r: r.contribution, reverse=True)
    return Budget(coefficient, float(estimate), unit, tuple(rows), u_c, nu_eff, k, k * u_c,
                  bool(cross), sensor, serial, tuple(notes))
