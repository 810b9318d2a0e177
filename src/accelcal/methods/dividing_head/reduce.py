"""One entry point for every indexing-head reduction: :func:`reduce`.

:func:`reduce` is the one place that knows which options each method
takes (:data:`OPTIONS`); :func:`options_from_record` gives the options a record
file supplies (its measured first harmonic and autocollimator readings).
The ``tumble`` method maps the IEEE 1293 multipoint reduction of
:mod:`accelcal.methods.tumble` to Dong2014's coefficients.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [IEEE1293] IEEE Std 1293-2018, multipoint tumble test.
.. [DOMAIN] accelcal domain notes, sections 4-5.
"""

import dataclasses

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import combination_name
from accelcal.io.formats.dividing_head import HeadRecord
from accelcal.io.recordings.repairs import with_repairs
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.four import four
from accelcal.methods.dividing_head.joint import joint
from accelcal.methods.dividing_head.response import response
from accelcal.methods.dividing_head.result import K_O_STAR, head_reduction
from accelcal.methods.dividing_head.single import single
from accelcal.methods.dividing_head.theory import COEFFICIENTS, METHODS, coefficient_units, psi
from accelcal.methods.dividing_head.unestimated import (
    PRIOR_CHOICES,
    check_sensor_terms,
    with_type_b,
)
from accelcal.results import Estimate, Reduction
from accelcal.validation import shown

OPTIONS = {
    "single": (),
    "four": ("first_harmonic", "first_harmonic_sd", "covariance"),
    "joint": ("first_harmonic", "first_harmonic_sd", "mean_error", "autocollimator",
              "autocollimator_sd", "gauss_newton", "max_iterations"),
    "tumble": (),
}
"""The options (keyword arguments) each method takes."""


def check_options(method: str, options: dict) -> dict:
    """The options given (not None) after checking that ``method`` takes them.

    Raises
    ------
    AccelcalError
        For an unknown method, or an option the method does not take.
    """
    if method not in METHODS:
        raise AccelcalError(f"unknown method {shown(method)}; choose one of {', '.join(METHODS)}",
                            parameter="method")
    given = {k: v for k, v in options.items() if v is not None}
    for name in given:
        if name not in OPTIONS[method]:
            users = [m for m in METHODS if name in OPTIONS[m]]
            where = f"method {' or '.join(users)} only" if users else "no method"
            raise AccelcalError(f"applies to {where}, not {method}", parameter=name)
    return given


def reduce(data, method: str = "joint", *, gaps: str = "refuse", max_fill: int = 5,
           **options) -> Reduction:
    """Run ``method`` (``single``, ``four``, ``joint`` or ``tumble``) on ``data``.

    ``data`` is a :class:`HeadData`, or a record (:class:`HeadRecord` or its
    file): a record's own first harmonic and autocollimator readings are
    then used where ``options`` do not give them (:func:`lab_options`), as
    ``accelcal dividing-head reduce`` does. ``options`` are passed to the
    method (:data:`OPTIONS`; an option given as None counts as not given):
    ``first_harmonic``, ``first_harmonic_sd``; for ``four`` also
    ``covariance``; for ``joint`` also ``mean_error``, ``autocollimator``,
    ``autocollimator_sd``, ``gauss_newton``, ``max_iterations``; for every
    method ``priors`` (``"default"``: the terms Dong2014 eq. (5) leaves out
    bounded by the embedded default priors and propagated as Type B,
    :mod:`~accelcal.methods.dividing_head.unestimated`; ``"none"``: only
    their aliases listed) and ``sensor_terms`` (``"independent"``, the
    default: the sensors' terms uncorrelated, GUM 5.2; ``"equal"``: each
    row also bounded with the sensors' terms equal in the worst sign, for
    sensors sharing a design bias). ``tumble``
    uses the IEEE 1293 multipoint Fourier reduction of
    :mod:`accelcal.methods.tumble` on each sensor, with the head axis along
    PA. ``gaps``, ``max_fill``: a record file's incomplete repeats
    (:func:`~accelcal.io.formats.dividing_head.read_head_record`); what a
    record's reader left out is in the provenance (``repairs``) and notes.

    Returns
    -------
    Reduction
        Family ``dividing-head``, method ``dividing-head/<method>``.

    Raises
    ------
    AccelcalError
        For an unknown method or options the method does not take.
    """
    from os import PathLike

    if isinstance(data, str | PathLike):
        from accelcal.io.formats.dividing_head import read_head_record

        data = read_head_record(data, gaps=gaps, max_fill=max_fill)
    found = None
    if isinstance(data, HeadRecord):
        options = lab_options(data, method, **options)
        data, found = HeadData.from_record(data), data.repairs
    return with_repairs(_reduced(data, method, options), found)


def _reduced(data, method: str, options: dict) -> Reduction:
    """:func:`reduce` of :class:`HeadData`."""
    priors = options.pop("priors", None) or "default"
    if priors not in PRIOR_CHOICES:
        raise AccelcalError(f"{shown(priors)} is not one of {', '.join(PRIOR_CHOICES)}",
                            parameter="priors")
    sensor_terms = check_sensor_terms(options.pop("sensor_terms", None) or "independent")
    given = check_options(method, options)
    if method == "tumble":
        red = tumble(data)
        return with_type_b(data, red, tumble, terms=(), priors=priors,
                           linear=response("tumble", data, red, given),
                           sensor_terms=sensor_terms)
    run = {"single": single, "four": four, "joint": joint}[method]
    red = run(data, **given)
    return with_type_b(data, red, lambda d: run(d, **given), priors=priors,
                       linear=response(method, data, red, given), sensor_terms=sensor_terms)


def lab_options(record: HeadRecord, method: str, **given) -> dict:
    """The options of ``method`` for a record: the record's own, then those ``given``.

    A ``first_harmonic`` given replaces the record's measured one and its
    uncertainty (``first_harmonic_sd`` then only when given too); options
    given as None count as not given.

    Raises
    ------
    AccelcalError
        For an unknown method.
    """
    options = options_from_record(record, method)
    if given.get("first_harmonic") is not None:
        options.pop("first_harmonic_sd", None)
    return {**options, **{k: v for k, v in given.items() if v is not None}}


def options_from_record(record: HeadRecord, method: str) -> dict:
    """The options a record file supplies to ``method``.

    Its measured first harmonic (with its standard uncertainty) for the
    methods that take one, and its autocollimator readings for ``joint``.

    Raises
    ------
    AccelcalError
        For an unknown method.
    """
    check_options(method, {})
    takes = OPTIONS[method]
    options = {}
    if "first_harmonic" in takes and record.first_harmonic is not None:
        options["first_harmonic"] = tuple(float(v) for v in record.first_harmonic)
        options["first_harmonic_sd"] = record.first_harmonic_sd
    if "autocollimator" in takes and record.autocollimator is not None:
        options["autocollimator"] = record.autocollimator
        options["autocollimator_sd"] = record.autocollimator_sd
    return options


def tumble(data: HeadData) -> Reduction:
    """Per-sensor IEEE 1293 multipoint reduction, mapped to Dong2014 coefficients.

    Calls :func:`accelcal.methods.tumble.reduce_tumble` with
    ``rotation_axis="PA"`` on each sensor's angles beta_k and converts the
    accelcal terms to K_F = K1 K0, K_I = K1, K_O = K1 Ko, K_IO = K1 Kio,
    K_II = K1 K2 (covariance by the Jacobian of that map). A rotation about
    PA cannot separate Koo from K0 and K2: the rows are ``K_F+K_OO`` and
    ``K_II-K_OO`` (K_OO = K1 Koo, volts per g^2), and the tumble's Type B
    contributions (K0', K1' bounded by their priors) are carried over,
    scaled to volts.

    Returns
    -------
    Reduction
        Method ``dividing-head/tumble``.

    References
    ----------
    .. [1] IEEE1293 multipoint tumble; [DOMAIN] section 5.
    """
    from accelcal.methods import tumble as tumble_module

    units = coefficient_units(data.output_unit)
    sensors = []
    notes: list[str] = []
    type_b, aliases, priors = [], [], {}
    for k, (b, u) in enumerate(zip(data.angles(), data.outputs, strict=True)):
        res = tumble_module.reduce_tumble(b, u, rotation_axis="PA", output_unit=data.output_unit)
        est = res.estimate
        values, cov = _terms_to_dong2014(est)
        resid = est.residuals if est.residuals is not None and \
            np.shape(est.residuals) == u.shape else u - psi(b) @ values
        labels = {c: combination_name(c, {"K_OO": w}) for c, plain, w in _CROSS}
        sensors.append(Estimate(COEFFICIENTS, values, cov, units, "tumble", residuals=resid,
                                dof=est.dof, labels=labels))
        notes.extend(n for n in est.notes if n not in notes)
        rename = {est.label(t): (labels.get(c, c), c) for c, t in _DONG}
        k1 = est["K1"]
        for c in res.type_b:
            if c.row in rename:
                row, plain = rename[c.row]
                scale = 1.0 if plain == "K_I" else k1
                type_b.append(dataclasses.replace(
                    c, row=row, sensitivity=scale * c.sensitivity,
                    contribution=abs(scale) * c.contribution, unit=units[plain], sensor=k))
        aliases += [dataclasses.replace(a, sensor=k) for a in res.aliases]
        priors |= {p.name: p for p in res.priors}
    red = head_reduction(data, "tumble", sensors, dof=sensors[0].dof, assumptions=(K_O_STAR,),
                         notes=tuple(notes))
    return dataclasses.replace(red, type_b=tuple(type_b), aliases=tuple(aliases),
                               priors=tuple(priors.values()))


_DONG = (("K_F", "K0"), ("K_I", "K1"), ("K_O", "Ko"), ("K_IO", "Kio"), ("K_II", "K2"))
"""Dong2014 coefficient and the accelcal term it is K1 times (K_I is K1 itself)."""

_CROSS = (("K_F", "K0", 1.0), ("K_II", "K2", -1.0))
"""Rows a rotation about PA mixes with K_OO = K1 Koo, and the weight."""


def _terms_to_dong2014(est: Estimate):
    """Map an accelcal-term estimate (K0, K1, Ko, Kio, K2) to Dong2014 volts with covariance.

    A term the tumble reduction does not report (or reports as not
    identifiable, NaN) is taken as zero, with NaN covariance.
    """
    src = ("K0", "K1", "Ko", "Kio", "K2")
    have = {n: i for i, n in enumerate(est.names) if n in src and np.isfinite(est.values[i])}

    def get(name):
        return float(est.values[have[name]]) if name in have else 0.0

    k1 = get("K1")
    if k1 == 0.0:
        raise AccelcalError("the tumble reduction returned no scale factor K1")
    values = np.array([k1 * get("K0"), k1, k1 * get("Ko"), k1 * get("Kio"), k1 * get("K2")])
    cols = list(have.values())
    jac = np.zeros((5, len(cols)))
    at = {name: cols.index(i) for name, i in have.items()}
    for row, name in ((0, "K0"), (2, "Ko"), (3, "Kio"), (4, "K2")):
        if name in have:
            jac[row, at[name]] = k1
            jac[row, at["K1"]] += get(name)
    jac[1, at["K1"]] = 1.0
    cov = jac @ np.asarray(est.covariance)[np.ix_(cols, cols)] @ jac.T
    missing = [src.index(s) for s in src if s not in have]
    cov[missing, :] = np.nan
    cov[:, missing] = np.nan
    return values, cov
