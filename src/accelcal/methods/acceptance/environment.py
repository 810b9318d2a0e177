"""Before/after an environment: two simulated calibrations of one serial, as records.

The rig (:func:`accelcal.rigs.acceptance_env.simulate_environment`) gives
the tumble records of a calibration before and after an environment that
shifts the coefficients; each is reduced by the IEEE 1293 tumble reduction
(:func:`accelcal.methods.tumble.reduce`, noise estimated from the
residuals, so each record states its degrees of freedom; the terms left
out, the asymmetries, are taken as zero without the Type B bound of their
priors: they are the sensor's own, the same in both calibrations, and would
cancel in the shift) to a calibration record of the serial, a day apart,
that :func:`~accelcal.methods.acceptance.records.compare` tests for the
shift. With a zero shift the difference of each coefficient is the
difference of two independent estimates, Student-t distributed with the
records' uncertainties.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, tests after environmental exposure.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import dataclasses
import datetime as dt


def simulate_pair(shift=None, *, serial: str = "SN-ENV", environment: str = "thermal cycle",
                  date: str = "2026-01-01", seed=None, **settings) -> tuple:
    """Two calibration records of one serial around an environment (module docs).

    Parameters
    ----------
    shift : dict, optional
        Coefficient -> shift (g/g^n; K1 relative), e.g. from
        :func:`accelcal.rigs.acceptance_env.parse_shift`.
    serial, environment, date : str
        The serial number, the environment's name (in the records' notes),
        the date of the first calibration (the second is a day later).
    seed : int, SeedSequence or Generator, optional
    **settings
        ``model``, ``positions``, ``repeats``, ``noise`` of the rig.

    Returns
    -------
    tuple of CalibrationRecord
        ``(before, after)``, method ``tumble/fourier``, simulated.
    """
    from accelcal.io.lab_metadata import LabInfo
    from accelcal.methods import tumble
    from accelcal.rigs.acceptance_env import simulate_environment

    data = simulate_environment(shift, seed=seed, **settings)
    first = dt.datetime.fromisoformat(date).replace(tzinfo=dt.UTC)
    told = ", ".join(f"{k}={v:.6g}" for k, v in sorted((shift or {}).items())) or "none"
    out = []
    for i, (record, when) in enumerate(zip(data, ("before", "after"), strict=True)):
        red = tumble.reduce(record, priors="none")
        day = (first + dt.timedelta(days=i)).isoformat()
        rec = red.to_records(LabInfo(serials=(serial,), date=day, simulated=True), date=day)[0]
        out.append(dataclasses.replace(rec, notes=(
            *rec.notes, (f"simulated calibration {when} a {environment}; true shift "
                         f"(g/g^n, K1 relative): {told}"))))
    return tuple(out)
