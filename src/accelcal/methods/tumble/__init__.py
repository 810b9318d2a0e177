"""Multipoint tumble test (IEEE 1293 style): identifiability and reduction.

The accelerometer is turned about one of its own axes (OA or PA) through N
positions in the gravity field. The package:

- :mod:`~accelcal.physics.tumble` (below the package, shared with the
  rigs): specific force at the positions and the design of the output-unit
  coefficients ``b_t = K1 K_t``, re-exported here;
- :mod:`~accelcal.methods.tumble.identify`: what a position set separates
  (:func:`identifiability`, on :mod:`accelcal.identifiability`);
- :mod:`~accelcal.methods.tumble.fourier`: the harmonics A_k, B_k of a
  uniform tumble and the IEEE relations;
- :mod:`~accelcal.methods.tumble.reduce`: :func:`reduce_tumble` (one record
  -> :class:`~accelcal.results.Reduction`) and :func:`tumble_arrays` (many
  trials -> arrays);
- :mod:`~accelcal.methods.tumble.figures`: the reduction's figures.

The rig simulator is :mod:`accelcal.rigs.tumble`, the record file format
:mod:`accelcal.io.formats.tumble`.

The verbs every method package has: :func:`simulate` (the rig),
:func:`reduce` (a record, or its file, to a Reduction: what ``accelcal
tumble reduce`` does) and :func:`plan` (what a set of positions separates,
``accelcal tumble identify``). ``reduce_tumble`` (angles and outputs) and
``identifiability`` stay as they were.

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

from accelcal.methods import ReportText
from accelcal.methods.tumble.figures import figures
from accelcal.methods.tumble.fourier import FourierCoefficients, fourier_coefficients
from accelcal.methods.tumble.identify import (
    IdentifiabilityReport,
    combination_label,
    identifiability,
)
from accelcal.methods.tumble.reduce import ROUTES, TumbleArrays, reduce_tumble, tumble_arrays
from accelcal.physics.tumble import (
    ASYMMETRY_TERMS,
    AXES,
    DEFAULT_TERMS,
    FULL_TERMS,
    design_matrix,
    specific_force,
)

__all__ = [
    "ASYMMETRY_TERMS",
    "AXES",
    "DEFAULT_TERMS",
    "ERRATA",
    "FULL_TERMS",
    "ROUTES",
    "FourierCoefficients",
    "IdentifiabilityReport",
    "TumbleArrays",
    "combination_label",
    "design_matrix",
    "figures",
    "fourier_coefficients",
    "identifiability",
    "plan",
    "reduce",
    "reduce_tumble",
    "report_text",
    "simulate",
    "specific_force",
    "tumble_arrays",
]

ERRATA = (
    ("Eight uniform positions already separate K4 (the 4th harmonic is then the Nyquist one, "
     "amplitude sum E cos 4θ / sum cos² 4θ); the '12 points add K4' rule is corrected."),
    ("The cross-axis nonlinearity (Kpp about OA, Koo about PA) is never separable by a "
     "rotation about one axis: K0 and K2 stand for K0 + Kpp and K2 − Kpp."),
    ("IEEE's misalignment δ_o is taken as accelcal's +Kp (B1 = K1 Kp); the relations for a "
     "rotation about PA are derived and checked, not quoted."),
)
"""Short corrections of the IEEE 1293 multipoint relations (docs/errata.md, IEEE 1293)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of a tumble reduction."""
    axis = reduction.assumed("rotation_axis", "")
    n = reduction.provenance.get("positions", len(reduction.observations.get("angles", ())))
    route = ("the IEEE 1293 Fourier relations" if reduction.assumed("route") == "fourier"
             else "least squares on the design at the positions")
    return ReportText(
        title="Multipoint tumble (IEEE 1293)",
        summary=(f"Multipoint tumble in the gravity field: {n} positions about {axis}, reduced "
                 f"by {route}. Coefficients in g/g^n are the output-unit coefficients divided "
                 "by K1 (first-order covariance)."),
        sensor_summary="Model E = K1 (K0 + a_i + K2 a_i² + K3 a_i³ + K4 a_i⁴ + cross terms).",
        paper="IEEE1293",
    )


def simulate(positions_rad, model, *, seed=None, **settings):
    """Readings of ``model`` at the positions: the rig's :func:`accelcal.rigs.tumble.simulate`.

    ``settings``: ``rotation_axis``, ``noise``, ``repeats``, ``position_sd``;
    ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.tumble import simulate as rig_simulate

    return rig_simulate(positions_rad, model, seed=seed, **settings)


def reduce(records, *, terms=None, route: str = "auto", sigma=None, **options):
    """Reduce a tumble record (or its file), as ``accelcal tumble reduce`` does.

    The record's positions, outputs (every repeat), rotation axis and output
    unit go to :func:`reduce_tumble`.

    Parameters
    ----------
    records : accelcal.io.formats.tumble.TumbleRecord or path-like
        The record, or a tumble record file.
    terms : sequence of str, optional
        Terms to fit (default: :data:`DEFAULT_TERMS` of the axis).
    route : {"auto", "fourier", "lsq"}
        The IEEE 1293 Fourier relations or least squares [IEEE1293]_.
    sigma : float, optional
        Known noise SD of one reading, output unit.
    **options
        ``asymmetry`` and ``priors`` of :func:`reduce_tumble` (the terms
        taken as zero: estimated where the positions separate them, or
        bounded as Type B).

    Returns
    -------
    accelcal.results.Reduction
        Method ``tumble/fourier`` or ``tumble/lsq``.
    """
    from os import PathLike

    record = records
    if isinstance(records, str | PathLike):
        from accelcal.io.formats import tumble as tumble_format

        record = tumble_format.read(records)
    repeats = record.repeats
    return reduce_tumble(record.angles_rad,
                         record.outputs if repeats > 1 else record.outputs[:, 0],
                         rotation_axis=record.rotation_axis, output_unit=record.output_unit,
                         terms=terms, route=route, sigma=sigma, repeats=repeats > 1, **options)


def plan(design, rotation_axis: str = "OA", *, terms=None) -> IdentifiabilityReport:
    """What a set of positions (rad) separates before the test: :func:`identifiability`."""
    return identifiability(design, rotation_axis, terms=terms)
