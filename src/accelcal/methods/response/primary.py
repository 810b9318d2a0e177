"""The response without a reference accelerometer: by laser (ISO 16063-11) and gravity (-16).

Both routes reduce each step as the comparison does
(:func:`~accelcal.methods.response.stepped.step_ratio`: the phasors of the
input and of the DUT by one harmonic fit on whole periods, their complex
ratio with its covariance), with the input known from first principles
instead of from a reference's certificate:

Laser, method 3 (sine approximation)
    The interferometer's quadrature signals ``I`` (the record's ``ref``) and
    ``Q`` (its ``quadrature``) are corrected by Heydemann's ellipse fit
    (:mod:`accelcal.signal.quadrature`), the phase unwrapped and turned into
    displacement ``s = lambda phi / (4 pi)`` (double-pass Michelson); its
    phasor at the step's frequency is fitted with the DUT's, and the
    acceleration's phasor is ``-w^2 s_hat / g_n`` (g), the displacement's
    turned by 180 deg. The DUT's complex sensitivity is then
    ``u_dut / u_a / D`` (``D`` the DAQ's known mismatch).
Gravity
    The DUT turns at a constant rate about a horizontal axis; the table's
    encoder gives the angle ``theta`` (the record's ``ref``), the input is
    ``g_local cos(theta)`` (g), 1 g at the rotation frequency, and the DUT's
    sensitivity there is ``u_dut / u_in``. The harmonic fit's DC term takes
    the bias and the harmonics the second-order coefficient. At the lowest
    rotation frequencies the magnitude is the static scale factor
    (``|S(f)| = S0 (1 + (1 - 2 zeta^2) (f / fn)^2 + ...)``): given one (of
    a tumble, :mod:`accelcal.methods.tumble`), the reduction states their
    relative difference with its uncertainty, the tie of the response to
    the static calibration.

References
----------
.. [ISO16063-11] ISO 16063-11:1999, sec. 8.4 and annex A (method 3).
.. [ISO16063-16] ISO 16063-16:2014, Calibration by Earth's gravitation.
.. [Heydemann1981] Heydemann P. L. M., Appl. Opt. 20(19), 1981, p. 3382-3384.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.response.stepped import _daq, _real, assemble, step_ratio
from accelcal.results import Assumption

LASER = "response/laser"
"""Method id of the primary calibration by laser interferometry."""

GRAVITY = "response/gravity"
"""Method id of the calibration by the Earth's gravitation on a rotating table."""

G_N = 9.80665
"""Standard gravity, m/s^2."""


def _records(records, kind: str) -> list:
    records = [records] if not isinstance(records, list | tuple) else list(records)
    if not records:
        raise AccelcalError("give at least one record", parameter="records")
    for rec in records:
        if rec.excitation != kind:
            raise AccelcalError(f"a {kind} reduction needs {kind} records, not "
                                f"{rec.excitation} ones", parameter="method")
    units = {r.output_unit for r in records}
    if len(units) > 1:
        raise AccelcalError(f"the records' DUT units differ ({', '.join(sorted(units))})",
                            parameter="records")
    return records


def _steps(records, input_of):
    """Per step: ``input_of(rec, slice, f, where)`` gives the input in g and a correction."""
    out = {k: [] for k in ("freqs", "amps", "values", "blocks", "dofs", "periods")}
    for n, rec in enumerate(records):
        f_steps = rec.frequencies
        amp_meta = rec.metadata.get("amplitudes_g") or []
        for k, sl in enumerate(rec.steps):
            f = float(f_steps[k])
            where = f"record {n + 1}, step {k} ({f:g} Hz)" if len(records) > 1 else \
                f"step {k} ({f:g} Hz)"
            u_in, correction = input_of(rec, sl, f, where)
            ratio, cov, dof, p = step_ratio(u_in, rec.dut[sl], rec.sample_rate_hz, f,
                                            t0=float(rec.t[sl][0]), where=where)
            jc = _real(correction)
            out["values"].append(correction * ratio)
            out["blocks"].append(jc @ cov @ jc.T)
            out["freqs"].append(f)
            out["amps"].append(float(amp_meta[k]) if k < len(amp_meta) else float("nan"))
            out["dofs"].append(dof)
            out["periods"].append(p)
    return out


def reduce_laser(records, *, reference_frequency: float | None = None):
    """The DUT's complex sensitivity at each step of laser records (ISO 16063-11, method 3).

    Parameters
    ----------
    records : ResponseRecord or sequence of them
        Records whose ``excitation`` is ``laser`` (its ``wavelength_m``),
        with the ``quadrature`` column.
    reference_frequency : float, optional
        Frequency of the deviations, Hz.

    Returns
    -------
    accelcal.results.Reduction
        As the comparison's (:func:`~accelcal.methods.response.stepped.reduce_stepped`),
        method ``response/laser``; the assumption ``ellipse`` gives the fitted
        ellipse of the first step (p, q, a, b, e).

    Raises
    ------
    AccelcalError
        For a record without quadrature signal or wavelength, signals that
        trace no ellipse, a step too short.

    References
    ----------
    .. [1] ISO 16063-11:1999, annex A; Heydemann (1981).
    """
    from accelcal.signal.quadrature import fit_ellipse, phase

    records = _records(records, "laser")
    ellipses = []

    def displacement_in_g(rec, sl, f, where):
        if rec.quadrature is None:
            raise AccelcalError(f"{where}: a laser record needs its quadrature column",
                                parameter="records")
        wavelength = rec.metadata["excitation"].get("wavelength_m")
        if not (isinstance(wavelength, int | float) and 1e-7 <= wavelength <= 1e-4):
            raise AccelcalError("a laser record's excitation must state its wavelength_m "
                                "(1e-7 to 1e-4 m)", parameter="records")
        ell = fit_ellipse(rec.ref[sl], rec.quadrature[sl], where=where)
        ellipses.append(ell)
        phi = phase(rec.ref[sl], rec.quadrature[sl], ell)
        if np.ptp(phi) < 2 * np.pi:
            raise AccelcalError(f"{where}: the phase spans {np.ptp(phi):.3g} rad, less than a "
                                "fringe (2 pi): a larger displacement")
        s = wavelength * phi / (4 * np.pi)
        gain, delay = _daq(rec.metadata)
        w = 2 * np.pi * f
        # a = -w^2 s at the fundamental (the harmonics are fitted beside, not used)
        return s * (-(w**2) / G_N), complex(1.0 / (gain * np.exp(-1j * w * delay)))

    steps = _steps(records, displacement_in_g)
    e0 = ellipses[0]
    return assemble(
        LASER, f"{records[0].output_unit}/g", steps, reference_frequency,
        extra=(Assumption("ellipse", (e0.p, e0.q, e0.a, e0.b, e0.e), "",
                          "Heydemann ellipse of the first step: p, q (V), a, b (V), e (rad)"),),
        note=("Primary calibration by laser interferometry (ISO 16063-11, method 3): "
              "Heydemann-corrected quadrature phase, displacement by the sine approximation "
              "on whole periods, acceleration -w^2 s; covariance from the fits' residuals."))


def reduce_gravity(records, *, static_scale_factor=None,
                   reference_frequency: float | None = None):
    """The DUT's complex sensitivity at each rotation rate (ISO 16063-16).

    Parameters
    ----------
    records : ResponseRecord or sequence of them
        Records whose ``excitation`` is ``gravity`` (``local_g``, g), ``ref``
        the encoder angle in rad.
    static_scale_factor : (float, float), optional
        The static scale factor and its standard uncertainty (output unit per
        g, e.g. a tumble's), to tie the response to.
    reference_frequency : float, optional
        Frequency of the deviations, Hz (default: the lowest rate).

    Returns
    -------
    accelcal.results.Reduction
        Method ``response/gravity``; with a static scale factor, the
        assumption ``static_tie``: ``(|S(f_low)| / S_static - 1, its standard
        uncertainty, f_low)``.

    References
    ----------
    .. [1] ISO 16063-16:2014.
    """
    records = _records(records, "gravity")

    def encoder_input(rec, sl, f, where):
        local = rec.metadata["excitation"].get("local_g", 1.0)
        if not (isinstance(local, int | float) and 0.9 <= local <= 1.1):
            raise AccelcalError("a gravity record's local_g must be from 0.9 to 1.1 g",
                                parameter="records")
        return local * np.cos(rec.ref[sl]), 1.0 + 0j

    steps = _steps(records, encoder_input)
    f_ref = min(steps["freqs"]) if reference_frequency is None else reference_frequency
    red = assemble(
        GRAVITY, f"{records[0].output_unit}/g", steps, f_ref,
        note=("Calibration by the Earth's gravitation (ISO 16063-16): the input g cos(theta) "
              "from the table's encoder, its phasor and the DUT's by one harmonic fit on "
              "whole turns; covariance from the fits' residuals."))
    if static_scale_factor is None:
        return red
    return tie_to_static(red, static_scale_factor)


def tie_to_static(reduction, static_scale_factor):
    """``reduction`` with the assumption ``static_tie``: its lowest point against ``S_static``."""
    from dataclasses import replace

    try:
        value, u = (float(x) for x in static_scale_factor)
    except (TypeError, ValueError):
        raise AccelcalError("give the static scale factor as (value, standard uncertainty)",
                            parameter="static_scale_factor") from None
    if not (np.isfinite(value) and value != 0 and np.isfinite(u) and u >= 0):
        raise AccelcalError("the static scale factor must be non-zero and its uncertainty "
                            ">= 0", parameter="static_scale_factor")
    mag, u_mag, _, _ = reduction.estimate.polar()
    ratio = mag[0] / abs(value)
    rel = ratio * np.hypot(u_mag[0] / mag[0], u / value)
    f_low = float(reduction.observations["frequency_hz"][0])
    tie = Assumption("static_tie", (float(ratio - 1.0), float(rel), f_low), "",
                     f"|S({f_low:g} Hz)| / static scale factor - 1 and its standard "
                     "uncertainty")
    return replace(reduction, assumptions=(*reduction.assumptions, tie))
