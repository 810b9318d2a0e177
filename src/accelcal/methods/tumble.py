"""Multipoint tumble test (IEEE 1293 style): identifiability and reduction.

The accelerometer is turned about one of its own axes through N positions
theta_j in the gravity field (1 g). About the output axis (OA) the specific
force is ``a_i = cos(theta)``, ``a_p = sin(theta)``, ``a_o = 0``; about the
pendulum axis (PA, the indexing head of Dong2014) it is ``a_i = sin(theta)``,
``a_o = cos(theta)``, ``a_p = 0``.

The model (see :mod:`accelcal.model`) is linear in the output-unit
coefficients ``b_t = K1 K_t`` (with ``b_K1 = K1``)::

    E(theta) = sum_t b_t f_t(theta)

so a position set identifies exactly the linear functionals of ``b`` in the
row space of the design ``D[j, t] = f_t(theta_j)``. :func:`identifiability`
analyses that space (rank, condition number, which terms are determined
alone, which only in combination); :func:`reduce_tumble` estimates what is
identifiable, by the IEEE Fourier relations for uniform sets of eight or
more positions or by least squares otherwise, with covariance. Coefficients
in g/g^n are ``K_t = b_t / K1`` (first-order covariance propagation).

Leading axes of the outputs are trials; the last axis is positions.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers, annex on
   multipoint tumble analysis.
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [DOMAIN] accelcal domain notes, section 5 (corrected where docs/errata.md
   says so).
"""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.model import TERMS, term_unit
from accelcal.results import Estimate
from accelcal.units import OUTPUT_UNITS

AXES = ("OA", "PA")
"""Rotation axes: the accelerometer's output axis or pendulum axis."""

FULL_TERMS: dict[str, tuple[str, ...]] = {
    "OA": ("K0", "K1", "K2", "K3", "K4", "Kp", "Kpp", "Kip"),
    "PA": ("K0", "K1", "K2", "K3", "K4", "Ko", "Koo", "Kio"),
}
"""Every symmetric term a rotation about each axis excites (asymmetry aside)."""

DEFAULT_TERMS: dict[str, tuple[str, ...]] = {
    "OA": ("K0", "K1", "K2", "K3", "K4", "Kp", "Kip"),
    "PA": ("K0", "K1", "K2", "K3", "K4", "Ko", "Kio"),
}
"""Terms the reduction estimates by default: the IEEE Fourier set. The
cross-axis nonlinearity (Kpp about OA, Koo about PA) is left out because no
rotation about a single axis separates it from K0 and K2 (a_i^2 + a_p^2 = 1
about OA, a_i^2 + a_o^2 = 1 about PA): without it, K0 and K2 stand for
K0 + Kpp and K2 - Kpp (OA) or K0 + Koo and K2 - Koo (PA)."""

ASYMMETRY_TERMS = ("K0_asym", "K1_asym")
"""Optional asymmetry terms, ``1/2 sgn(a_i) (K0' + K1' a_i)``."""

_PRIORITY = ("K1", "K0", "Ko", "Kp", "K2", "Kio", "Kip", "K3", "K4", "Koo", "Kpp", *ASYMMETRY_TERMS)
"""Order in which terms are preferred when a choice among aliases is made."""

_SNAP = 4.0 * np.finfo(float).eps
"""|cos|, |sin| below this are exactly zero (cos(pi/2) rounds to 6e-17)."""

_ESTIMABLE_TOL = 1e-8
"""A term is identifiable when its squared norm in the null space is below this."""

_RANK_RTOL = 1e-10
"""Singular values below this times the largest count as zero."""

_ANGLE_TOL = 1e-9
"""Two angles closer than this (rad, modulo 2 pi) are the same position."""


# ----------------------------------------------------------------- records
@dataclass(frozen=True)
class Combination:
    """A linear combination of output-unit coefficients ``b_t = K1 K_t``.

    Attributes
    ----------
    label : str
        Human-readable form, e.g. ``"K1*(1 + K3)"`` or ``"K1*(K0 + Kpp)"``.
    weights : tuple of (str, float)
        The combination ``sum w_t b_t`` as (term, weight) pairs.
    """

    label: str
    weights: tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class IdentifiabilityReport:
    """What a set of tumble positions can separate.

    Attributes
    ----------
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about.
    angles_rad : tuple of float
        The positions, rad.
    terms : tuple of str
        The model terms analysed (accelcal names).
    rank : int
        Rank of the design (number of independent combinations determined).
    condition_number : float
        Ratio of largest to smallest singular value of the design; ``inf``
        when it is rank deficient.
    condition_number_identifiable : float
        The same over the non-zero singular values only: the conditioning
        of what is identified.
    singular_values : tuple of float
        Singular values of the design (columns are the g-unit regressors).
    identifiable : tuple of str
        Terms determined individually (their output-unit value ``K1 K_t``;
        their value in g/g^n also needs K1 to be identifiable).
    unobservable : tuple of str
        Terms with no effect at any of the positions.
    aliased : tuple of tuple of str
        Groups of terms determined only in combination with each other.
    combinations : tuple of Combination
        Independent identifiable combinations within each aliased group.
    suggested_terms : tuple of str
        A largest identifiable subset, choosing among aliases in the order
        K1, K0, cross-axis, K2, cross-coupling, K3, K4, cross nonlinearity,
        asymmetry. Using it takes the other terms as zero.
    uniform : bool
        Whether the positions are N equally spaced angles.
    """

    rotation_axis: str
    angles_rad: tuple[float, ...]
    terms: tuple[str, ...]
    rank: int
    condition_number: float
    condition_number_identifiable: float
    singular_values: tuple[float, ...]
    identifiable: tuple[str, ...]
    unobservable: tuple[str, ...]
    aliased: tuple[tuple[str, ...], ...]
    combinations: tuple[Combination, ...]
    suggested_terms: tuple[str, ...]
    uniform: bool

    @property
    def n_positions(self) -> int:
        """Number of positions."""
        return len(self.angles_rad)

    @property
    def full_rank(self) -> bool:
        """True when every term is identifiable."""
        return self.rank == len(self.terms)

    def status(self, term: str) -> str:
        """``"identifiable"``, ``"unobservable"`` or ``"aliased with ..."`` for one term."""
        if term in self.identifiable:
            return "identifiable"
        if term in self.unobservable:
            return "unobservable"
        group = next(g for g in self.aliased if term in g)
        return "aliased with " + ", ".join(t for t in group if t != term)

    def rows(self) -> list[dict]:
        """One row per term: ``term``, ``status`` (for tables and files)."""
        return [{"term": t, "status": self.status(t)} for t in self.terms]

    def summary(self) -> str:
        """A few lines of text describing the report."""
        lines = [
            (
                f"{self.n_positions} positions ({'uniform' if self.uniform else 'non-uniform'}), "
                f"rotation about {self.rotation_axis}: "
                f"rank {self.rank} of {len(self.terms)} terms, "
                f"condition number {self.condition_number:.4g} "
                f"(identifiable part {self.condition_number_identifiable:.4g})"
            ),
            "identifiable: " + (", ".join(self.identifiable) or "none"),
        ]
        if self.unobservable:
            lines.append("not observable: " + ", ".join(self.unobservable))
        for group in self.aliased:
            combos = [c.label for c in self.combinations if {w[0] for w in c.weights} <= set(group)]
            lines.append(f"aliased: {', '.join(group)}; determined only as {'; '.join(combos)}")
        return "\n".join(lines)


@dataclass(frozen=True)
class FourierCoefficients:
    """Discrete Fourier coefficients of a uniform tumble, harmonics 0..kmax.

    ``A[..., 0]`` is the mean output. For ``0 < k < N/2``,
    ``A_k = (2/N) sum E cos(k theta)`` and ``B_k = (2/N) sum E sin(k theta)``.
    At the Nyquist harmonic ``k = N/2`` (even N), ``cos(k theta_j) =
    cos(k theta_0) (-1)^j`` and ``sin(k theta_j) = sin(k theta_0) (-1)^j``
    are proportional, so only one amplitude is observable: ``A_k`` is the
    amplitude of ``cos(k theta)`` alone, ``sum E cos(k theta) / sum
    cos^2(k theta)`` (``(1/N) sum E cos(k theta)`` when theta_0 = 0; NaN when
    ``cos(k theta_0) = 0``), and ``B_k`` is set to 0. The tumble model has
    no ``sin(4 theta)`` term, so this is the amplitude it needs. Harmonics
    above N/2 are not computed.

    Attributes
    ----------
    k : tuple of int
        Harmonic numbers.
    A, B : numpy.ndarray
        Shape ``(..., len(k))``, in the output unit.
    """

    k: tuple[int, ...]
    A: np.ndarray
    B: np.ndarray


@dataclass(frozen=True)
class CombinationEstimate:
    """Estimate of an identifiable combination of aliased terms (output unit)."""

    combination: Combination
    value: np.ndarray
    std: np.ndarray


@dataclass(frozen=True)
class TumbleResult:
    """Result of :func:`reduce_tumble`.

    Attributes
    ----------
    names : tuple of str
        Term names (accelcal names), in the order of ``terms``.
    values : numpy.ndarray
        Shape ``(..., p)``: K1 in output unit per g, the others in g/g^n;
        NaN where not identifiable.
    covariance : numpy.ndarray
        Shape ``(..., p, p)``; NaN rows and columns for unidentifiable terms.
    units : dict
        Unit of each term.
    route : {"fourier", "lsq"}
        How the estimate was computed.
    residuals : numpy.ndarray
        Shape ``(..., N)``, observed minus fitted, output unit.
    dof : int
        Residual degrees of freedom (N minus the rank).
    sigma : numpy.ndarray
        Shape ``(...)``: the noise SD per (averaged) position used for the
        covariance, output unit (estimated from the residuals unless given).
    notes : tuple of str
        Unidentifiable terms, assumptions, errata applied.
    identifiability : IdentifiabilityReport
        The report for the positions and terms.
    fourier : FourierCoefficients or None
        The A_k, B_k of the (averaged) outputs; None for non-uniform positions.
    combinations : tuple of CombinationEstimate
        Estimates of the identifiable combinations of aliased terms.
    """

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    units: dict
    route: str
    residuals: np.ndarray
    dof: int
    sigma: np.ndarray
    notes: tuple[str, ...]
    identifiability: IdentifiabilityReport
    fourier: FourierCoefficients | None
    combinations: tuple[CombinationEstimate, ...]

    def __post_init__(self) -> None:
        for name in ("values", "covariance", "residuals", "sigma"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """The leading (trial) shape of the outputs."""
        return self.values.shape[:-1]

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties, shape ``(..., p)``."""
        return np.sqrt(np.diagonal(self.covariance, axis1=-2, axis2=-1))

    @property
    def estimate(self) -> Estimate:
        """The result as an :class:`accelcal.results.Estimate` (single record only).

        Raises
        ------
        AccelcalError
            When the outputs had leading (trial) axes: use :meth:`estimate_at`.
        """
        if self.batch_shape:
            raise AccelcalError(
                f"tumble result holds {self.batch_shape} trials; use estimate_at(index) "
                "for one of them, or values/covariance for all"
            )
        return self.estimate_at(())

    def estimate_at(self, index=()) -> Estimate:
        """The :class:`~accelcal.results.Estimate` of one trial (``index``: leading axes)."""
        if not isinstance(index, tuple):
            index = (index,)
        return Estimate(
            names=self.names,
            values=self.values[index],
            covariance=self.covariance[index],
            units=self.units,
            method=f"tumble-{self.route}",
            residuals=self.residuals[index],
            dof=self.dof,
            notes=self.notes,
            provenance={
                "rotation_axis": self.identifiability.rotation_axis,
                "positions": self.identifiability.n_positions,
                "route": self.route,
            },
        )


# ---------------------------------------------------------------- geometry
def specific_force(angles_rad, rotation_axis: str = "OA"):
    """Specific force (a_i, a_o, a_p) in g at tumble angles theta.

    Parameters
    ----------
    angles_rad : array_like
        Head angles theta, rad.
    rotation_axis : {"OA", "PA"}
        About OA: ``a_i = cos theta, a_p = sin theta``; about PA:
        ``a_i = sin theta, a_o = cos theta``. Components within 4 eps of
        zero are set to exactly zero (so that ``sgn(a_i)`` is 0 where the
        input axis is horizontal).

    Returns
    -------
    tuple of numpy.ndarray
        ``(a_i, a_o, a_p)``, each of the shape of ``angles_rad``.

    References
    ----------
    .. [1] DOMAIN section 5 (OA); Dong2014 set-up, DOMAIN section 4 (PA).
    """
    axis = _check_axis(rotation_axis)
    theta = np.asarray(angles_rad, dtype=float)
    c, s = _snap(np.cos(theta)), _snap(np.sin(theta))
    zero = np.zeros_like(theta)
    if axis == "OA":
        return c, zero, s  # [DOMAIN] section 5
    return s, c, zero  # [Dong2014] set-up, a_i = sin b, a_o = cos b


def design_matrix(angles_rad, rotation_axis: str = "OA", terms=None) -> np.ndarray:
    """Regressors ``f_t(theta_j)`` of the output-unit coefficients ``b_t = K1 K_t``.

    ``E(theta_j) = sum_t b_t f_t(theta_j)``: ``f_K1 = a_i``, ``f_K0 = 1``,
    ``f_K2 = a_i^2``, ``f_Kp = a_p``, ``f_Kip = a_i a_p``, ...,
    ``f_K0_asym = sgn(a_i)/2``, ``f_K1_asym = sgn(a_i) a_i / 2``.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
    rotation_axis : {"OA", "PA"}
    terms : sequence of str, optional
        Default :data:`FULL_TERMS` of the axis.

    Returns
    -------
    numpy.ndarray, shape (N, p)

    References
    ----------
    .. [1] Guan2021 eqs. (1)-(3) with K4 [IEEE1293]: the model of accelcal.model.
    """
    axis = _check_axis(rotation_axis)
    terms = _check_terms(terms, axis, FULL_TERMS[axis])
    a_i, a_o, a_p = specific_force(angles_rad, axis)
    sgn = np.sign(a_i)
    columns = {
        "K0": np.ones_like(a_i),
        "K1": a_i,
        "K2": a_i**2,
        "K3": a_i**3,
        "K4": a_i**4,
        "Ko": a_o,
        "Kp": a_p,
        "Koo": a_o**2,
        "Kpp": a_p**2,
        "Kio": a_i * a_o,
        "Kip": a_i * a_p,
        "K0_asym": 0.5 * sgn,  # Eq. (3) [Guan2021]
        "K1_asym": 0.5 * sgn * a_i,  # Eq. (3) [Guan2021]
    }
    return np.column_stack([columns[t] for t in terms])


# ------------------------------------------------------------ identifiability
def identifiability(angles_rad, rotation_axis: str = "OA", *, terms=None) -> IdentifiabilityReport:
    """Which coefficients a set of tumble positions can separate.

    Builds the design of the model's terms at the positions (see
    :func:`design_matrix`) and analyses its column space by SVD: rank,
    condition number, the terms determined individually, those with no
    effect, and the groups of aliased terms with the combinations of them
    that are determined.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        Positions theta_j, rad (distinct modulo 2 pi).
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about.
    terms : sequence of str, optional
        Terms to analyse. Default :data:`FULL_TERMS` of the axis (asymmetry
        terms may be added).

    Returns
    -------
    IdentifiabilityReport

    Raises
    ------
    AccelcalError
        For an unknown axis, a term that does not apply to it, no K1,
        repeated terms, or non-finite or duplicated angles.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5.
    .. [2] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.5
       (rank-deficient least squares).

    Examples
    --------
    >>> import numpy as np
    >>> r = identifiability(np.arange(4) * np.pi / 2, "OA")
    >>> r.rank, r.unobservable
    (4, ('Kip',))
    """
    axis = _check_axis(rotation_axis)
    angles = _check_angles(angles_rad)
    terms = _check_terms(terms, axis, FULL_TERMS[axis])
    D = design_matrix(angles, axis, terms)
    return _analyse(D, angles, axis, terms)


def _analyse(D, angles, axis, terms) -> IdentifiabilityReport:
    n, p = D.shape
    _, s, vt = np.linalg.svd(D, full_matrices=True)
    smax = s[0] if s.size else 0.0
    rank = int(np.sum(s > _RANK_RTOL * smax)) if smax > 0 else 0
    null = vt[rank:].T  # (p, p - rank)
    proj = null @ null.T  # projector on the null space: basis independent
    in_null = np.diag(proj) > _ESTIMABLE_TOL
    col_norm = np.linalg.norm(D, axis=0)
    unobservable = tuple(
        t for t, c in zip(terms, col_norm, strict=True) if c <= _RANK_RTOL * max(smax, 1.0)
    )
    identifiable = tuple(t for t, bad in zip(terms, in_null, strict=True) if not bad)
    groups = _alias_groups(proj, in_null, terms, unobservable)
    combinations = tuple(c for g in groups for c in _combinations(vt[:rank].T, terms, g))
    cond = float(smax / s[p - 1]) if rank == p else float("inf")
    cond_id = float(smax / s[rank - 1]) if rank else float("inf")
    return IdentifiabilityReport(
        rotation_axis=axis,
        angles_rad=tuple(float(a) for a in angles),
        terms=tuple(terms),
        rank=rank,
        condition_number=cond,
        condition_number_identifiable=cond_id,
        singular_values=tuple(float(v) for v in s[: min(n, p)]),
        identifiable=identifiable,
        unobservable=unobservable,
        aliased=groups,
        combinations=combinations,
        suggested_terms=_suggest(D, terms),
        uniform=_is_uniform(angles),
    )


def _alias_groups(proj, in_null, terms, unobservable):
    """Connected components of the null-space projector among aliased terms."""
    idx = [i for i, t in enumerate(terms) if in_null[i] and t not in unobservable]
    link = np.abs(proj) > _ESTIMABLE_TOL
    groups, seen = [], set()
    for start in idx:
        if start in seen:
            continue
        stack, comp = [start], set()
        while stack:
            i = stack.pop()
            if i in comp:
                continue
            comp.add(i)
            stack.extend(j for j in idx if link[i, j] and j not in comp)
        seen |= comp
        groups.append(tuple(terms[i] for i in sorted(comp)))
    return tuple(groups)


def _combinations(row_basis, terms, group):
    """Identifiable functionals supported on ``group``, in reduced echelon form."""
    order = sorted(group, key=_PRIORITY.index)
    cols = [terms.index(t) for t in order]
    # Functionals w on the group with w orthogonal to the null space: the row
    # space of D intersected with the group's coordinates.
    others = [i for i in range(len(terms)) if i not in cols]
    rb = row_basis  # (p, r), orthonormal columns spanning the row space
    if others:
        # Row-space vectors with zero weight outside the group.
        _, s, vt = np.linalg.svd(rb[others], full_matrices=True)
        k = int(np.sum(s > 1e-9))
        coeff = vt[k:].T  # (r, r - k)
        w = (rb @ coeff)[cols]  # (|g|, m)
    else:
        w = rb[cols]
    m = w.shape[1]
    if m == 0:
        return []
    rows = _rref(w.T)
    out = []
    for row in rows[:m]:
        weights = tuple((t, float(v)) for t, v in zip(order, row, strict=True) if abs(v) > 1e-9)
        out.append(Combination(label=_label(weights), weights=weights))
    return out


def _rref(a):
    a = np.array(a, dtype=float)
    rows, cols = a.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(a[r:, c])))
        if abs(a[piv, c]) < 1e-9:
            continue
        a[[r, piv]] = a[[piv, r]]
        a[r] /= a[r, c]
        for i in range(rows):
            if i != r:
                a[i] -= a[i, c] * a[r]
        r += 1
    a[np.abs(a) < 1e-12] = 0.0
    return a[:r]


def _label(weights) -> str:
    """``sum w_t b_t`` written as ``K1*(...)`` with b_K1 = K1 and b_t = K1 K_t."""
    text = ""
    for term, w in weights:
        mag = abs(w)
        if term == "K1":
            part = f"{mag:.6g}"
        elif np.isclose(mag, 1.0, rtol=0.0, atol=1e-9):
            part = term
        else:
            part = f"{mag:.6g}*{term}"
        if not text:
            text = part if w > 0 else "-" + part
        else:
            text += (" + " if w > 0 else " - ") + part
    return f"K1*({text})"


def _suggest(D, terms):
    """Greedy largest identifiable subset, in :data:`_PRIORITY` order."""
    chosen, cols = [], []
    for t in sorted(terms, key=_PRIORITY.index):
        trial = np.column_stack([*cols, D[:, terms.index(t)]])
        s = np.linalg.svd(trial, compute_uv=False)
        if s.size == trial.shape[1] and s[-1] > _RANK_RTOL * s[0]:
            chosen.append(t)
            cols.append(D[:, terms.index(t)])
    return tuple(t for t in terms if t in chosen)


# ------------------------------------------------------------------ Fourier
def fourier_coefficients(angles_rad, outputs, kmax: int = 4) -> FourierCoefficients:
    """The A_k, B_k of a uniform tumble, harmonics 0..min(kmax, N//2).

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        N equally spaced positions (any start, any order), rad.
    outputs : array_like, shape (..., N)
        Outputs at the positions.
    kmax : int
        Highest harmonic wanted.

    Returns
    -------
    FourierCoefficients

    Raises
    ------
    AccelcalError
        If the positions are not uniform or the shapes do not match.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5.
    """
    angles = _check_angles(angles_rad)
    y = _check_outputs(outputs, angles.size)
    if not _is_uniform(angles):
        raise AccelcalError(
            "Fourier coefficients need N equally spaced positions; these are not "
            "(use the least-squares route for non-uniform positions)"
        )
    n = angles.size
    ks = tuple(range(min(int(kmax), n // 2) + 1))
    k = np.asarray(ks, dtype=float)
    cos_k, sin_k = np.cos(np.outer(angles, k)), np.sin(np.outer(angles, k))  # (N, K)
    weight = 1.0 / _cos_norm(angles, k)  # 2/N below Nyquist
    A = (y @ cos_k) * weight  # Eq. A_k = (2/N) sum E cos(k theta) [IEEE1293]
    B = np.where(2 * k == n, 0.0, (y @ sin_k) * weight)  # Eq. B_k [IEEE1293]
    return FourierCoefficients(k=ks, A=A, B=B)


def _cos_norm(angles, k):
    """Sum over the positions of cos^2(k theta) for a uniform set.

    N at k = 0, N/2 for 0 < k < N/2 and N cos^2(k theta_0) at the Nyquist
    harmonic k = N/2; NaN there when it vanishes, so that the amplitude comes
    out NaN rather than as a silent value.
    """
    n = angles.size
    norm = np.where(k == 0, float(n), n / 2.0)
    nyq = 2 * k == n
    if nyq.any():
        c2 = float(np.sum(np.cos(k[nyq][0] * angles) ** 2))
        norm = np.where(nyq, c2 if c2 > 1e-9 * n else np.nan, norm)
    return norm


def _fourier_map(axis: str, terms, ks):
    """Matrix L with b = L h, h the harmonic amplitudes used, for DEFAULT_TERMS.

    Rows follow ``terms``; h = (A0, A1, B1, A2, B2, A3, B3, A4).
    """
    idx = {"A0": 0, "A1": 1, "B1": 2, "A2": 3, "B2": 4, "A3": 5, "B3": 6, "A4": 7}
    rows = {}

    def row(**w):
        r = np.zeros(len(idx))
        for key, v in w.items():
            r[idx[key]] = v
        return r

    if axis == "OA":
        # A1 = K1 (1 + 3 K3/4), 4 A3/K1 = K3  ->  K1 = A1 - 3 A3   # Eq. [DOMAIN] s. 5
        rows["K1"] = row(A1=1.0, A3=-3.0)
        rows["K3"] = row(A3=4.0)  # 4 A3 = K1 K3  # [DOMAIN] s. 5
        rows["Kp"] = row(B1=1.0)  # B1 = K1 Kp (IEEE delta_o)  # [DOMAIN] s. 5
        rows["Kip"] = row(B2=2.0)  # 2 B2 = K1 Kip  # [DOMAIN] s. 5
        rows["K4"] = row(A4=8.0)  # 8 A4 = K1 K4  # [DOMAIN] s. 5
        rows["K2"] = row(A2=2.0, A4=-8.0)  # 2 A2 = K1 (K2 - Kpp + K4)  # [DOMAIN] s. 5
        # A0 = K1 (K0 + (K2 + Kpp)/2 + 3 K4/8)  # [DOMAIN] s. 5
        rows["K0"] = row(A0=1.0, A2=-1.0, A4=1.0)  # b0 = A0 - b2/2 - 3 b4/8
    else:
        # About PA: B1 = K1 (1 + 3 K3/4), B3 = -K1 K3/4, A1 = K1 Ko,
        # 2 B2 = K1 Kio, 8 A4 = K1 K4, -2 A2 = K1 (K2 - Koo + K4),
        # A0 = K1 (K0 + (K2 + Koo)/2 + 3 K4/8).  # Derived as [DOMAIN] s. 5, a_i = sin
        rows["K1"] = row(B1=1.0, B3=3.0)
        rows["K3"] = row(B3=-4.0)
        rows["Ko"] = row(A1=1.0)
        rows["Kio"] = row(B2=2.0)
        rows["K4"] = row(A4=8.0)
        rows["K2"] = row(A2=-2.0, A4=-8.0)
        rows["K0"] = row(A0=1.0, A2=1.0, A4=1.0)  # b0 = A0 - b2/2 - 3 b4/8
    used = [k for k in idx if int(k[1]) in ks]
    return np.array([rows[t] for t in terms]), used, idx


def _harmonics_vector(fc: FourierCoefficients, idx):
    h = np.zeros((*fc.A.shape[:-1], len(idx)))
    for key, i in idx.items():
        k = int(key[1])
        if k in fc.k:
            h[..., i] = (fc.A if key[0] == "A" else fc.B)[..., fc.k.index(k)]
    return h


# --------------------------------------------------------------- reduction
def reduce_tumble(
    angles_rad,
    outputs,
    *,
    rotation_axis: str = "OA",
    output_unit: str = "V",
    terms=None,
    route: str = "auto",
    sigma=None,
    repeats: bool = False,
) -> TumbleResult:
    """Reduce a multipoint tumble to the model's coefficients, with covariance.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        Positions theta_j, rad, distinct modulo 2 pi.
    outputs : array_like, shape (..., N) or (..., N, R) with ``repeats``
        Outputs in ``output_unit``; leading axes are independent trials.
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about (see :func:`specific_force`).
    output_unit : {"V", "mV", "mA", "g"}
        Unit of the outputs (K1 is then in output_unit/g).
    terms : sequence of str, optional
        Terms to estimate (must include K1); terms left out are taken as
        zero, and the notes say so. Default :data:`DEFAULT_TERMS` of the axis.
    route : {"auto", "fourier", "lsq"}
        ``"fourier"``: the IEEE relations between A_k, B_k and the
        coefficients (needs N >= 8 uniform positions and the default
        terms); ``"lsq"``: least squares on the design; ``"auto"``: Fourier
        when it applies, else least squares. Both give the same numbers
        where both apply.
    sigma : float, optional
        Known noise SD of one reading, output unit. Without it the noise is
        estimated from the residuals (needs N greater than the rank).
    repeats : bool
        When True the last axis of ``outputs`` holds R repeated readings at
        each position; they are averaged.

    Returns
    -------
    TumbleResult
        Terms that the positions cannot separate are NaN (value and
        covariance) and listed in ``notes``; identifiable combinations of
        them are in ``combinations``.

    Raises
    ------
    AccelcalError
        Fewer positions than terms, duplicated angles, non-finite outputs,
        mismatched shapes, no degrees of freedom without ``sigma``, a
        route that does not apply, or a bad axis, term or unit.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5 (the
       Fourier relations, checked and extended to rotation about PA).
    .. [2] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.5.

    Examples
    --------
    >>> import numpy as np
    >>> from accelcal import ErrorModel
    >>> theta = np.arange(24) * 2 * np.pi / 24
    >>> truth = ErrorModel(K0=1e-4, K1=1.2, K2=2e-5, K3=-3e-6, Kp=5e-5)
    >>> a_i, a_o, a_p = specific_force(theta, "OA")
    >>> res = reduce_tumble(theta, truth.output(a_i, a_o, a_p) + 1e-9 * np.cos(7 * theta))
    >>> round(res.estimate["K2"] / 2e-5, 6), res.route
    (1.0, 'fourier')
    """
    axis = _check_axis(rotation_axis)
    if output_unit not in OUTPUT_UNITS:
        raise AccelcalError(f"output_unit {output_unit!r} is not one of {', '.join(OUTPUT_UNITS)}")
    if route not in ("auto", "fourier", "lsq"):
        raise AccelcalError(f"route {route!r} is not one of auto, fourier, lsq")
    angles = _check_angles(angles_rad)
    terms = _check_terms(terms, axis, DEFAULT_TERMS[axis])
    n, p = angles.size, len(terms)
    y = np.asarray(outputs, dtype=float)
    n_rep = 1
    if repeats:
        if y.ndim < 2 or y.shape[-2] != n:
            raise AccelcalError(
                f"with repeats, outputs must have shape (..., {n}, R) for {n} positions; "
                f"got {y.shape}"
            )
        n_rep = y.shape[-1]
        _check_outputs(y.reshape(*y.shape[:-2], -1), n * n_rep)
        y = y.mean(axis=-1)
    y = _check_outputs(y, n)
    if n < p:
        report = identifiability(angles, axis, terms=terms)
        raise AccelcalError(
            f"{n} positions cannot determine {p} unknowns ({', '.join(terms)}); these "
            f"positions identify at most {report.rank}: use terms={list(report.suggested_terms)} "
            "or more positions"
        )
    if sigma is not None:
        sigma = float(sigma)
        if not np.isfinite(sigma) or sigma <= 0:
            raise AccelcalError(f"sigma = {sigma} must be a positive finite noise SD (output unit)")
    D = design_matrix(angles, axis, terms)
    report = _analyse(D, angles, axis, terms)
    dof = n - report.rank
    if dof == 0 and sigma is None:
        raise AccelcalError(
            f"{n} positions and {report.rank} identifiable combinations leave no degrees of "
            "freedom to estimate the noise; give sigma (noise SD, output unit) or more positions"
        )
    fourier_ok = (
        report.uniform and n >= 8 and report.full_rank and set(terms) == set(DEFAULT_TERMS[axis])
    )
    if route == "fourier" and not fourier_ok:
        raise AccelcalError(
            "the Fourier route needs at least 8 equally spaced positions that separate the "
            f"default terms {', '.join(DEFAULT_TERMS[axis])}; use route='lsq'"
        )
    use_fourier = fourier_ok and route in ("auto", "fourier")
    fc = fourier_coefficients(angles, y) if report.uniform else None
    sigma_mean = None if sigma is None else sigma / np.sqrt(n_rep)
    if use_fourier:
        b, cov_b, resid, s = _fourier_solution(
            angles, y, fc, axis=axis, terms=terms, dof=dof, sigma=sigma_mean
        )
    else:
        b, cov_b, resid, s = _lsq_solution(D, y, report.rank, dof, sigma_mean)
    k1 = b[..., terms.index("K1")]
    floor = 1e-10 * np.max(np.abs(y), axis=-1)  # rounding level of the outputs, x 1e6
    if "K1" in report.identifiable and not np.all(np.abs(k1) > floor):
        raise AccelcalError(
            "the scale factor K1 estimated from these outputs is 0 (no response to the "
            "input axis): check the outputs column and the rotation axis"
        )
    values, cov = _to_g_units(b, cov_b, terms)
    ident_b = np.array([t in report.identifiable for t in terms])
    k1_ok = "K1" in report.identifiable
    ident = ident_b & k1_ok
    values = np.where(ident, values, np.nan)
    mask = ident[:, None] & ident[None, :]
    cov = np.where(mask, cov, np.nan)
    combos = tuple(_combination_estimate(c, b, cov_b, terms) for c in report.combinations)
    notes = _notes(report, terms, axis, k1_ok=k1_ok, use_fourier=use_fourier, n_rep=n_rep)
    units = {t: term_unit(t, output_unit) for t in terms}
    return TumbleResult(
        names=tuple(terms),
        values=values,
        covariance=cov,
        units=units,
        route="fourier" if use_fourier else "lsq",
        residuals=resid,
        dof=dof,
        sigma=s,
        notes=notes,
        identifiability=report,
        fourier=fc,
        combinations=combos,
    )


def _lsq_solution(D, y, rank, dof, sigma):
    u, s, vt = np.linalg.svd(D, full_matrices=False)
    ur, sr, vr = u[:, :rank], s[:rank], vt[:rank].T
    pinv = vr @ (ur / sr).T  # (p, N): minimum-norm solution; unique on estimable functionals
    b = y @ pinv.T
    resid = y - b @ D.T
    s_hat = _noise(resid, dof, sigma)
    cov_unit = (vr / sr**2) @ vr.T
    return b, s_hat[..., None, None] ** 2 * cov_unit, resid, s_hat


def _fourier_solution(angles, y, fc, *, axis, terms, dof, sigma):
    L, used, idx = _fourier_map(axis, terms, fc.k)
    h = _harmonics_vector(fc, idx)
    b = h @ L.T
    # Residual: the outputs minus the harmonics the model excites.
    k_of = {key: int(key[1]) for key in idx}
    basis = np.zeros((angles.size, len(idx)))
    for key, i in idx.items():
        if key in used and L[:, i].any():
            k = k_of[key]
            basis[:, i] = np.cos(k * angles) if key[0] == "A" else np.sin(k * angles)
    resid = y - h @ basis.T
    s_hat = _noise(resid, dof, sigma)
    var_h = 1.0 / _cos_norm(angles, np.array([float(k_of[key]) for key in idx]))
    cov_unit = (L * var_h) @ L.T  # harmonics are uncorrelated for uniform positions
    return b, s_hat[..., None, None] ** 2 * cov_unit, resid, s_hat


def _noise(resid, dof, sigma):
    if sigma is not None:
        return np.full(resid.shape[:-1], sigma)
    return np.sqrt(np.sum(resid**2, axis=-1) / dof)


def _to_g_units(b, cov_b, terms):
    """K_t = b_t / K1 with first-order covariance propagation."""
    i1 = terms.index("K1")
    k1 = b[..., i1]
    p = len(terms)
    values = b / k1[..., None]
    values[..., i1] = k1
    jac = np.zeros((*b.shape[:-1], p, p))
    diag = np.broadcast_to((1.0 / k1)[..., None], b.shape).copy()
    diag[..., i1] = 1.0
    jac[..., np.arange(p), np.arange(p)] = diag
    col = -b / k1[..., None] ** 2
    col[..., i1] = 1.0
    jac[..., :, i1] = col
    cov = np.einsum("...ij,...jk,...lk->...il", jac, cov_b, jac)
    return values, cov


def _combination_estimate(combo, b, cov_b, terms):
    w = np.zeros(len(terms))
    for t, v in combo.weights:
        w[terms.index(t)] = v
    return CombinationEstimate(
        combination=combo,
        value=b @ w,
        std=np.sqrt(np.einsum("i,...ij,j->...", w, cov_b, w)),
    )


def _notes(report, terms, axis, *, k1_ok, use_fourier, n_rep):
    notes = []
    left_out = [t for t in (*FULL_TERMS[axis], *ASYMMETRY_TERMS) if t not in terms]
    if left_out:
        notes.append(f"terms not estimated, taken as zero: {', '.join(left_out)}")
    cross = "Kpp" if axis == "OA" else "Koo"
    if cross in left_out and {"K0", "K2"} <= set(terms):
        notes.append(
            f"{cross} is not separable from K0 and K2 by a rotation about {axis}: "
            f"K0 stands for K0 + {cross} and K2 for K2 - {cross}"
        )
    for t in terms:
        if t not in report.identifiable:
            notes.append(f"{t} not identifiable ({report.status(t)}): reported as NaN")
    if not k1_ok:
        notes.append("K1 not identifiable: no coefficient in g/g^n can be given (see combinations)")
    if use_fourier:
        notes.append("Fourier route: IEEE 1293 relations as corrected in docs/errata.md")
    if n_rep > 1:
        notes.append(f"{n_rep} repeated readings averaged at each position")
    return tuple(notes)


# --------------------------------------------------------------- validation
def _snap(x):
    return np.where(np.abs(x) < _SNAP, 0.0, x)


def _check_axis(axis) -> str:
    if axis not in AXES:
        raise AccelcalError(f"rotation axis {axis!r} is not one of {', '.join(AXES)}")
    return axis


def _check_terms(terms, axis, default) -> tuple[str, ...]:
    if terms is None:
        return tuple(default)
    if isinstance(terms, str) or not isinstance(terms, Sequence):
        raise AccelcalError(f"terms must be a sequence of term names, got {terms!r}")
    allowed = (*FULL_TERMS[axis], *ASYMMETRY_TERMS)
    terms = tuple(terms)
    for t in terms:
        if t not in allowed:
            why = (
                "is not a model term"
                if t not in TERMS
                else f"does not apply to a rotation about {axis}"
            )
            raise AccelcalError(f"term {t!r} {why}; valid terms here are: {', '.join(allowed)}")
    if len(set(terms)) != len(terms):
        raise AccelcalError(f"terms {list(terms)} repeat a name; give each term once")
    if "K1" not in terms:
        raise AccelcalError("terms must include K1 (the scale factor)")
    return terms


def _check_angles(angles_rad) -> np.ndarray:
    angles = np.asarray(angles_rad, dtype=float)
    if angles.ndim != 1 or angles.size == 0:
        raise AccelcalError(
            f"angles must be a 1-D array of positions in rad; got shape {angles.shape}"
        )
    if not np.isfinite(angles).all():
        raise AccelcalError("angles contain NaN or infinite values; give finite angles in rad")
    wrapped = np.mod(angles, 2 * np.pi)
    order = np.argsort(wrapped)
    gaps = np.diff(np.append(wrapped[order], wrapped[order[0]] + 2 * np.pi))
    close = np.flatnonzero(gaps < _ANGLE_TOL)
    if angles.size > 1 and close.size:
        i, j = order[close[0]], order[(close[0] + 1) % angles.size]
        raise AccelcalError(
            f"positions {i} and {j} are the same angle modulo 360 deg "
            f"({np.degrees(wrapped[i]):.9g} deg); give distinct positions "
            "(average repeated readings, or pass them with repeats=True)"
        )
    return angles


def _check_outputs(outputs, n) -> np.ndarray:
    y = np.asarray(outputs, dtype=float)
    if y.ndim == 0 or y.shape[-1] != n:
        raise AccelcalError(f"outputs must have shape (..., {n}) for {n} positions; got {y.shape}")
    bad = ~np.isfinite(y)
    if bad.any():
        first = np.argwhere(bad)[0]
        raise AccelcalError(
            f"outputs contain {int(bad.sum())} NaN or infinite value(s), the first at index "
            f"{tuple(int(i) for i in first)}; remove or repeat those readings"
        )
    return y


def _is_uniform(angles) -> bool:
    n = angles.size
    if n < 2:
        return False
    wrapped = np.sort(np.mod(angles, 2 * np.pi))
    gaps = np.diff(np.append(wrapped, wrapped[0] + 2 * np.pi))
    return bool(np.all(np.abs(gaps - 2 * np.pi / n) < _ANGLE_TOL))
