"""The plateaus of a thermal test: settling checks and one tumble reduction each.

Each plateau's soak is checked (:mod:`~accelcal.methods.thermal.settle`); a
plateau that did not settle is refused. Its multipoint tumble is reduced by
:func:`accelcal.methods.tumble.reduce_tumble` (IEEE 1293 Fourier relations
for uniform positions, least squares otherwise; noise from the residuals),
and its temperature is the mean of the sensor temperature over the tumble.

The standard uncertainties used as weights are the tumbles' with the noise
pooled over the plateaus, ``s_pool^2 = sum nu_j s_j^2 / sum nu_j`` (the same
sensor and positions at every plateau): a tumble of a dozen positions
estimates its own noise from a handful of degrees of freedom, and weights
that scatter with those estimates would make the weighted fit's stated
covariance optimistic [Draper 9.2]. The scatter between plateaus is
estimated by the fit itself (:mod:`~accelcal.methods.thermal.poly`).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, multipoint tumble at each test temperature.
.. [DOMAIN] accelcal domain notes, sections 5 and 8.
.. [Draper] Draper N. R., Smith H., Applied Regression Analysis, 3rd ed.,
   1998, sec. 9.2 (weighted least squares with estimated weights).
"""

import dataclasses
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.thermal.settle import Settling, settling


@dataclass(frozen=True)
class Plateau:
    """One plateau: index, setpoint, direction, temperature, settling, tumble reduction.

    ``pooled`` is the ratio of the pooled noise SD to the tumble's own;
    ``temperature_sd`` the standard uncertainty of ``temperature`` from the
    readings (their standard error of the mean over the tumble, degC).
    """

    index: int
    setpoint: float
    direction: int
    temperature: float
    settling: Settling
    reduction: object
    pooled: float = 1.0
    temperature_sd: float = 0.0

    def value(self, name: str) -> float:
        """The tumble's estimate of ``name``."""
        return self.reduction.estimate[name]

    def std(self, name: str) -> float:
        """Its standard uncertainty with the pooled noise (module docs)."""
        return self.reduction.estimate.std_of(name) * self.pooled


def reduce_plateaus(record, *, window: float, rate_limit: float, tolerance: float,
                    terms=None) -> list[Plateau]:
    """Settle-check and reduce every plateau of a thermal record.

    Parameters
    ----------
    record : accelcal.io.formats.thermal.ThermalRecord
    window, rate_limit, tolerance : float
        Settling criterion (:func:`~accelcal.methods.thermal.settle.settling`).
    terms : sequence of str, optional
        Tumble terms (default the tumble's default for the axis).

    Returns
    -------
    list of Plateau
        In test order.

    Raises
    ------
    AccelcalError
        For fewer than two plateaus with a tumble, or a plateau that did not
        settle (naming it, its rate and the limit).
    """
    from accelcal.methods.tumble import reduce_tumble

    present = sorted({int(p) for p in record.plateau[record.phase == 2]})
    if len(present) < 2:
        raise AccelcalError(
            f"the record has {len(present)} plateau(s) with a tumble; a thermal test needs "
            "tumbles at several temperatures (at least 3 for a temperature coefficient with "
            "its uncertainty)")
    directions = record.directions()
    out, unsettled = [], []
    for j in present:
        rows = record.rows("soak", j)
        if rows.size == 0:  # no soak recorded: the tumble's own readings must be settled
            rows = record.rows("tumble", j)
        st = settling(record.t[rows], record.temperature[rows], window=window,
                      rate_limit=rate_limit, tolerance=tolerance)
        if not st.settled:
            unsettled.append((j, st))
            continue
        angles, outputs, temps = record.tumble(j)
        # Type A only: the terms each tumble takes as zero are the same at every plateau,
        # and the thermal reduction propagates their priors once, to the rows at T0.
        red = reduce_tumble(angles, outputs if outputs.shape[1] > 1 else outputs[:, 0],
                            rotation_axis=record.rotation_axis, output_unit=record.output_unit,
                            terms=terms, repeats=outputs.shape[1] > 1, priors=None)
        temps = np.ravel(temps)
        sem = float(np.std(temps, ddof=1) / np.sqrt(temps.size)) if temps.size > 1 else 0.0
        out.append(Plateau(j, record.setpoints[j], int(directions[j]), float(np.mean(temps)),
                           st, red, temperature_sd=sem))
    if unsettled:
        j, st = unsettled[0]
        seen = ("too few readings in the window" if st.samples < 3 else
                f"its temperature still changes {abs(st.rate):.3g} degC/min over the last "
                f"{window:g} s of its soak (limit {rate_limit:g})")
        raise AccelcalError(
            f"{len(unsettled)} plateau(s) never settled, first plateau {j} (setpoint "
            f"{record.setpoints[j]:g} degC): {seen}; soak longer, or give a larger rate limit "
            "if the test procedure allows it", parameter="rate_limit")
    dof = np.array([p.reduction.dof for p in out], dtype=float)
    sd = np.array([p.reduction.assumed("noise_sd") for p in out])
    pooled = np.sqrt(np.sum(dof * sd**2) / np.sum(dof))  # Eq. (6) [Draper 9.2]
    return [dataclasses.replace(p, pooled=float(pooled / s)) for p, s in zip(out, sd,
                                                                             strict=True)]
