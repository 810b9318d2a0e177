"""What a set of tumble positions can separate.

Rank, condition numbers, the null space and the estimable combinations come
from the shared :mod:`accelcal.identifiability` (one tolerance,
:data:`~accelcal.identifiability.RANK_RTOL` on the column-equilibrated
design). This module adds what is particular to the tumble: the groups of
terms aliased with each other, the combinations within each group written
with the preferred term first (``K1*(1 + K3)``), and a largest identifiable
term set to suggest.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [DOMAIN] accelcal domain notes, section 5.
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., Johns
   Hopkins, 2013, sec. 5.5 (rank-deficient least squares).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import (
    NULL_ATOL,
    Combination,
    Identifiability,
    analyse,
    estimable_combinations,
)
from accelcal.physics.tumble import (
    ASYMMETRY_TERMS,
    FULL_TERMS,
    check_angles,
    check_axis,
    check_terms,
    design_matrix,
    is_uniform,
)
from accelcal.resources import check_memory

MEMORY_FACTOR = 8
"""Arrays of (positions x terms) float64 an analysis holds at its peak: the design,
its column-equilibrated copy and QR factors, the trial designs of the suggested
set (about 5 measured); 8 leaves a margin."""

PRIORITY = ("K1", "K0", "Ko", "Kp", "K2", "Kio", "Kip", "K3", "K4", "Koo", "Kpp", *ASYMMETRY_TERMS)
"""Order in which terms are preferred when a choice among aliases is made."""


@dataclass(frozen=True)
class IdentifiabilityReport:
    """What a set of tumble positions can separate.

    Attributes
    ----------
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about.
    angles_rad : tuple of float
        The positions, rad.
    analysis : accelcal.identifiability.Identifiability
        Rank, singular values, identifiable and unobservable terms and the
        null space of the design (columns: the output-unit coefficients
        ``b_t = K1 K_t``, named by their term).
    aliased : tuple of tuple of str
        Groups of terms determined only in combination with each other.
    combinations : tuple of accelcal.identifiability.Combination
        Independent identifiable combinations ``sum w_t b_t`` within each
        aliased group, the preferred term (:data:`PRIORITY`) first with weight
        1 (values NaN; :func:`combination_label` writes them as ``K1*(...)``).
    suggested_terms : tuple of str
        A largest identifiable subset, choosing among aliases in the order
        K1, K0, cross-axis, K2, cross-coupling, K3, K4, cross nonlinearity,
        asymmetry. Using it takes the other terms as zero.
    uniform : bool
        Whether the positions are N equally spaced angles.
    """

    rotation_axis: str
    angles_rad: tuple[float, ...]
    analysis: Identifiability
    aliased: tuple[tuple[str, ...], ...]
    combinations: tuple[Combination, ...]
    suggested_terms: tuple[str, ...]
    uniform: bool

    @property
    def terms(self) -> tuple[str, ...]:
        """The model terms analysed (accelcal names)."""
        return self.analysis.names

    @property
    def rank(self) -> int:
        """Rank of the design (number of independent combinations determined)."""
        return self.analysis.rank

    @property
    def condition_number(self) -> float:
        """Condition number of the column-equilibrated design (``inf`` when rank deficient)."""
        return self.analysis.condition_number

    @property
    def condition_number_identifiable(self) -> float:
        """The same over the non-zero singular values: the conditioning of what is identified."""
        return self.analysis.condition_number_identifiable

    @property
    def singular_values(self) -> tuple[float, ...]:
        """Singular values of the column-equilibrated design, largest first."""
        return self.analysis.singular_values

    @property
    def identifiable(self) -> tuple[str, ...]:
        """Terms determined individually.

        That is their output-unit value ``K1 K_t``; their value in g/g^n
        also needs K1 to be identifiable.
        """
        return self.analysis.identifiable

    @property
    def unobservable(self) -> tuple[str, ...]:
        """Terms with no effect at any of the positions."""
        return self.analysis.unobservable

    @property
    def n_positions(self) -> int:
        """Number of positions."""
        return len(self.angles_rad)

    @property
    def full_rank(self) -> bool:
        """True when every term is identifiable."""
        return self.analysis.full_rank

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

    def labels(self) -> tuple[str, ...]:
        """The combinations written as ``K1*(...)`` (:func:`combination_label`)."""
        return tuple(combination_label(c) for c in self.combinations)

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
            combos = [combination_label(c) for c in self.combinations
                      if {w[0] for w in c.weights} <= set(group)]
            lines.append(f"aliased: {', '.join(group)}; determined only as {'; '.join(combos)}")
        return "\n".join(lines)


def identifiability(angles_rad, rotation_axis: str = "OA", *, terms=None) -> IdentifiabilityReport:
    """Which coefficients a set of tumble positions can separate.

    Builds the design of the model's terms at the positions (see
    :func:`~accelcal.methods.tumble.design_matrix`) and analyses it with
    :func:`accelcal.identifiability.analyse`: rank, condition number, the
    terms determined individually, those with no effect, and the groups of
    aliased terms with the combinations of them that are determined.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        Positions theta_j, rad (distinct modulo 2 pi).
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about.
    terms : sequence of str, optional
        Terms to analyse. Default :data:`~accelcal.methods.tumble.FULL_TERMS`
        of the axis (asymmetry terms may be added).

    Returns
    -------
    IdentifiabilityReport

    Raises
    ------
    AccelcalError
        For an unknown axis, a term that does not apply to it, no K1,
        repeated terms, non-finite or duplicated angles, more positions than
        fit in memory, or positions that cannot separate the scale factor K1
        from the bias K0 (one position, or positions with the same input-axis
        component): the least a tumble must determine.

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
    >>> r.labels()
    ('K1*(K0 + Kpp)', 'K1*(K2 + K4 - Kpp)', 'K1*(1 + K3)')
    """
    axis = check_axis(rotation_axis)
    terms = check_terms(terms, axis, FULL_TERMS[axis])
    check_memory(np.size(angles_rad), len(terms), MEMORY_FACTOR,
                 f"the design of {np.size(angles_rad)} positions")
    angles = check_angles(angles_rad)
    report = report_of(design_matrix(angles, axis, terms), angles, axis, terms)
    needed = [t for t in ("K0", "K1") if t in terms]
    if not set(needed) <= set(report.suggested_terms):
        raise AccelcalError(
            f"{angles.size} position(s) about {axis} cannot separate "
            f"{' from '.join(needed[::-1])} (rank {report.rank} of {len(terms)}): a tumble "
            "needs at least two positions with different input-axis components, e.g. 4 "
            "equally spaced ones")
    return report


def report_of(design, angles, axis, terms) -> IdentifiabilityReport:
    """The :class:`IdentifiabilityReport` of a tumble design (checked inputs)."""
    analysis = analyse(design, terms)
    groups = _alias_groups(analysis)
    combinations = tuple(c for g in groups for c in _group_combinations(analysis, g))
    return IdentifiabilityReport(
        rotation_axis=axis,
        angles_rad=tuple(float(a) for a in angles),
        analysis=analysis,
        aliased=groups,
        combinations=combinations,
        suggested_terms=_suggest(design, terms),
        uniform=is_uniform(angles),
    )


def _alias_groups(analysis: Identifiability) -> tuple[tuple[str, ...], ...]:
    """Connected components of the null-space projector among aliased terms.

    The projector ``Q Q'`` (Q an orthonormal basis of the null space in
    coefficient coordinates) does not depend on the basis; two terms are
    linked when its entry exceeds :data:`~accelcal.identifiability.NULL_ATOL`.
    """
    terms = analysis.names
    null = analysis.null_space
    if null.shape[1] == 0:
        return ()
    q, _ = np.linalg.qr(null)
    link = np.abs(q @ q.T) > NULL_ATOL
    idx = [i for i, t in enumerate(terms)
           if t not in analysis.identifiable and t not in analysis.unobservable]
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


def _group_combinations(analysis: Identifiability, group) -> list[Combination]:
    """Estimable combinations supported on ``group``, preferred term first.

    A combination w on the group's coordinates is estimable iff it is
    orthogonal to the null space there (``N_g' w = 0``, Searle 1971 sec. 5.4);
    :func:`accelcal.identifiability.estimable_combinations` gives them in
    reduced row-echelon form over the group in :data:`PRIORITY` order.
    """
    order = sorted(group, key=PRIORITY.index)
    rows = [analysis.names.index(t) for t in order]
    null = analysis.null_space[rows]
    return [Combination(weights)
            for weights in estimable_combinations(null, order, np.ones(len(order), bool))]


def output_unit_name(term: str) -> str:
    """Name of the output-unit coefficient of ``term``: ``K1`` for K1, ``K1*Kt`` otherwise."""
    return term if term == "K1" else f"K1*{term}"


def combination_label(combination) -> str:
    """A combination ``sum w_t b_t`` written as ``K1*(...)`` (``b_K1 = K1``, ``b_t = K1 K_t``).

    The weights may name the terms (``K3``, as :class:`IdentifiabilityReport`
    does) or the output-unit coefficients (``K1*K3``, as the combinations of
    :func:`~accelcal.methods.tumble.reduce_tumble` do, see
    :func:`output_unit_name`).

    Examples
    --------
    >>> combination_label(Combination((("K1", 1.0), ("K3", 1.0))))
    'K1*(1 + K3)'
    >>> combination_label(Combination((("K0", 1.0), ("K4", -0.125))))
    'K1*(K0 - 0.125*K4)'
    >>> combination_label(Combination((("K1", 1.0), ("K1*K3", 1.0))))
    'K1*(1 + K3)'
    """
    text = ""
    for name, w in combination.weights:
        term = name.removeprefix("K1*")
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


def _suggest(design, terms) -> tuple[str, ...]:
    """Greedy largest identifiable subset, in :data:`PRIORITY` order."""
    chosen, cols = [], []
    for t in sorted(terms, key=PRIORITY.index):
        trial = [*cols, design[:, terms.index(t)]]
        if analyse(np.column_stack(trial), [*chosen, t]).full_rank:
            chosen.append(t)
            cols.append(design[:, terms.index(t)])
    return tuple(t for t in terms if t in chosen)
