"""What a stated 95 % interval covers when the unestimated terms follow their priors.

A reported row ``y +- k u_c`` combines a Type A part (the residual
scatter, ``nu_A`` degrees of freedom) with Type B contributions of the
priors of terms the reduction takes as zero (:mod:`accelcal.aliasing`), and
``k`` is Student's t of the row's Welch-Satterthwaite degrees of freedom
(``Reduction.dof_eff``, GUM G.4). That ``k`` assumes the error is close to
normal. Where a bounded prior dominates, it is not: a rectangular of
half-width ``a`` has ``u = a / sqrt 3``, and ``1.96 u = 1.13 a`` covers all
of it. This module computes, for every row with Type B, the probability
that the stated interval covers the truth when

- each prior's term follows the prior's own distribution (uniform within a
  bound, normal for a standard uncertainty, ``+-a`` with equal odds for a
  two-point prior; an input without a prior of its own reads as normal),
  the contributions of one prior to a row adding linearly (one term, one
  draw) and those of different priors independent;
- the Type A part is ``u_A t_nu`` (GUM-S1 6.4.9: a scaled t with the
  reduction's dof; normal when the noise was given), so that a row without
  Type B has exactly 95 %.

The sum's distribution is computed deterministically: the bounded and
normal Type B terms as cell masses on a grid, convolved (FFT), and the
Type A part by its exact distribution function, ``P(|X| <= k u_c) =
sum_i m_i P(|A + x_i| <= k u_c)``. No random draws; about a millisecond a
row. The rows whose probability is outside :data:`BAND` get a statement
(:func:`statements`), which the reduction's notes, rows, JSON and
calibration records carry: it states, it never alters ``k`` or ``u_c``.

References
----------
.. [1] JCGM 100:2008 (GUM), secs. 4.3.7 (rectangular distribution), G.2
   (central limit theorem: when the combined distribution is not normal),
   G.4 (Welch-Satterthwaite), G.6.5 (a dominant rectangular component).
.. [2] JCGM 101:2008 (GUM Supplement 1), 6.4.9 (a Type A input as a scaled
   and shifted t distribution), 8 (the GUM's interval checked against the
   distribution of the output).
"""

import math
from dataclasses import dataclass

import numpy as np

LEVEL = 0.95
"""The coverage probability the stated interval claims (``k`` from Student's t for it)."""

BAND = (0.93, 0.97)
"""Coverage under the priors outside this band is stated for the row (conservative above,
short below): the band the project's coverage harness holds every method to."""

CELLS = 1024
"""Grid cells across the Type B terms' joint span (the probability within 1e-5 of that of a
grid 32 times finer)."""

_NORMAL_SPAN = 8.0
"""A gridded normal Type B term is kept to +- this many standard deviations."""


def coverage_factor(dof: float, level: float = LEVEL) -> float:
    """``k`` of a two-sided ``level`` interval: Student's t for ``0 < dof < inf``, else normal.

    The rule of the coverage harness (``tests/helpers/coverage.py``), which calls it.
    """
    from scipy.special import ndtri, stdtrit

    q = 0.5 + level / 2.0
    if dof and 0.0 < dof < math.inf:
        return float(stdtrit(dof, q))
    return float(ndtri(q))


def _cell_masses(distribution: str, value: float, h: float) -> np.ndarray:
    """Probability masses of a symmetric term on the cells ``[(i - 1/2) h, (i + 1/2) h]``."""
    from scipy.special import ndtr

    if distribution == "two-point":  # +-value, each split linearly between its neighbours
        j, f = divmod(value / h, 1.0)
        j = int(j)
        m = np.zeros(2 * j + 3)
        for sign in (-1, 1):
            m[j + 1 + sign * j] += (1.0 - f) / 2.0
            m[j + 1 + sign * (j + 1)] += f / 2.0
        return m
    if distribution == "normal":
        n = math.ceil(_NORMAL_SPAN * value / h)
        x = np.arange(-n, n + 1) * h
        m = ndtr((x + h / 2) / value) - ndtr((x - h / 2) / value)
        return m / m.sum()
    n = math.ceil(value / h)  # rectangular: the cell's overlap with [-value, value]
    x = np.arange(-n, n + 1) * h
    overlap = np.minimum(x + h / 2, value) - np.maximum(x - h / 2, -value)
    return np.clip(overlap, 0.0, None) / (2.0 * value)


def coverage_probability(half_width: float, type_a: float, dof_a: float, terms) -> float:
    """``P(|A + sum_j B_j| <= half_width)`` for independent symmetric terms.

    Parameters
    ----------
    half_width : float
        Half-width of the interval, ``k u_c`` (row unit).
    type_a : float
        Scale of the Type A part ``A = type_a t_nu`` (its standard uncertainty).
    dof_a : float
        Its degrees of freedom ``nu`` (``inf`` or 0: normal).
    terms : iterable of (str, float)
        The Type B terms: ``("rectangular", a)`` uniform within ``+-a``,
        ``("normal", u)``, ``("two-point", a)`` at ``+-a`` with equal odds
        (row unit).

    Returns
    -------
    float
        The coverage probability, in [0, 1].

    References
    ----------
    .. [1] JCGM 101:2008 (GUM Supplement 1), 6.4.9.
    """
    from scipy.signal import fftconvolve
    from scipy.special import ndtr, stdtr

    terms = [(d, float(v)) for d, v in terms if float(v) > 0.0]
    finite = bool(dof_a) and 0.0 < dof_a < math.inf
    var_normal = sum(v**2 for d, v in terms if d == "normal")
    if finite:  # a t and a normal do not merge: the normal goes on the grid
        scale = type_a
        grid = [(d, v) for d, v in terms if d != "normal"]
        if var_normal > 0.0:
            grid.append(("normal", math.sqrt(var_normal)))
    else:
        scale = math.sqrt(type_a**2 + var_normal)
        grid = [(d, v) for d, v in terms if d != "normal"]

    def inside(y):
        """``P(|A' + y| <= half_width)`` of the smooth part ``A'``."""
        if finite:
            return stdtr(dof_a, (half_width - y) / scale) - stdtr(dof_a, (-half_width - y) / scale)
        return ndtr((half_width - y) / scale) - ndtr((-half_width - y) / scale)

    span = sum(_NORMAL_SPAN * v if d == "normal" else v for d, v in grid)
    if span <= 1e-12 * (half_width + scale):
        return float(inside(0.0)) if scale > 0.0 else float(half_width >= 0.0)
    h = span / CELLS
    widest = max((v for d, v in grid if d == "rectangular"), default=0.0)
    if widest >= h:  # cell edges at the widest bound's ends: its masses are exact
        h = widest / (max(round(widest / h - 0.5), 1) + 0.5)
    masses = np.ones(1)
    for d, v in grid:
        masses = np.clip(fftconvolve(masses, _cell_masses(d, v, h)), 0.0, None)
    mid = masses.size // 2  # every term is symmetric: fold the masses onto x >= 0
    folded = masses[mid:].copy()
    folded[1:] += masses[mid - 1::-1]
    x = np.arange(folded.size) * h
    if scale >= h:  # the smooth part resolves the cells: Simpson's rule across each
        half = inside(np.arange(-1, 2 * x.size) * (h / 2))  # at x - h/2, x, x + h/2
        p = (half[:-2:2] + 4.0 * half[1:-1:2] + half[2::2]) / 6.0
    else:  # it does not: each cell's mass spread evenly over the cell
        p = np.clip(np.minimum(x + h / 2, half_width) - np.maximum(x - h / 2, -half_width),
                    0.0, h) / h
    return float(np.clip(np.dot(folded, p) / folded.sum(), 0.0, 1.0))


@dataclass(frozen=True)
class RowCoverage:
    """The coverage of one row's stated interval under the priors.

    Attributes
    ----------
    row : str
        The reported row's name.
    sensor : int
        Index of the sensor.
    probability : float
        Coverage of ``y +- k u_c`` with each term following its prior.
    k : float
        The interval's ``k`` (Student's t for the row's ``dof_eff`` at :data:`LEVEL`).
    dominant : str
        The Type B input with the largest share of the variance (a bounded one, where
        the interval is conservative).
    distribution : str
        Its prior's distribution (``"normal"`` where it has no prior of its own).
    bounded_share : float
        Share of the row's variance ``u_c^2`` from bounded priors (rectangular, two-point).
    """

    row: str
    sensor: int
    probability: float
    k: float
    dominant: str
    distribution: str
    bounded_share: float

    @property
    def outside(self) -> bool:
        """True when the probability is outside :data:`BAND` (the outputs say so)."""
        return not BAND[0] <= self.probability <= BAND[1]

    def text(self, sensor_name: str = "") -> str:
        """The statement for people, e.g. ``K_I: 95 % interval conservative: covers 98.5 %...``."""
        how = {"rectangular": "uniform within its bound",
               "two-point": "at +- its bound (sign unknown)"}.get(self.distribution, "normal")
        verdict = "conservative" if self.probability > BAND[1] else "short"
        who = f" ({sensor_name})" if sensor_name else ""
        return (f"{self.row}{who}: {100 * LEVEL:.0f} % interval (k = {self.k:.3g}) {verdict}: "
                f"covers {100 * self.probability:.1f} % with {self.dominant} {how} (bounded priors "
                f"{100 * self.bounded_share:.0f} % of the variance); the stated uncertainty is "
                "kept")


def _prior_of(name: str, priors: dict):
    """The prior of an input: by its name, else the term's (another sensor's ``K3[U2]``)."""
    return priors.get(name) or priors.get(name.split("[", maxsplit=1)[0])


def row_coverage(reduction, row: str, sensor: int = 0) -> RowCoverage | None:
    """:class:`RowCoverage` of one row of a reduction; None for a row without Type B.

    The row's Type B inputs are its contributions (``Reduction.contributions``),
    those of one input added linearly with their signs (one term: the
    covariance ``A u^2 A'`` adds them so); the Type A part is the row's
    variance less theirs, with the reduction's dof; ``k`` is that of the
    row's ``Reduction.dof_eff``.
    """
    parts = reduction.contributions(row, sensor)
    if not parts or reduction.sensors[sensor].is_complex:
        return None
    u_c = reduction.std(row, sensor)
    if not (math.isfinite(u_c) and u_c > 0.0):
        return None
    priors = {p.name: p for p in reduction.priors}
    signed: dict[str, float] = {}
    for c in parts:
        signed[c.input] = signed.get(c.input, 0.0) + math.copysign(c.contribution,
                                                                    c.sensitivity)
    terms, shares = [], {}
    for name, s in signed.items():
        prior = _prior_of(name, priors)
        dist = "normal" if prior is None or prior.standard == 0.0 else prior.distribution
        ratio = 1.0 if dist == "normal" else prior.value / prior.standard
        terms.append((dist, abs(s) * ratio))
        shares[name] = (s**2 / u_c**2, dist)
    var_a = max(u_c**2 - sum(s**2 for s in signed.values()), 0.0)
    dof_a = reduction.dof if reduction.dof > 0 else math.inf
    k = coverage_factor(reduction.dof_eff(row, sensor))
    p = coverage_probability(k * u_c, math.sqrt(var_a), dof_a, terms)
    bounded = {n: s for n, (s, d) in shares.items() if d != "normal"}
    pool = bounded if p > BAND[1] and bounded else {n: s for n, (s, _) in shares.items()}
    dominant = max(pool, key=pool.get)
    return RowCoverage(reduction.sensors[sensor].label(row), sensor, p, k, dominant,
                       shares[dominant][1], min(sum(bounded.values()), 1.0))


def coverages(reduction) -> list[RowCoverage]:
    """:class:`RowCoverage` of every real row with Type B, sensor by sensor."""
    out = []
    for k, est in enumerate(reduction.sensors):
        if est.is_complex or not any(c.sensor == k for c in reduction.type_b):
            continue
        for name, value in zip(est.names, est.values, strict=True):
            if np.isfinite(value):
                rc = row_coverage(reduction, name, k)
                if rc is not None:
                    out.append(rc)
    return out


def statements(reduction) -> list[str]:
    """One sentence per row whose interval's coverage under the priors is outside :data:`BAND`."""
    many = reduction.n_sensors > 1
    return [rc.text(reduction.sensor_names[rc.sensor] if many else "")
            for rc in reduction.coverage_under_priors() if rc.outside]
