"""Acceptance tests of pendulous accelerometers: threshold, resolution, hysteresis (issue 27).

The tests of a specification that are not calibration coefficients (IEEE
1293, IEEE 337), on the indexing head. The package:

:mod:`~accelcal.methods.acceptance.dwells`
    :func:`dwell_means`: the output at each dwell with its standard error.
:mod:`~accelcal.methods.acceptance.steps`
    :func:`reduce_steps`: threshold (at null) and resolution (at a set
    point) by the 50 % rule, the probability that the decision is wrong
    and the dwell that makes it reliable.
:mod:`~accelcal.methods.acceptance.hysteresis`
    :func:`reduce_hysteresis`: decreasing minus increasing leg at each
    input point of the cycle 0 -> +1 g -> 0 -> -1 g -> 0.
:mod:`~accelcal.methods.acceptance.figures`
    :func:`figures`: the step response with the 50 % line, the hysteresis
    loop.

The rig simulator is :mod:`accelcal.rigs.acceptance`, the record format
:mod:`accelcal.io.formats.acceptance` (kind ``steps``). The verbs:
:func:`simulate` (the rig) and :func:`reduce` (a record, or its file, to a
Reduction: what ``accelcal acceptance reduce`` does); :func:`quantity_rows`
gives that command's rows.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, IEEE Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers.
.. [DOMAIN] accelcal domain notes, section 12.
"""

from accelcal.methods import ReportText
from accelcal.methods.acceptance.dwells import Dwells, dwell_means
from accelcal.methods.acceptance.figures import figures
from accelcal.methods.acceptance.hysteresis import reduce_hysteresis
from accelcal.methods.acceptance.steps import FAMILY, MAX_ERROR, RULE, TARGET, reduce_steps

__all__ = [
    "ERRATA", "FAMILY", "MAX_ERROR", "RULE", "TARGET", "Dwells", "dwell_means", "figures",
    "quantity_rows", "reduce", "reduce_hysteresis", "reduce_steps", "report_text", "simulate",
]

ERRATA = ()
"""No departures from the standards' definitions (docs/acceptance.md)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of an acceptance reduction."""
    prov = reduction.provenance
    test = prov.get("test", "")
    if test == "hysteresis":
        summary = (f"Input cycle 0 → +1 g → 0 → −1 g → 0 on the indexing head; the hysteresis at "
                   f"each of {len(prov.get('points_g', []))} input points is the decreasing-leg "
                   "minus the increasing-leg dwell mean over the scale factor.")
    else:
        summary = (f"Input stepped about {prov.get('set_point_g', 0.0):.3g} g by a ladder of "
                   f"{len(prov.get('sizes_g', []))} increments, each applied and reversed; the "
                   f"{test} is the smallest increment whose output change reaches 50 % of the "
                   "predicted change, with the probability that the decision is wrong.")
    return ReportText(title=f"Acceptance test: {test}", summary=summary,
                      sensor_summary="Dwell means with pooled white-noise standard errors.",
                      paper="IEEE1293")


def simulate(test: str = "threshold", *, seed=None, **settings):
    """A simulated step test: the rig's :func:`accelcal.rigs.acceptance.simulate`."""
    from accelcal.rigs.acceptance import simulate as rig_simulate

    return rig_simulate(test, seed=seed, **settings)


def reduce(records, *, test: str | None = None, settle: float = 0.0,
           max_error: float = MAX_ERROR, target: float = TARGET):
    """Reduce a step record (or its file), as ``accelcal acceptance reduce`` does.

    ``test`` (optional) must be the record's own; ``settle``, ``max_error``
    and ``target`` as :func:`reduce_steps` takes them (the hysteresis uses
    ``settle`` only).
    """
    from os import PathLike

    from accelcal.errors import AccelcalError

    record = records
    if isinstance(records, str | PathLike):
        from accelcal.io.formats import acceptance as steps_format

        record = steps_format.read(records)
    if test is not None and test != record.test:
        raise AccelcalError(f"the record holds a {record.test} test, not {test}",
                            parameter="test")
    if record.test == "hysteresis":
        return reduce_hysteresis(record, settle=settle)
    return reduce_steps(record, settle=settle, max_error=max_error, target=target)


def quantity_rows(reduction) -> list[dict]:
    """Rows ``quantity, estimate, std, unit``: accelerations in ug, responses as fractions.

    A resolution also gets ``resolution / input`` (ppm of the set point's input).
    """
    est, prov = reduction.estimate, reduction.provenance
    rows = []
    for name, value, std in zip(est.names, est.values, est.std, strict=True):
        unit = est.units[name]
        label = name
        if name.startswith("response_"):
            label = f"response to {prov['sizes_g'][int(name[9:]) - 1] * 1e6:.4g} ug"
        elif name.startswith("hysteresis_"):
            label = f"hysteresis at {prov['points_g'][int(name[11:]) - 1]:+.4g} g"
        factor = 1e6 if unit == "g" else 1.0
        rows.append({"quantity": label, "estimate": float(value) * factor,
                     "std": float(std) * factor, "unit": "ug" if unit == "g" else unit})
    a0 = abs(prov.get("set_point_g", 0.0))
    if prov.get("test") == "resolution" and a0 > 0:
        rows.insert(1, {"quantity": "resolution / input", "unit": "ppm",
                        "estimate": reduction.value("resolution") / a0 * 1e6,
                        "std": reduction.std("resolution") / a0 * 1e6})
    return rows
