"""What a test design can separate: rank, null space, estimable combinations.

One module, one tolerance, for every method. A design matrix ``A`` (n
observations x p coefficients, optionally weighted by the observations'
standard deviations) is first *column-equilibrated*: each column is divided
by its Euclidean norm, so that coefficients of very different magnitude
(a bias in g beside a K4 in g/g^4) are judged alike and the decision does
not depend on the units chosen. Its singular values ``s_1 >= s_2 >= ...``
then decide the rank: ``s_k`` counts when ``s_k > RANK_RTOL * s_1``.

:data:`RANK_RTOL` is ``1e-10``. A design that is rank deficient in exact
arithmetic has its "zero" singular values at the rounding level,
``~ max(n, p) * eps * s_1`` (about 1e-13 for the designs accelcal builds,
n <= 1e6); a design whose smallest singular value is below 1e-10 of the
largest would amplify the data's noise by more than 1e10 in some direction,
which no calibration can use. Between the two lies a gap of three orders of
magnitude, so the decision is stable under rounding and under the noise of
the data that enter the design (angles, amplitudes). The condition number
reported is that of the equilibrated design, ``s_1 / s_p`` (``inf`` when
rank deficient), and ``s_1 / s_r`` over the identifiable part.

A coefficient is *identifiable* when its unit vector is orthogonal to the
null space (to within :data:`NULL_ATOL` on the unit null vectors of the
equilibrated design); the others are determined only through the linear
combinations that are orthogonal to the null space
(:func:`estimable_combinations`).

Everything here costs O(n p^2) time and O(p^2) memory beyond the design:
the null space comes from the p x p right singular vectors of the R factor
of a QR decomposition, never from an n x n matrix.

References
----------
.. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., Johns
   Hopkins, 2013, secs. 5.4-5.5 (rank-revealing decompositions,
   rank-deficient least squares).
.. [2] Searle S. R., Linear Models, Wiley, 1971, sec. 5.4 (estimable
   functions: a linear function c'x is estimable iff c lies in the row
   space of the design).
"""

import re
from dataclasses import dataclass

import numpy as np

RANK_RTOL = 1e-10
"""Relative singular-value threshold of the equilibrated design (see module docs)."""

NULL_ATOL = 1e-8
"""A coefficient whose component in every unit null vector is below this is identifiable."""


@dataclass(frozen=True)
class Combination:
    """A linear combination of coefficients, and its estimate where one exists.

    Attributes
    ----------
    weights : tuple of (str, float)
        The combination ``sum w_t x_t`` as (coefficient, weight) pairs; the
        first weight is 1.
    value : float
        Its estimate (NaN when only the combination itself is reported).
    std : float
        Its standard uncertainty (NaN likewise).
    unit : str
        Unit of the combination (that of its first coefficient).
    sensor : int
        Index of the sensor it belongs to.
    """

    weights: tuple[tuple[str, float], ...]
    value: float = float("nan")
    std: float = float("nan")
    unit: str = ""
    sensor: int = 0

    @property
    def label(self) -> str:
        """Text of the combination, e.g. ``K2 + 6 K3``."""
        return describe(dict(self.weights))

    def as_dict(self) -> dict:
        """JSON-ready form: ``{"combination", "weights", "estimate", "std", "unit", "sensor"}``."""
        return {"combination": self.label, "weights": dict(self.weights),
                "estimate": self.value, "std": self.std, "unit": self.unit,
                "sensor": self.sensor}


@dataclass(frozen=True)
class Identifiability:
    """What a design determines.

    Attributes
    ----------
    names : tuple of str
        The coefficients (design columns).
    rank : int
        Numerical rank (decided with :data:`RANK_RTOL` on the equilibrated design).
    singular_values : tuple of float
        Of the equilibrated design, largest first.
    identifiable : tuple of str
        Coefficients determined individually.
    unobservable : tuple of str
        Coefficients whose column is zero (no effect on any observation).
    null_space : numpy.ndarray
        Shape ``(p, p - rank)``: unit null vectors in coefficient coordinates.
    combinations : tuple of Combination
        Independent combinations of the non-identifiable coefficients that the
        design determines (values NaN; a reduction fills them in).
    tolerance : float
        :data:`RANK_RTOL`.
    """

    names: tuple[str, ...]
    rank: int
    singular_values: tuple[float, ...]
    identifiable: tuple[str, ...]
    unobservable: tuple[str, ...]
    null_space: np.ndarray
    combinations: tuple[Combination, ...]
    tolerance: float = RANK_RTOL

    @property
    def full_rank(self) -> bool:
        """True when every coefficient is identifiable."""
        return self.rank == len(self.names)

    @property
    def condition_number(self) -> float:
        """``s_1 / s_p`` of the equilibrated design (``inf`` when rank deficient)."""
        sv = self.singular_values
        if not sv or self.rank < len(self.names) or sv[-1] == 0.0:
            return float("inf")
        return sv[0] / sv[-1]

    @property
    def condition_number_identifiable(self) -> float:
        """``s_1 / s_rank``: the conditioning of what is identified."""
        sv = self.singular_values
        return sv[0] / sv[self.rank - 1] if self.rank else float("inf")

    @property
    def unidentifiable(self) -> tuple[str, ...]:
        """Coefficients not determined individually."""
        return tuple(n for n in self.names if n not in self.identifiable)


def _equilibrate(design, sigma=None) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(design, dtype=float)
    if sigma is not None:
        a = a / np.broadcast_to(np.asarray(sigma, dtype=float), (a.shape[0],))[:, None]
    scale = np.linalg.norm(a, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return a / scale, scale


def small_svd(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (one per column, zeros appended) and right singular vectors (p x p).

    A tall ``a`` is first reduced to its R factor, which has the same singular
    values and right vectors, so no n x n factor is ever formed.
    """
    n, p = a.shape
    if n > p:
        a = np.linalg.qr(a, mode="r")  # R has a's singular values and right vectors
    _, sv, vt = np.linalg.svd(a, full_matrices=True)
    if sv.size < p:
        sv = np.concatenate([sv, np.zeros(p - sv.size)])
    return sv, vt


def numerical_rank(singular_values) -> int:
    """Number of singular values above ``RANK_RTOL`` times the largest."""
    sv = np.asarray(singular_values, dtype=float)
    if sv.size == 0 or sv[0] <= 0.0:
        return 0
    return int((sv > RANK_RTOL * sv[0]).sum())


def analyse(design, names, *, sigma=None, units=None) -> Identifiability:
    """Rank, null space and estimable combinations of a design.

    Parameters
    ----------
    design : array_like, shape (n, p)
        Observations x coefficients.
    names : sequence of str
        The p coefficient names.
    sigma : float or array_like, optional
        Standard deviation of each observation (weights the rows).
    units : dict, optional
        Unit of each coefficient (for the combinations).

    Returns
    -------
    Identifiability

    Notes
    -----
    With a null space N (unit columns, coefficient coordinates), coefficient
    t is identifiable iff ``max_k |N[t, k]| < NULL_ATOL``. The estimable
    combinations among the others are the vectors w on those coordinates with
    ``N' w = 0`` [2]; they are returned in reduced form (first weight 1).

    References
    ----------
    .. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.5.
    .. [2] Searle S. R., Linear Models, 1971, sec. 5.4.
    """
    names = tuple(names)
    a, scale = _equilibrate(design, sigma)
    p = a.shape[1]
    if len(names) != p:
        raise ValueError(f"analyse: {len(names)} names for a design of {p} columns")
    raw_norm = np.linalg.norm(np.asarray(design, dtype=float), axis=0)
    sv, vt = small_svd(a)
    rank = numerical_rank(sv)
    null = vt[rank:].T / scale[:, None]  # back to coefficient coordinates
    norms = np.linalg.norm(null, axis=0)
    null = null / np.where(norms > 0, norms, 1.0)
    bad = np.abs(null).max(axis=1, initial=0.0) >= NULL_ATOL
    unobservable = tuple(n for n, c in zip(names, raw_norm, strict=True) if c == 0.0)
    combos = tuple(
        Combination(weights, unit=(units or {}).get(weights[0][0], ""))
        for weights in estimable_combinations(null, names, bad)
    )
    return Identifiability(
        names=names, rank=rank, singular_values=tuple(float(s) for s in sv),
        identifiable=tuple(n for n, b in zip(names, bad, strict=True) if not b),
        unobservable=unobservable, null_space=null, combinations=combos,
    )


def estimable_combinations(null, names, bad) -> list[tuple[tuple[str, float], ...]]:
    """Independent combinations of the flagged coefficients orthogonal to ``null``.

    The combinations are returned in reduced row-echelon form, which is
    unique for the subspace they span, in O(s r^2) for ``s`` flagged
    coefficients and an ``r``-dimensional null space (no s x s matrix, so a
    design with a million flagged head errors costs seconds): with
    ``M = N_s'`` (r x s), the non-pivot columns ``J`` are chosen from the
    right, each kept when independent of those kept to its right; every
    other column i gives the row ``e_i - e_J M_J^-1 M_i``.

    Parameters
    ----------
    null : numpy.ndarray, shape (p, k)
        Null-space basis in coefficient coordinates.
    names : sequence of str
    bad : array_like of bool, shape (p,)
        The coefficients not identifiable individually.

    Returns
    -------
    list of tuple of (str, float)
        Each combination with leading weight 1, weights below ``NULL_ATOL``
        dropped.
    """
    sub = np.flatnonzero(np.asarray(bad))
    if sub.size == 0 or null.shape[1] == 0:
        return []
    mat = null[sub].T  # (r, s): a combination w on sub is estimable iff mat @ w = 0
    r = numerical_rank(np.linalg.svd(mat, compute_uv=False))
    chosen: list[int] = []
    for i in range(sub.size - 1, -1, -1):
        if len(chosen) == r:
            break
        if numerical_rank(np.linalg.svd(mat[:, [*chosen, i]], compute_uv=False)) > len(chosen):
            chosen.append(i)
    chosen.sort()
    pivots = np.setdiff1d(np.arange(sub.size), chosen)
    coef = -np.linalg.lstsq(mat[:, chosen], mat[:, pivots], rcond=None)[0]  # (|J|, pivots)
    out = []
    for col, i in enumerate(pivots):
        weights = [(int(i), 1.0)] + [(int(j), float(coef[m, col])) for m, j in enumerate(chosen)
                                     if j > i and abs(coef[m, col]) > NULL_ATOL]
        out.append(tuple((names[sub[j]], v) for j, v in sorted(weights)))
    return out


def describe(weights: dict) -> str:
    """Text of a linear combination, e.g. ``K2 + 6 K3`` (weights to 6 digits)."""
    parts = []
    for name, w in weights.items():
        sign = "-" if w < 0 else "+"
        mag = "" if abs(abs(w) - 1.0) < 1e-12 else f"{abs(w):.6g} "
        parts.append(f"{sign} {mag}{name}")
    text = " ".join(parts)
    return text[2:] if text.startswith("+ ") else text


def combination_name(plain: str, shares: dict) -> str:
    """The name of a row that estimates ``plain`` plus inseparable shares of other terms.

    ``shares`` maps each term the design cannot separate from ``plain`` to
    its weight in the row (the alias matrix's entry, see
    :mod:`accelcal.aliasing`): ``combination_name("K0", {"Kpp": 1})`` is
    ``"K0+Kpp"``, ``combination_name("K2", {"Kpp": -1})`` is ``"K2-Kpp"``,
    a weight other than +-1 is written before its term (``"K3+0.5*K1_asym"``,
    6 significant digits). Weights below :data:`NULL_ATOL` are dropped; with
    none left the name is ``plain``. Every method names its rows here, so
    one combination has one name everywhere (rows, JSON, records, the store,
    reports).
    """
    text = plain
    for term, weight in shares.items():
        w = float(weight)
        if abs(w) < NULL_ATOL:
            continue
        mag = "" if abs(abs(w) - 1.0) < 1e-9 else f"{abs(w):.6g}*"
        text += f"{'-' if w < 0 else '+'}{mag}{term}"
    return text


_COMBINATION = re.compile(r"^([A-Za-z][\w']*?)((?:[+-](?:\d+(?:\.\d*)?(?:e[+-]?\d+)?\*)?"
                          r"[A-Za-z][\w']*)+)$")
"""A row name of :func:`combination_name`: the plain coefficient, then signed (weighted) terms."""


def plain_name(name: str) -> str:
    """The plain coefficient of a row name: the inverse of :func:`combination_name`.

    ``"K0+Kpp"`` -> ``"K0"``, ``"K_F+K_OO"`` -> ``"K_F"``,
    ``"K3+0.5*K1_asym"`` -> ``"K3"``; a name that is no combination
    (``"K1"``, ``"K1_T1"``) is its own plain name. Used where only the name
    survives (the store's rows) to follow a coefficient across its renaming.
    """
    match = _COMBINATION.match(name)
    return match.group(1) if match else name


def inseparable(design, unestimated, names, *, sigma=None, rtol=None) -> tuple[str, ...]:
    """The unestimated terms that the design cannot separate from the estimated ones.

    A term of ``unestimated`` (columns ``Z``, named ``names``) is
    inseparable when adding its column to ``design`` does not raise the
    rank (decided as in :func:`analyse`): the rows then estimate
    combinations that include it, named by :func:`combination_name`. With
    ``rtol``, also when the design reproduces the column to within ``rtol``
    of its norm (the part of it orthogonal to the design's columns is
    smaller): separable in exact arithmetic, but only through differences
    the data cannot see (e.g. a few microradians of misalignment), so the
    rows are named after the combination and the rest is bounded by the
    term's prior.
    """
    x = np.asarray(design, dtype=float)
    z = np.asarray(unestimated, dtype=float).reshape(x.shape[0], -1)
    if sigma is not None:
        w = 1.0 / np.broadcast_to(np.asarray(sigma, dtype=float), (x.shape[0],))[:, None]
        x, z = x * w, z * w
    base = numerical_rank(small_svd(_equilibrate(x)[0])[0])
    out = []
    for j, name in enumerate(names):
        both = np.column_stack([x, z[:, j]])
        if numerical_rank(small_svd(_equilibrate(both)[0])[0]) == base:
            out.append(name)
        elif rtol is not None:
            rest = z[:, j] - x @ np.linalg.lstsq(x, z[:, j], rcond=None)[0]
            if np.linalg.norm(rest) <= rtol * np.linalg.norm(z[:, j]):
                out.append(name)
    return tuple(out)
