"""Reduction of a centrifuge record: coefficients with covariance, rig errors given or estimated.

:func:`reduce_centrifuge` reduces one record (its steps' steady readings
averaged, spin-up readings excluded) to a
:class:`~accelcal.results.Reduction`: weighted least squares on the exact
geometry (:mod:`~accelcal.methods.centrifuge.core`), the rig errors given
(the record's survey or ``rig_errors``: value with standard uncertainty,
propagated) or estimated where the records separate them. Terms default to
the largest identifiable subset (:mod:`~accelcal.methods.centrifuge.identify`).

Assumptions set (names for code): ``noise`` (``"given"`` or ``"residuals"``),
``noise_sd`` (output unit, one reading), ``rig_given`` (name, value, SD
triples), ``terms_taken_zero``, ``revolution_mean``, ``spinup_excluded``,
``aliases``, ``few_dof``. Observations: ``level`` (g), ``position`` (index),
``outputs``, ``fitted`` (output unit, step means) and, for joint
reductions, ``one_g_outputs``, ``one_g_fitted``.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, sections 1 and 9.
.. [GUM] JCGM 100:2008, sec. 5.1.
"""

from collections.abc import Mapping

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.io.formats.centrifuge import MAX_OUTPUT, MIN_SD
from accelcal.methods.centrifuge.core import Block, solve
from accelcal.methods.centrifuge.identify import identifiability
from accelcal.methods.centrifuge.unestimated import analyse_unestimated
from accelcal.model import ErrorModel, term_unit
from accelcal.physics.centrifuge import (
    ASYMMETRY_TERMS,
    FULL_TERMS,
    MISALIGNMENT_AXES,
    RIG_ERRORS,
    check_terms,
    misalignment_name,
    position_matrix,
    rig_unit,
)
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.units import STANDARD_GRAVITY
from accelcal.validation import shown

FAMILY = "centrifuge"
METHOD = "centrifuge/lsq"


def centrifuge_block(record) -> Block:
    """The step means of a record as a :class:`~accelcal.methods.centrifuge.core.Block`.

    Raises
    ------
    AccelcalError
        For bad steps (:meth:`~accelcal.io.formats.centrifuge.CentrifugeRecord.steps`),
        one level only, or every step in positions of the same orientation.
    """
    steps = record.steps()
    mats = np.stack([position_matrix(p) for p in record.positions])
    if np.unique(steps.level).size < 2:
        raise AccelcalError(f"the record has one level only ({steps.level[0]:g} g): the "
                            "nonlinearity needs several levels (e.g. 5 to 50 g)",
                            parameter="levels")
    used = np.unique(steps.position)
    if np.unique(np.round(mats[used].reshape(used.size, -1), 12), axis=0).shape[0] < 2:
        raise AccelcalError("every step has the sensor in the same orientation: odd and even "
                            "terms need IA inward and outward (and OA or PA radial for the "
                            "cross-coupling)", parameter="positions")
    gravity = record.metadata.get("local_gravity") or STANDARD_GRAVITY
    return Block("centrifuge", steps.output, steps.count.astype(float), c=mats[steps.position],
                 position=steps.position, position_names=record.position_names,
                 rate2=steps.rate2, radius=record.radius_m, gravity=float(gravity),
                 level=steps.level)


def rig_parameters(record, rig_errors: Mapping | None, estimate) -> tuple[dict, tuple, dict]:
    """Given values, estimated names and given SDs of the rig errors.

    ``rig_errors`` (name -> ``(value, sd)``) overrides the record's survey;
    ``"misalignment"`` applies to every position's three angles, and
    ``estimate`` may name ``"misalignment"`` for all of them.
    """
    given = {k: (v["value"], v["sd"]) for k, v in record.survey.items()}
    for name, pair in dict(rig_errors or {}).items():
        value, sd = (float(x) for x in pair)
        if not (np.isfinite(value) and abs(value) <= 1.0 and (sd == 0 or MIN_SD <= sd <= 1.0)):
            raise AccelcalError(f"{name}: ({value}, {sd}) must be a value within +-1 and an SD "
                                f"0 or {MIN_SD:g} to 1 (SI units)", parameter="rig_errors")
        given[name] = (value, sd)
    expanded = {}
    for name, pair in given.items():
        if name == "misalignment":
            for p in record.position_names:
                for ax in MISALIGNMENT_AXES:
                    expanded.setdefault(misalignment_name(p, ax), pair)
        elif name in RIG_ERRORS or _is_misalignment(name, record):
            expanded[name] = pair
        else:
            raise AccelcalError(f"{shown(name)} is not a rig error ({', '.join(RIG_ERRORS)}, "
                                "misalignment)", parameter="rig_errors")
    est = []
    for name in estimate or ():
        names = ([misalignment_name(p, a) for p in record.position_names
                  for a in MISALIGNMENT_AXES] if name == "misalignment" else [name])
        for n in names:
            if n not in RIG_ERRORS and not _is_misalignment(n, record):
                raise AccelcalError(f"{shown(n)} is not a rig error", parameter="estimate")
            if n not in est:
                est.append(n)
    rig = {k: v for k, (v, _) in expanded.items()}
    sds = {k: sd for k, (_, sd) in expanded.items() if sd > 0 and k not in est}
    return rig, tuple(est), sds


def _is_misalignment(name: str, record) -> bool:
    parts = name.split(":")
    return (len(parts) == 3 and parts[0] == "misalignment" and parts[1] in record.position_names
            and parts[2] in MISALIGNMENT_AXES)


def reduce_centrifuge(record, *, terms=None, estimate=(), rig_errors=None, sigma=None,
                      priors="default") -> Reduction:
    """Reduce a centrifuge record to the model's coefficients, with covariance.

    Parameters
    ----------
    record : CentrifugeRecord
        From :func:`accelcal.io.formats.centrifuge.read` or the rig.
    terms : sequence of str, optional
        Terms to estimate (K1 included); default the largest identifiable
        subset of :data:`~accelcal.physics.centrifuge.FULL_TERMS`.
        Terms left out are taken as zero (assumption ``terms_taken_zero``).
    estimate : sequence of str
        Rig errors to estimate (``proof_mass_offset``, ``arm_stretch``,
        ``misalignment`` or ``misalignment:<position>:<IA|OA|PA>``); the others
        are given. ``radius_error`` is aliased with K1 on the centrifuge
        alone: use :func:`~accelcal.methods.centrifuge.joint.reduce_joint`.
    rig_errors : mapping, optional
        Given rig errors, name -> ``(value, sd)``, overriding the record's survey.
    sigma : float, optional
        Known noise SD of one reading, output unit (default: from the residuals).
    priors : "default", "none" or None
        Priors of the unestimated terms the records could separate, and of
        the asymmetry's unknown sign at IA-tangential positions
        (:mod:`~accelcal.methods.centrifuge.unestimated`): ``"default"``
        propagates them as Type B; ``"none"``/None lists only how much each
        would move each row (``aliases``).

    Returns
    -------
    Reduction
        Family ``"centrifuge"``, method ``"centrifuge/lsq"``; ``shared`` holds
        the estimated rig errors (None when all are given). A row that
        estimates a combination is named after it (``Ko-Kop``, ``Kio+Kop``
        with the rig errors given; other weights when the proof-mass offset
        is estimated).

    Raises
    ------
    AccelcalError
        Bad steps, one level, one orientation, a design that does not
        separate the terms asked for, no degrees of freedom, bad ``sigma``.

    References
    ----------
    .. [1] IEEE836; DOMAIN sections 1 and 9; GUM 5.1.
    """
    if sigma is not None and not (np.isfinite(sigma) and MIN_SD <= sigma <= MAX_OUTPUT):
        raise AccelcalError(f"{sigma} must be a noise SD from {MIN_SD:g} to {MAX_OUTPUT:g} "
                            "(output unit)", parameter="sigma")
    block = centrifuge_block(record)
    rig, est, sds = rig_parameters(record, rig_errors, estimate)
    return solve_and_reduce([block], record, rig, est, sds, terms=terms, sigma=sigma,
                            method=METHOD, priors=priors)


def solve_and_reduce(blocks, record, rig, est, sds, *, terms, sigma, method,
                     extra_notes=(), priors="default") -> Reduction:
    """Choose the terms, solve, and build the Reduction (shared by both reductions)."""
    if not (priors is None or priors in ("default", "none")):
        raise AccelcalError(f"priors {shown(priors)} is not one of default, none",
                            parameter="priors")
    report = identifiability(blocks, rig, (*FULL_TERMS, *ASYMMETRY_TERMS), est)
    terms = check_terms(terms, report.suggested)
    sol = solve(blocks, terms, rig, est, sds, sigma=sigma)
    return _reduction(sol, blocks, record, report, (rig, sds), method=method,
                      given=sigma is not None, extra_notes=extra_notes, priors=priors)


def to_g_units(z, cov, terms):
    """``K_t = b_t / K1`` (K1 kept) for the leading ``len(terms)`` entries, with covariance."""
    p = len(terms)
    i1 = terms.index("K1")
    k1 = z[i1]
    jac = np.eye(z.size)
    jac[:p, :p] /= k1
    jac[i1, i1] = 1.0
    jac[:p, i1] = -z[:p] / k1**2
    jac[i1, i1] = 1.0
    values = z.copy()
    values[:p] = z[:p] / k1
    values[i1] = k1
    return values, jac @ cov @ jac.T


def _reduction(sol, blocks, record, report, survey, *, method, given, extra_notes,
               priors="default"):
    terms, p = sol.terms, len(sol.terms)
    unit = record.output_unit
    values, cov = to_g_units(sol.z, sol.cov, terms)
    un = analyse_unestimated(sol, blocks, values=values, cov=cov, output_unit=unit,
                             priors=priors)
    cov = cov + un.covariance
    resid = np.concatenate(sol.residuals)
    units = {t: term_unit(t, unit) for t in terms}
    notes = tuple(report.statements()) + tuple(extra_notes) + _unestimated_notes(un)
    est = Estimate(terms, values[:p], cov[:p, :p], units, method, residuals=resid, dof=sol.dof,
                   notes=notes, provenance={"steps": int(blocks[0].y.size)}, labels=un.labels)
    shared = None
    if sol.estimated:
        shared = Estimate(sol.estimated, values[p:], cov[p:, p:],
                          {n: rig_unit(n) for n in sol.estimated}, method, dof=sol.dof)
    obs = {"level": blocks[0].level, "position": blocks[0].position.astype(float),
           "outputs": blocks[0].y, "fitted": sol.fitted[0]}
    if len(blocks) > 1:
        obs |= {"one_g_outputs": blocks[1].y, "one_g_fitted": sol.fitted[1]}
    model = ErrorModel.from_terms(dict(zip(terms, values[:p].tolist(), strict=True)),
                                  output_unit=unit)
    return Reduction(
        family=FAMILY, method=method, sensors=(est,), shared=shared,
        covariance=cov if shared is not None else None, dof=sol.dof,
        identifiability=analyse(sol.design, (*terms, *sol.estimated)),
        assumptions=_assumptions(sol, blocks, record, report, survey, given=given, unit=unit),
        observations=obs, models=(model,), notes=notes, type_b=un.contributions,
        aliases=un.aliases, priors=un.priors,
        provenance={"positions": list(record.position_names), "radius_m": record.radius_m,
                    "output_unit": unit, "terms": list(terms), "estimated": list(sol.estimated),
                    "steps": int(blocks[0].y.size), "simulated": bool(
                        record.metadata.get("simulated", False)),
                    "noise_sd": [float(s) for s in sol.sigma]},
    )


def _unestimated_notes(un) -> tuple[str, ...]:
    """The IA-tangential sign terms' priors, in words."""
    signs = [p for p in un.priors if "@" in p.name]
    if not signs:
        return ()
    where = ", ".join(p.name.split("@")[1] for p in signs)
    return ((f"the asymmetry's sign at {where} (IA perpendicular to the specific force, sign "
             "taken as 0) is unknown when the sensor is misaligned on the arm: s K0' bounded "
             f"by +-{signs[0].value:.3g} g ({signs[0].source}), propagated as Type B"),)


def _assumptions(sol, blocks, record, report, survey, *, given, unit):
    sd_text = ", ".join(f"{blk.name} {s:.3g} {unit}" for blk, s in zip(blocks, sol.sigma,
                                                                         strict=True))
    out = [
        Assumption("noise", "given" if given else "residuals", "",
                   f"noise SD of one reading {'given' if given else 'from the residuals'}: "
                   f"{sd_text}" + ("" if given else f" ({sol.dof} degrees of freedom)")),
        Assumption("noise_sd", float(sol.sigma[0]), unit),
        Assumption("revolution_mean", True, "",
                   "each reading is a whole-revolution mean: spin-axis tilt and once-per-"
                   "revolution rate ripple average out to first order (residue of second "
                   "order, see docs/centrifuge.md)"),
    ]
    values, sds = survey
    rig_given = tuple((k, float(v), float(sds.get(k, 0.0))) for k, v in sorted(values.items())
                      if k not in sol.estimated and (v or k in sds))
    if rig_given or "radius_error" not in sol.estimated:
        shown_given = rig_given or (("radius_error", 0.0, 0.0),)
        out.append(Assumption("rig_given", tuple(x for t in shown_given for x in t), "",
                              "rig errors given (value +- SD, propagated): "
                              + "; ".join(_given_text(shown_given))))
    left = [t for t in (*FULL_TERMS, *ASYMMETRY_TERMS) if t not in sol.terms]
    if left:
        out.append(Assumption("terms_taken_zero", tuple(left), "",
                              f"terms not estimated, taken as zero: {', '.join(left)}"))
    aliased = {k: v for k, v in report.rig_aliases.items() if v}
    if aliased:
        out.append(Assumption("aliases", tuple(f"{k}~{'+'.join(v)}" for k, v in aliased.items()),
                              "", "; ".join(f"{k} cannot be separated from {', '.join(v)} by "
                                            "these records" for k, v in aliased.items())))
    excluded = int(np.sum(record.spinup))
    if excluded:
        out.append(Assumption("spinup_excluded", excluded, "",
                              f"{excluded} spin-up reading(s) excluded"))
    from accelcal.calibration import FEW_DOF

    if not given and sol.dof < FEW_DOF:
        out.append(Assumption("few_dof", int(sol.dof), "",
                              f"noise SD from only {sol.dof} degrees of freedom"))
    return tuple(out)


def _given_text(given) -> list[str]:
    """``name = v +- u unit`` per given rig error; equal misalignments in one item."""
    out, mis = [], {}
    for k, v, sd in given:
        if k.startswith("misalignment:"):
            mis.setdefault((v, sd), []).append(k)
        else:
            out.append(f"{k} = {v:.4g} +- {sd:.3g} {rig_unit(k)}")
    for (v, sd), names in mis.items():
        out.append(f"misalignment ({len(names)} angles) = {v:.4g} +- {sd:.3g} rad")
    return out
