"""Comparison by stepped sine (ISO 16063-21): the DUT's complex sensitivity at each step.

At each step of frequency ``f`` both channels are fitted, on the whole
periods recorded, with a sine of the known frequency (the three-parameter
fit of IEEE 1057, :func:`accelcal.signal.sinefit.sine_fit3`, with the second
and third harmonics fitted beside: :data:`HARMONICS`), giving their phasors
``u_ref`` and ``u_dut``. Then::

    S_dut(f) = S_ref(f) u_dut / u_ref / D(f),    D(f) = g exp(-i 2 pi f tau),

``S_ref`` the reference's complex sensitivity from its certificate
(interpolated in frequency) and ``D`` the DAQ's known channel mismatch (the
DUT channel's gain ratio ``g`` and delay ``tau`` relative to the
reference's, from the record's ``daq`` metadata; none by default).

The covariance of ``[Re S, Im S]`` is propagated to first order from the
fits' covariances (each ``s^2 (D'D)^-1`` with ``s`` the channel's residual
standard deviation, the channels independent), through the complex
derivatives ``dR/du_dut = 1 / u_ref`` and ``dR/du_ref = -R / u_ref``; its
degrees of freedom are the fits' residual ones (the smaller of the two
channels', ``n - 7``). The reference's certificate uncertainty is not
included: it is a Type B term of the comparison's budget (DOMAIN.md
section 10), not of this reduction.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, sec. 6 (comparison, sine excitation)
   and annex A (uncertainty).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.1 (three-parameter sine fit).
.. [GUMS2] JCGM 102:2011 (GUM Supplement 2), sec. 6 (complex quantities as
   real 2-vectors).
"""

import re

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.results import Assumption, Estimate, Reduction

FAMILY = "response"
"""Reduction family of frequency responses."""

METHOD = "response/comparison"
"""Method id of the stepped-sine comparison."""

MIN_PERIODS = 3
"""Fewest whole periods a step must hold."""

MIN_EXPLAINED = 0.9
"""Least fraction of the reference channel's variance the step's sine must explain:
below it the step's frequency is not the one in the data."""

HARMONICS = 3
"""Harmonics fitted with the fundamental (those below the Nyquist frequency): the shaker's
distortion is then fitted, not left in the residuals, where a record of a fractional
number of samples per period would let it leak into the fundamental."""

REFERENCE_FREQUENCY = 80.0
"""Default reference frequency of the deviations, Hz (ISO 16063-21: 160 or 80 Hz); the
step nearest it is taken."""


def _real(c: complex) -> np.ndarray:
    """The 2 x 2 real matrix of multiplication by ``c`` on ``[Re, Im]``."""
    return np.array([[c.real, -c.imag], [c.imag, c.real]])


def step_ratio(ref, dut, fs: float, f: float, *, t0: float, where: str):
    """The phasor ratio ``u_dut / u_ref`` of one step, its 2 x 2 covariance and dof.

    Parameters
    ----------
    ref, dut : numpy.ndarray
        The step's samples of both channels.
    fs, f : float
        Sample rate and step frequency, Hz.
    t0 : float
        Time of the first sample, s.
    where : str
        The step, for messages.

    Returns
    -------
    ratio : complex
    covariance : numpy.ndarray, shape (2, 2)
        Of ``[Re, Im]`` of the ratio.
    dof : int
    periods : int
        Whole periods fitted.

    Raises
    ------
    AccelcalError
        For fewer than :data:`MIN_PERIODS` whole periods, or a step whose
        frequency is not in the reference channel.
    """
    from accelcal.signal.sinefit import sine_fit3

    periods = int(np.floor(ref.size * f / fs + 1e-9))
    if periods < MIN_PERIODS:
        raise AccelcalError(f"{where}: {ref.size} samples at {fs:g} Hz hold {periods} whole "
                            f"period(s) of {f:g} Hz; at least {MIN_PERIODS} are needed")
    m = min(ref.size, round(periods * fs / f))
    harmonics = max(1, min(HARMONICS, int(np.ceil(fs / (2 * f))) - 1))
    fit = sine_fit3(np.stack([ref[:m], dut[:m]]), fs, f, harmonics=harmonics, t0=t0)
    u_ref, u_dut = fit.phasors[:, 0]
    amp = np.abs(u_ref)
    explained = amp**2 / 2 / (amp**2 / 2 + fit.residual_std[0] ** 2) if amp > 0 else 0.0
    if not explained >= MIN_EXPLAINED:
        raise AccelcalError(f"{where}: {f:g} Hz is not found in the data (a sine at it "
                            f"explains {100 * explained:.3g} % of the reference channel's "
                            f"variance, at least {100 * MIN_EXPLAINED:g} % is needed)")
    if u_dut == 0:
        raise AccelcalError(f"{where}: the DUT channel holds no signal at {f:g} Hz")
    flip = np.diag([1.0, -1.0])  # (a, b) -> (Re P, Im P) = (a, -b)
    cov = fit.covariance[:, 1:3, 1:3]
    v_ref, v_dut = (flip @ c @ flip for c in cov)
    ratio = complex(u_dut / u_ref)
    j_dut, j_ref = _real(1.0 / u_ref), _real(-ratio / u_ref)
    covariance = j_dut @ v_dut @ j_dut.T + j_ref @ v_ref @ j_ref.T
    return ratio, covariance, int(fit.dof), periods


def _names(frequencies, amplitudes) -> tuple[str, ...]:
    names = [f"S({f:g} Hz)" for f in frequencies]
    if len(set(names)) < len(names):
        names = [f"S({f:g} Hz, {a:g} g)" for f, a in zip(frequencies, amplitudes, strict=True)]
    if len(set(names)) < len(names):
        raise AccelcalError("two steps share a frequency and an amplitude: give each step once",
                            parameter="records")
    return tuple(names)


POINT_NAME = re.compile(r"^S\((?P<f>[^ ,)]+) Hz(?:, (?P<a>[^ )]+) g)?\)")
"""A point's row name, ``S(f Hz)`` or ``S(f Hz, a g)`` (:func:`_names`): its frequency
and amplitude; a suffix (a fit's ``#k`` of a repeated frequency) is left unread."""


def point_of(name: str) -> tuple[float, float | None] | None:
    """The frequency (Hz) and amplitude (g, or None) a point's row name states; None if not one."""
    m = POINT_NAME.match(name)
    if m is None:
        return None
    return float(m.group("f")), float(m.group("a")) if m.group("a") else None


def _daq(meta) -> tuple[float, float]:
    daq = meta.get("daq") or {}
    try:
        gain, delay = float(daq.get("gain_ratio", 1.0)), float(daq.get("delay_s", 0.0))
    except (TypeError, ValueError, AttributeError):
        raise AccelcalError("the record's daq metadata must give numbers gain_ratio and "
                            "delay_s", parameter="records") from None
    if not (np.isfinite(gain) and gain > 0 and np.isfinite(delay)):
        raise AccelcalError("the record's daq gain_ratio must be positive and its delay_s "
                            "finite", parameter="records")
    return gain, delay


def reduce_stepped(records, reference=None, *, reference_frequency: float | None = None
                   ) -> Reduction:
    """The DUT's complex sensitivity at each step of one or more stepped-sine records.

    Parameters
    ----------
    records : ResponseRecord or sequence of them
        Stepped-sine records (:mod:`accelcal.io.formats.response`), of one DUT
        output unit.
    reference : accelcal.rigs.shaker_response.ReferenceTable, optional
        The reference's certificate; default the one each record states.
    reference_frequency : float, optional
        Frequency of the deviations, Hz: the step nearest it (default
        :data:`REFERENCE_FREQUENCY`).

    Returns
    -------
    accelcal.results.Reduction
        Family ``response``, method ``response/comparison``: one complex
        coefficient ``S(f Hz)`` per step (output unit per g), covariance of
        the ``[Re, Im]`` pairs (block diagonal), ``dof`` the least of the
        steps'; observations ``frequency_hz``, ``amplitude_g``, ``periods``.

    Raises
    ------
    AccelcalError
        For a step too short, a frequency not in the data, a reference that
        does not cover the band, records of different units, none at all.

    References
    ----------
    .. [1] ISO 16063-21:2003, sec. 6.
    """
    from accelcal.rigs.shaker_response import ReferenceTable

    records = [records] if not isinstance(records, list | tuple) else list(records)
    if not records:
        raise AccelcalError("give at least one record", parameter="records")
    units = {r.output_unit for r in records}
    if len(units) > 1:
        raise AccelcalError(f"the records' DUT units differ ({', '.join(sorted(units))})",
                            parameter="records")
    for rec in records:
        if rec.excitation != "stepped":
            raise AccelcalError(f"a stepped-sine reduction needs stepped records, not "
                                f"{rec.excitation} ones", parameter="method")
    freqs, amps, values, blocks, dofs, periods = [], [], [], [], [], []
    for n, rec in enumerate(records):
        table = reference
        if table is None:
            if "reference" not in rec.metadata:
                raise AccelcalError("the record states no reference certificate: give one "
                                    "(a CSV table)", parameter="reference")
            table = ReferenceTable.from_dict(rec.metadata["reference"])
        gain, delay = _daq(rec.metadata)
        f_steps = rec.frequencies
        s_ref = table.sensitivity(f_steps)
        amp_meta = rec.metadata.get("amplitudes_g") or [float("nan")] * len(f_steps)
        for k, sl in enumerate(rec.steps):
            f = float(f_steps[k])
            where = f"record {n + 1}, step {k} ({f:g} Hz)" if len(records) > 1 else \
                f"step {k} ({f:g} Hz)"
            ratio, cov, dof, p = step_ratio(rec.ref[sl], rec.dut[sl], rec.sample_rate_hz, f,
                                            t0=float(rec.t[sl][0]), where=where)
            c = complex(s_ref[k] / (gain * np.exp(-2j * np.pi * f * delay)))
            jc = _real(c)
            values.append(c * ratio)
            blocks.append(jc @ cov @ jc.T)
            freqs.append(f)
            amps.append(float(amp_meta[k]) if k < len(amp_meta) else float("nan"))
            dofs.append(dof)
            periods.append(p)
    flagged = tuple(float(f["frequency_hz"]) for rec in records
                    for f in rec.metadata.get("flagged", ()) if isinstance(f, dict)
                    and isinstance(f.get("frequency_hz"), int | float))
    if flagged:
        extra_flags = (Assumption("flagged", flagged, "Hz", "steps flagged at import (their "
                                  "coherence below the limit), kept"),)
    else:
        extra_flags = ()
    source = "the records' own" if reference is None else "given"
    points = {"freqs": freqs, "amps": amps, "values": values, "blocks": blocks, "dofs": dofs,
              "periods": periods}
    return assemble(
        METHOD, f"{records[0].output_unit}/g", points, reference_frequency, extra=(
            Assumption("reference", source, "",
                       f"reference sensitivity from {source} certificate, interpolated "
                       "linearly in frequency (its uncertainty is not included)"),
            Assumption("daq", (gain, delay), "", "DUT channel's gain ratio and delay (s) "
                       "relative to the reference's, corrected"), *extra_flags),
        note=("Stepped-sine comparison (ISO 16063-21): three-parameter sine fits on whole "
              "periods, covariance of each step's [Re, Im] from the fits' residuals."))


def assemble(method: str, unit: str, points: dict, reference_frequency, *, extra=(),
             note: str, provenance=None) -> Reduction:
    """A response reduction of points in any order: sorted by frequency, named, block covariance.

    Parameters
    ----------
    method, unit : str
        The method id and the points' unit (output unit per g).
    points : dict
        Sequences ``freqs, amps, values, blocks, dofs, periods``, one entry per
        point: frequency (Hz), amplitude (g), complex value, 2 x 2 covariance
        of ``[Re, Im]``, degrees of freedom, periods fitted.
    reference_frequency : float or None
        Frequency of the deviations, Hz (default :data:`REFERENCE_FREQUENCY`).
    extra : tuple of Assumption
        The route's own assumptions.
    note : str
        The route in one sentence.
    provenance : dict, optional
        More provenance.
    """
    freqs, amps, values, blocks, dofs, periods = (points[k] for k in (
        "freqs", "amps", "values", "blocks", "dofs", "periods"))
    order = np.argsort(freqs, kind="stable")
    freqs = np.asarray(freqs, dtype=float)[order]
    names = _names(freqs, np.asarray(amps)[order])
    covariance = np.zeros((2 * len(names), 2 * len(names)))
    for i, j in enumerate(order):
        covariance[2 * i:2 * i + 2, 2 * i:2 * i + 2] = blocks[j]
    est = Estimate(names, np.asarray(values)[order], covariance, dict.fromkeys(names, unit),
                   method, dof=int(min(dofs)))
    f_ref = REFERENCE_FREQUENCY if reference_frequency is None else reference_frequency
    if not (isinstance(f_ref, int | float) and 1e-6 <= f_ref <= 1e9):
        raise AccelcalError(f"must be a frequency from 1e-6 to 1e9 Hz, got {f_ref!r}",
                            parameter="reference_frequency")
    ref_name = names[int(np.argmin(np.abs(np.log(freqs / f_ref))))]
    return Reduction(
        family=FAMILY, method=method, sensors=(est,), sensor_names=("dut",), dof=int(min(dofs)),
        assumptions=(
            Assumption("reference_frequency", float(freqs[names.index(ref_name)]), "Hz",
                       f"deviations from the sensitivity at {ref_name}"), *extra),
        observations={"frequency_hz": freqs, "amplitude_g": np.asarray(amps)[order],
                      "periods": np.asarray(periods)[order]},
        provenance={"steps": len(names), "unit": unit, **(provenance or {})},
        notes=(note,),
    )


def response_rows(reduction) -> list[dict]:
    """One row per step, as ``accelcal response reduce`` prints it.

    Keys ``frequency_hz, magnitude, magnitude_u, phase_deg, phase_u, unit``
    (standard uncertainties), then the deviation of the magnitude from the
    reference frequency's, ``deviation_pct``, ``deviation_pct_u`` (the two
    steps independent) and ``deviation_db``.
    """
    est = reduction.estimate
    mag, u_mag, phase, u_phase = est.polar()
    freqs = np.asarray(reduction.observations["frequency_hz"], dtype=float)
    f_ref = reduction.assumed("reference_frequency")
    i_ref = int(np.argmin(np.abs(freqs - f_ref)))
    rows = []
    for i, name in enumerate(est.names):
        ratio = mag[i] / mag[i_ref]
        rel = 0.0 if i == i_ref else np.hypot(u_mag[i] / mag[i], u_mag[i_ref] / mag[i_ref])
        rows.append({"frequency_hz": float(freqs[i]), "magnitude": float(mag[i]),
                     "magnitude_u": float(u_mag[i]), "phase_deg": float(np.rad2deg(phase[i])),
                     "phase_u": float(np.rad2deg(u_phase[i])), "unit": est.units[name],
                     "deviation_pct": float(100.0 * (ratio - 1.0)),
                     "deviation_pct_u": float(100.0 * ratio * rel),
                     "deviation_db": float(20.0 * np.log10(ratio))})
    return rows
