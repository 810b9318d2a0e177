"""The indexing head's unestimated terms: their aliases and Type B contributions.

Dong2014's basis ``Psi(beta) = [1, sin, cos, sin cos, sin^2]`` (a_p = 0)
leaves out terms every real sensor has: the cubic and quartic K3, K4 and
the asymmetry ``sgn(a_i)(K0' + K1' a_i)/2``. Over a full turn
``sin^3 = (3 sin - sin 3b)/4`` puts ``3/4 K_I K3`` into K_I, ``sgn(sin)/2``
has the Fourier series ``(2/pi)(sin b + sin 3b/3 + ...)`` and puts
``(2/pi) K_I K0'`` into K_I, and ``|sin|/2 = 1/pi - (2/3pi) cos 2b - ...``
moves K_F and K_II by K1'. (Koo is not among them: no rotation about PA
separates it, and the rows K_F+K_OO, K_II-K_OO are named for it.)

The alias matrix ``A`` (row unit per term unit, :mod:`accelcal.aliasing`)
is the reduction applied to each term's columns: sensor k's output change
``K_I,k f_z(beta_k)`` per unit term (``f_z`` of
:func:`accelcal.physics.tumble.design_matrix`, about PA) taken through the
reduction's linear response (:mod:`~accelcal.methods.dividing_head.response`:
one batched product or solve for all columns), and, where the reduction is
not linear in the normalised outputs (``joint`` with autocollimator
readings or Gauss-Newton iterations), by central differences of two more
reductions per column. This is the first-order alias; the shared head
error lets a term of one sensor move the others' rows. Each term of each
sensor is bounded by its prior and propagated as a Type B covariance
``A u^2 A'``, itemised in ``Reduction.type_b``; terms without a prior are
listed in ``Reduction.aliases`` with the rows they would move per unit.

How the sensors' terms are correlated (``sensor_terms``): by default
(``"independent"``) every sensor's terms are uncorrelated with the
others', the GUM's default for the unknown errors of separate instruments
([GUM] 5.2; the Monte Carlo of :mod:`~accelcal.methods.dividing_head.mc`
draws them so): the covariance is ``sum_z A_z u_z^2 A_z'`` over every
sensor's terms. A lab whose sensors share a design bias (one production
lot, the same K0' in every unit) chooses ``"equal"``: each row then gets
the larger of that variance and the one of the sensors' terms equal, in
the worst sign, where the contributions of one kind add linearly,
``(sum_m |a_m| u)^2`` ([GUM] 5.2.2, ``|r| <= 1``; input name
:data:`EQUAL`). On a head whose reduction separates a shared head error
(``four``, ``joint``) K_I moves with every sensor's K0', so the choice
matters there most.

The positions where a_i = 0. The sensor's input-axis component is
``a_i = sin(beta + d_j + eta_k)`` (head error d_j at position j, the
sensor's misalignment eta_k about the head axis). At the two nominal zeros
of a sensor, beta = 0 at position j and beta = pi at position j' half a
turn on, to first order ::

    a_i(j) = +(eta_k + d_j),    a_i(j') = -(eta_k + d_j'),

so ``sgn(a_i) K0'/2`` is ``s_j K0'/2`` and ``s_j' K0'/2`` with
``s_j = sgn(eta_k + d_j)`` and ``s_j' = -sgn(eta_k + d_j')``. When
``|eta_k|`` exceeds both ``|d_j|`` and ``|d_j'|`` the signs are opposite,
``s_j' = -s_j``: one unknown sign with opposite effect, which moves the
rows odd in beta (K_O, by ``K_I K0' / (n/2)`` in the worst case for n
positions per turn) and cancels in the rows even in beta (K_F, K_II);
when the head error exceeds the misalignment at either position the two
signs are unrelated and may be equal, which moves K_F and K_II and
cancels in K_O. No reduction here can tell the two apart: eta_k is
inseparable from K_O (only ``K_O* = K_O + K_I eta`` is identifiable) and
``single`` and ``tumble`` do not separate the head error. The two signs
are therefore taken as independent, each of either sign equally likely
(``s_j s_j'`` of mean zero): the pair's covariance is the mean of the
opposite-sign and equal-sign cases, so whichever holds, each row's share
from the pair is stated as half of what that row would get in the case
worse for it. With the misalignment dominating, as for most sensors on a
head, K_F and K_II are stated that share while their true one is zero,
and K_O half of its true one: on the tumble route (24 positions, the
contract's truths, signs always opposite) K_F and K_II then have SD ratio
0.92 (0.87 and 0.88 in the worst sign) and K_O 1.00 (docs/coverage.md).
``sensor_terms="equal"`` adds the two in the worst sign as well (every
row gets the worse case).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [Guan2021] Guan et al., the asymmetry terms, eq. (3).
.. [GUM] JCGM 100:2008, secs. 4.3.7, 5.1.2, 5.2.
.. [Montgomery] Montgomery D. C., Design and Analysis of Experiments, 8th
   ed., Wiley, 2013, sec. 10.3 (alias matrix).
"""

import dataclasses

import numpy as np

from accelcal.aliasing import Contribution, aliases, default_priors, propagate
from accelcal.errors import AccelcalError
from accelcal.model import term_unit
from accelcal.physics.tumble import design_matrix
from accelcal.validation import shown

TERMS = ("K3", "K4", "K0_asym", "K1_asym")
"""Terms of the error model a rotation about PA excites that Dong2014 eq. (5) leaves out
(and the positions could separate from the estimated ones)."""

ZERO_A_I = 1e-4
"""|sin beta| (rad) below which a position's a_i is zero to within the misalignment and
head error (20 arcsec): the sign of a_i there, and so that of K0'/2, is unknown."""

EQUAL = "sensors' terms equal"
"""Input name of the Type B part a row gets beyond that of independent sensors' terms when
the sensors' terms are taken as equal, in the worst sign (:func:`_sensors_equal`)."""

STEP = 1e-4
"""Perturbation of a term (g/g^n) for the alias matrix by central differences, where the
reduction has no linear response (:func:`~accelcal.methods.dividing_head.response.response`
is None): second order (~1e-8 relative) for the reductions normalised by the fitted K_I,
and rounding amplified by 1e-16 / STEP only."""


PRIOR_CHOICES = ("default", "none")
"""``priors`` of :func:`with_type_b`: the embedded default accelerometer's, or none (the
aliases only)."""

SENSOR_TERMS = ("independent", "equal")
"""``sensor_terms`` of :func:`with_type_b`: how the sensors' unestimated terms (and the
signs of K0'/2 where a_i = 0) are correlated; the first is the default (module docstring)."""


def with_type_b(data, red, method, terms=TERMS, priors="default", *, linear=None,
                sensor_terms="independent"):
    """``red`` with the unestimated terms' Type B covariance, contributions and aliases.

    Parameters
    ----------
    data : HeadData
        The data ``red`` was reduced from.
    red : Reduction
        A ``single``, ``four`` or ``joint`` reduction of ``data``.
    method : callable
        ``data -> Reduction``: the same reduction with the same options.
    terms : tuple of str
        The terms of :data:`TERMS` the reduction leaves out (the ``tumble``
        route estimates K3 and K4 and bounds K0', K1' itself: none); the
        positions where a_i = 0 are always added.
    priors : {"default", "none"}
        ``"none"``: nothing propagated; every term's aliases listed.
    linear : callable, optional
        The reduction's linear response, ``columns -> A``
        (:func:`~accelcal.methods.dividing_head.response.response`); without
        it the alias matrix is taken by central differences of ``method``.
    sensor_terms : {"independent", "equal"}
        ``"independent"``: the sensors' terms uncorrelated, and the signs
        of K0'/2 at the positions where a_i = 0 independent ([GUM] 5.2);
        ``"equal"``: each row gets the larger of that and the sensors'
        terms equal, in the worst sign (a lab whose sensors share a design
        bias). The note says which.

    Returns
    -------
    Reduction
        Each sensor's covariance plus ``sum_z A_z u_z^2 A_z'`` (and the
        coefficient block of ``red.covariance``), ``type_b``, ``aliases``
        of the terms without a prior and ``priors``.
    """
    if priors not in PRIOR_CHOICES:
        raise AccelcalError(f"priors {shown(priors)} is not one of {', '.join(PRIOR_CHOICES)}",
                            parameter="priors")
    check_sensor_terms(sensor_terms)
    use = priors == "default"
    priors = default_priors(terms, data.output_unit) if use else {}
    n_sens = len(red.sensors)
    p = len(red.sensors[0].names)
    listed = list(term_columns(data, red, priors, terms, use))
    names = [(k, term) for k, (term, _) in listed]
    changes = [(k, z) for k, (_, z) in listed]
    if not changes:
        a = np.zeros((n_sens * p, 0))
    elif linear is not None:
        a = linear(changes)  # (n_sens p, number of terms)
    else:
        a = central_differences(data, method, changes)
    cov_all = np.zeros((n_sens * p, n_sens * p))
    for i, (_, term) in enumerate(names):
        if term in priors:
            cov_all += np.outer(a[:, i], a[:, i]) * priors[term].standard**2
    excess = np.zeros(n_sens * p)
    if sensor_terms == "equal":
        excess = np.maximum(_sensors_equal(a, names, priors) - np.diagonal(cov_all), 0.0)
        cov_all += np.diag(excess)
    type_b, entries = [], []
    for k, est in enumerate(red.sensors):
        rows = tuple(est.label(n) for n in est.names)
        units = {est.label(n): est.units[n] for n in est.names}
        block = slice(k * p, (k + 1) * p)
        for m in range(n_sens):
            cols = [i for i, (s, _) in enumerate(names) if s == m]
            sub = a[block][:, cols]
            terms = tuple(names[i][1] for i in cols)
            # another sensor's term moves this sensor's rows: name it so
            named = terms if m == k else tuple(f"{t}[{data.sensors[m] if data.sensors else m}]"
                                                for t in terms)
            used = {s: priors[t] for s, t in zip(named, terms, strict=True) if t in priors}
            _, parts = propagate(sub, rows, named, used, row_units=units, sensor=k)
            type_b += parts
            free = [i for i, t in enumerate(terms) if t not in priors]
            entries += aliases(sub[:, free], rows, tuple(named[i] for i in free),
                               row_units=units,
                               term_units={named[i]: term_unit(terms[i].split("@")[0],
                                                                  data.output_unit)
                                           for i in free}, sensor=k)
        type_b += [Contribution(row, EQUAL, 1.0, float(np.sqrt(x)), float(np.sqrt(x)),
                                unit=units[row], source="default", sensor=k)
                   for row, x in zip(rows, excess[block], strict=True) if x > 0.0]
    sensors = tuple(dataclasses.replace(e, covariance=e.covariance + cov_all[k * p:(k + 1) * p,
                                                                               k * p:(k + 1) * p])
                    for k, e in enumerate(red.sensors))
    covariance = red.covariance
    if covariance is not None and np.ndim(covariance) == 2 and covariance.shape[0] >= n_sens * p:
        covariance = np.array(covariance, dtype=float)
        covariance[:n_sens * p, :n_sens * p] += cov_all
    bounds = [f"{pr.name} +-{pr.value:.3g} {pr.unit}" for pr in priors.values()
              if "@" not in pr.name]
    how = ({"independent": "each sensor's terms independent of the others' (GUM 5.2) and "
                           "the signs at the positions where a_i = 0 independent",
            "equal": "the larger of the sensors' terms independent and equal in the worst "
                     "sign, the signs where a_i = 0 worst too"}[sensor_terms])
    note = ("terms the reduction leaves out bounded by the embedded default priors, "
            f"propagated as Type B to the rows they move (sensor terms {sensor_terms}: {how}): "
            + ", ".join([*bounds, "K0'/2 of unknown sign at each position where a_i = 0"]))
    free = sorted({e.term.split("@")[0].split("[")[0] for e in entries})
    if not use:
        note = "priors none: no Type B propagated"
    if free:
        note += (f"; {', '.join(free)} (of every sensor and, for K0_asym, at each position "
                 "where a_i = 0) taken as zero, no prior: see the aliases")
    return dataclasses.replace(red, sensors=sensors, covariance=covariance,
                               type_b=(*red.type_b, *type_b), aliases=(*red.aliases, *entries),
                               priors=(*red.priors, *priors.values()),
                               notes=(*red.notes, note))


def check_sensor_terms(sensor_terms) -> str:
    """``sensor_terms`` when it is one of :data:`SENSOR_TERMS`.

    Raises
    ------
    AccelcalError
        Otherwise (parameter ``sensor_terms``).
    """
    if sensor_terms not in SENSOR_TERMS:
        raise AccelcalError(f"sensor terms {shown(sensor_terms)} is not one of "
                            f"{', '.join(SENSOR_TERMS)}", parameter="sensor_terms")
    return sensor_terms


def central_differences(data, method, changes) -> np.ndarray:
    """Alias matrix ``(K p, q)`` of ``method`` by central differences of :data:`STEP`.

    ``changes`` are ``(sensor, output change per unit term)``; two reductions per column.
    """
    columns = []
    for k, z in changes:
        ends = []
        for step in (STEP, -STEP):
            outputs = np.array(data.outputs, dtype=float)
            outputs[k] += step * z
            moved = method(dataclasses.replace(data, outputs=outputs))
            ends.append(np.concatenate([e.values for e in moved.sensors]))
        columns.append((ends[0] - ends[1]) / (2 * STEP))
    return np.column_stack(columns)


def _sensors_equal(a, names, priors) -> np.ndarray:
    """Each row's Type B variance with the sensors' terms equal, in the worst sign.

    The terms of one kind (K3, K0', ...; every ``K0_asym@`` of unknown sign
    counts as K0') move a row through every sensor; with the sensors'
    terms correlated in an unknown way (GUM 5.2.2: ``|r| <= 1``) the
    contributions of one kind add at most linearly:
    ``(sum_m |a_m| u)^2``.
    """
    worst = np.zeros(a.shape[0])
    for kind in TERMS:
        cols = [i for i, (_, t) in enumerate(names) if t.split("@")[0] == kind and t in priors]
        if cols:
            u = np.array([priors[names[i][1]].standard for i in cols])
            worst += (np.abs(a[:, cols]) @ u) ** 2
    return worst


def term_columns(data, red, priors, terms, bound):
    """``(sensor, (term, output change per unit term))`` of every unestimated term.

    Besides :data:`TERMS`, the positions where sensor k's a_i is zero (within
    :data:`ZERO_A_I`) get a term ``K0_asym@<angle of the first>`` per zero
    of a_i: there ``sgn(a_i) K0'/2`` is +-K0'/2 by a sign no one knows (added to
    ``priors`` when ``bound``, bounded as K0').
    """
    beta = data.angles()
    asym = default_priors(("K0_asym",), data.output_unit).get("K0_asym")
    for k, est in enumerate(red.sensors):
        k_i = float(est["K_I"])
        z = design_matrix(beta[k], "PA", (*terms, "K1"))[:, :-1] * k_i
        for j, term in enumerate(terms):
            yield k, (term, z[:, j])
        near = np.flatnonzero(np.abs(np.sin(beta[k])) < ZERO_A_I)
        crossing = np.rint(beta[k][near] / np.pi)
        for c in np.unique(crossing):
            at = near[crossing == c]  # one zero of a_i: one sign, unknown
            term = f"K0_asym@{np.degrees(data.positions[at[0]]):.6g}deg"
            if bound and asym is not None:
                priors[term] = dataclasses.replace(asym, name=term)
            impulse = np.zeros(beta.shape[1])
            impulse[at] = 0.5 * k_i
            yield k, (term, impulse)
