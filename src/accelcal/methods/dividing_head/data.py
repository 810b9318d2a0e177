"""Validated indexing-head data (:class:`HeadData`), from arrays or a record file.

Data: nominal head angles ``alpha`` (rad, shape ``(n,)``), sensor outputs
``U`` (output unit, shape ``(K, n)``, or ``(R, K, n)`` with R repeated
readings, averaged), mount phases ``phi`` (rad, ``(K,)``).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (1)-(5).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_OUTPUT, HeadRecord, check_positions


@dataclass(frozen=True)
class HeadData:
    """Validated indexing-head data.

    Parameters
    ----------
    positions : numpy.ndarray
        Nominal head angles, rad, shape ``(n,)``.
    outputs : numpy.ndarray
        Outputs, shape ``(K, n)`` (means over repeats).
    mounts : numpy.ndarray
        Mount phases, rad, shape ``(K,)``.
    output_unit : str
        Unit of the outputs.
    repeats : int
        Readings averaged per position.
    sensors : tuple of str
        Names of the sensor columns (default ``U1``, ``U2``, ...).
    nominal_scale_factors : tuple of float
        Each sensor's nominal scale factor, output unit per g (empty when not
        known); the reductions report K_I's deviation from it in ppm.
    """

    positions: np.ndarray
    outputs: np.ndarray
    mounts: np.ndarray
    output_unit: str = "V"
    repeats: int = 1
    sensors: tuple[str, ...] = ()
    nominal_scale_factors: tuple[float, ...] = ()

    @classmethod
    def build(cls, positions, outputs, mounts, output_unit: str = "V", *,
              sensors=None, nominal_scale_factors=None) -> "HeadData":
        """Check shapes and values and average repeats.

        Raises
        ------
        AccelcalError
            For duplicated or non-finite angles, NaN readings or readings
            beyond :data:`~accelcal.io.formats.dividing_head.MAX_OUTPUT`, or a number
            of mount phases (or sensor names) that does not match the output
            columns.
        """
        alpha = np.asarray(positions, dtype=float).reshape(-1)
        check_positions(alpha)
        u = np.asarray(outputs, dtype=float)
        if u.ndim == 1:
            u = u[None, :]
        if u.ndim not in (2, 3) or u.shape[-1] != alpha.size:
            raise AccelcalError(
                f"outputs of shape {u.shape} do not match {alpha.size} positions; "
                "give shape (sensors, positions) or (repeats, sensors, positions)"
            )
        if not np.isfinite(u).all():
            bad = np.argwhere(~np.isfinite(u))[0]
            raise AccelcalError(
                f"output reading at index {tuple(int(i) for i in bad)} is NaN or inf; "
                "remove or re-measure that position"
            )
        if np.abs(u).max(initial=0.0) > MAX_OUTPUT:
            raise AccelcalError(
                f"an output reading of {np.abs(u).max():.3g} is beyond +-{MAX_OUTPUT:g} "
                f"{output_unit}: not a reading; check the values and the output unit",
                parameter="outputs")
        repeats = u.shape[0] if u.ndim == 3 else 1
        u = u.mean(axis=0) if u.ndim == 3 else u
        phi = np.asarray(mounts, dtype=float).reshape(-1)
        if phi.size != u.shape[0]:
            raise AccelcalError(
                f"{phi.size} mount phases given for {u.shape[0]} sensor output columns; "
                "give one mount phase per sensor column"
            )
        if not np.isfinite(phi).all():
            raise AccelcalError("mount phases contain NaN or inf")
        names = tuple(sensors) if sensors is not None else \
            tuple(f"U{k + 1}" for k in range(u.shape[0]))
        if len(names) != u.shape[0]:
            raise AccelcalError(
                f"{len(names)} sensor names given for {u.shape[0]} sensor output columns",
                parameter="sensors",
            )
        nominal = () if nominal_scale_factors is None else \
            tuple(float(x) for x in np.asarray(nominal_scale_factors, dtype=float).reshape(-1))
        if nominal and (len(nominal) != u.shape[0] or not all(
                np.isfinite(x) and x != 0 and abs(x) <= MAX_OUTPUT for x in nominal)):
            raise AccelcalError(
                f"give one finite, non-zero nominal scale factor per sensor column "
                f"({u.shape[0]}), got {len(nominal)}", parameter="nominal_scale_factors",
            )
        return cls(alpha, u, phi, output_unit, repeats, names, nominal)

    @classmethod
    def from_record(cls, record: HeadRecord) -> "HeadData":
        """The data of a ``dividing-head`` record file (repeats averaged)."""
        return cls.build(record.positions, record.outputs, record.mounts, record.output_unit,
                         sensors=record.sensors,
                         nominal_scale_factors=record.nominal_scale_factors)

    @property
    def n_sensors(self) -> int:
        """Number of sensors K."""
        return self.outputs.shape[0]

    def angles(self) -> np.ndarray:
        """Nominal sensor angles beta, rad, shape ``(K, n)``."""
        return self.positions[None, :] + self.mounts[:, None]
