"""Shaker rig: sinusoidal vibration in the transverse plane of an accelerometer.

Frame (DOMAIN conventions, GuanTang Fig. 1): IA = Z, OA = Y, PA = X. The
shaker vibrates along a direction at angle ``theta`` in the XY plane,
measured from PA towards OA, so the unit vector of the vibration axis in
(PA, OA, IA) components is ``(cos theta, sin theta, 0)``.

The specific force the accelerometer feels is ::

    f(t) = (G + a_v(t)) e_v + a_n(t) e_n + a_ia(t) e_i,
    a_v(t) = A_v sin(w t + phi)                                   (GuanTang eq. (5))

with ``G`` the static gravity component along the vibration axis (0 is the
paper's idealised set-up, 1 the physical vertical shaker with IA horizontal:
the drive law (4) cannot remove gravity from the sensed specific force),
``e_n = (-sin theta, cos theta, 0)`` the in-plane direction perpendicular to
the vibration axis and ``e_i`` the input axis. The shaker's own transverse
motion has amplitude ``ratio * A_v``, phase ``phase`` relative to ``a_v``
and direction ``beta`` in the plane perpendicular to the vibration axis,
from ``e_n`` towards IA: ``a_n = ratio A_v cos(beta) sin(w t + phi + psi)``,
``a_ia = ratio A_v sin(beta) sin(w t + phi + psi)``. In the laboratory this
plane is horizontal and does not turn with the accelerometer about IA.

The reference accelerometer measures ``a_v`` (column ``ref``); optionally
the transverse motion too (``ref_n``, ``ref_ia``).

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (1)-(6), (14), Figs. 1-2.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration
   sensitivity (shaker method).
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.model import ErrorModel
from accelcal.units import OUTPUT_UNITS


@dataclass(frozen=True)
class LinearModel:
    """Linear model of a vibration accelerometer: ``u = s_i a_i + s_o a_o + s_p a_p``.

    Parameters
    ----------
    s_i, s_o, s_p : float
        Sensitivities along IA, OA and PA in the output unit per g.
    output_unit : {"V", "mV", "mA", "g"}
        Output unit.
    sigma : float
        Output noise standard deviation in g (scaled by ``s_i``).

    References
    ----------
    .. [1] GuanTang, eq. (2); ISO 16063-31.
    """

    s_i: float
    s_o: float = 0.0
    s_p: float = 0.0
    output_unit: str = "mV"
    sigma: float = 0.0

    def __post_init__(self) -> None:
        for name in ("s_i", "s_o", "s_p", "sigma"):
            if not np.isfinite(getattr(self, name)):
                raise AccelcalError(f"LinearModel {name} must be finite")
        if self.s_i == 0.0:
            raise AccelcalError("LinearModel s_i (axial sensitivity) must be non-zero")
        if self.sigma < 0:
            raise AccelcalError("LinearModel sigma must be >= 0")
        if self.output_unit not in OUTPUT_UNITS:
            raise AccelcalError(f"LinearModel output_unit must be one of {OUTPUT_UNITS}")

    @property
    def K1(self) -> float:
        """Axial sensitivity, output unit per g (the analogue of ErrorModel.K1)."""
        return self.s_i

    def output(self, a_i, a_o=0.0, a_p=0.0, *, rng=None):
        """Output in the output unit; Eq. (2) [GuanTang]."""
        u = self.s_i * np.asarray(a_i, float) + self.s_o * np.asarray(a_o, float)
        u = u + self.s_p * np.asarray(a_p, float)  # Eq. (2) [GuanTang]
        if rng is not None and self.sigma > 0:
            u = u + rng.normal(0.0, self.sigma * abs(self.s_i), size=np.shape(u))
        return u


Sensor = ErrorModel | LinearModel


@dataclass(frozen=True)
class ShakerRecords:
    """Simulated or measured shaker records, one per direction angle.

    Arrays have shape ``(..., m, n)``: leading axes (trials), ``m`` angles,
    ``n`` samples. Optional channels are None when absent.

    Attributes
    ----------
    t : numpy.ndarray
        Sample times, s, shape ``(n,)``.
    theta : numpy.ndarray
        Direction angles, rad, shape ``(m,)``.
    ref : numpy.ndarray
        Reference accelerometer along the vibration axis, g.
    u : numpy.ndarray
        Sensor output while vibrating, ``output_unit``.
    frequency, sample_rate : float
        Hz.
    amplitude : float
        Nominal vibration amplitude A_v, g.
    gravity : float
        Static specific force along the vibration axis, g.
    output_unit : str
        Unit of ``u``.
    scale_factor : float
        Axial scale factor of the sensor (K1 or s_i), output unit per g, when known.
    ref_n, ref_ia : numpy.ndarray or None
        Reference channels measuring the shaker's transverse motion along
        ``e_n`` and along IA, g.
    u_rest : numpy.ndarray or None
        Sensor output at rest (static gravity only) at each angle.
    metadata : dict
        Further description (sensor, settings).
    """

    t: np.ndarray
    theta: np.ndarray
    ref: np.ndarray
    u: np.ndarray
    frequency: float
    sample_rate: float
    amplitude: float
    gravity: float
    output_unit: str
    scale_factor: float | None = None
    ref_n: np.ndarray | None = None
    ref_ia: np.ndarray | None = None
    u_rest: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = np.shape(self.t)[-1]
        m = np.shape(self.theta)[-1]
        for name in ("ref", "u", "ref_n", "ref_ia", "u_rest"):
            arr = getattr(self, name)
            if arr is None:
                continue
            shape = np.shape(arr)
            if len(shape) < 2 or shape[-1] != n or shape[-2] != m:
                raise AccelcalError(
                    f"shaker records: channel {name} has shape {shape}, expected (..., {m}, {n}) "
                    f"for {m} angles of {n} samples; give channels of equal length"
                )


@dataclass(frozen=True)
class ShakerRig:
    """A shaker vibrating along a direction in the transverse plane.

    Parameters
    ----------
    amplitude : float
        Vibration amplitude A_v, g (>= 0).
    frequency : float
        Vibration frequency f, Hz.
    sample_rate : float
        Sample rate, Hz (above 4 f so that the 2w component is resolved).
    periods : float
        Record length in periods; a non-integer gives a partial last period.
    phase : float
        Initial phase phi of ``a_v = A_v sin(w t + phi)``, rad.
    gravity : float
        Static specific force along the vibration axis, g (0 or 1 typically).
    transverse_ratio : float
        Amplitude of the shaker's own transverse motion relative to A_v.
    transverse_phase : float
        Its phase relative to ``a_v``, rad.
    transverse_direction : float
        Its direction beta from ``e_n`` towards IA, rad.
    ref_noise : float
        Noise of the reference channels, g (standard deviation).
    noise : float, optional
        Sensor output noise in g (scaled by the axial scale factor); default
        the sensor's own ``sigma``.
    measure_transverse : bool
        Record reference channels ``ref_n`` and ``ref_ia`` of the transverse motion.
    rest : bool
        Also record the output at rest (``u_rest``, same length) at each angle.

    References
    ----------
    .. [1] GuanTang, eqs. (4)-(6) and (14); ISO 16063-31.
    """

    amplitude: float
    frequency: float = 160.0
    sample_rate: float = 10240.0
    periods: float = 16.0
    phase: float = 0.0
    gravity: float = 0.0
    transverse_ratio: float = 0.0
    transverse_phase: float = 0.0
    transverse_direction: float = 0.0
    ref_noise: float = 0.0
    noise: float | None = None
    measure_transverse: bool = False
    rest: bool = False

    def __post_init__(self) -> None:
        for name in ("amplitude", "frequency", "sample_rate", "periods", "phase", "gravity",
                     "transverse_ratio", "transverse_phase", "transverse_direction",
                     "ref_noise"):
            if not np.isfinite(getattr(self, name)):
                raise AccelcalError(f"shaker: {name} must be finite")
        if self.amplitude < 0:
            raise AccelcalError(f"shaker: amplitude {self.amplitude} g must be >= 0")
        if self.frequency <= 0 or self.sample_rate <= 0:
            raise AccelcalError("shaker: frequency and sample rate must be positive (Hz)")
        if self.sample_rate <= 4 * self.frequency:
            raise AccelcalError(
                f"shaker: sample rate {self.sample_rate} Hz must exceed 4 f = "
                f"{4 * self.frequency} Hz to resolve the 2w component"
            )
        if self.periods < 1:
            raise AccelcalError(
                f"shaker: {self.periods} periods is shorter than one period; record at least one"
            )
        if self.ref_noise < 0 or (self.noise is not None and self.noise < 0):
            raise AccelcalError("shaker: noise levels must be >= 0 (g)")

    @property
    def samples(self) -> int:
        """Samples per record, ``round(periods fs / f)``."""
        return round(self.periods * self.sample_rate / self.frequency)

    def time(self) -> np.ndarray:
        """Sample times, s."""
        return np.arange(self.samples) / self.sample_rate

    def inputs(self, theta):
        """Specific force (a_i, a_o, a_p) and reference signals at angles ``theta``.

        Parameters
        ----------
        theta : array_like, shape (m,)
            Direction angles, rad.

        Returns
        -------
        (a_i, a_o, a_p), (a_v, a_n, a_ia) : tuples of numpy.ndarray, shape (m, n)
            Specific force components in g, and the vibration and transverse
            motion signals in g.

        References
        ----------
        .. [1] GuanTang, eqs. (5)-(6) [DOMAIN section 3], gravity as a static component.
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))[:, None]
        wt = 2 * np.pi * self.frequency * self.time()
        a_v = self.amplitude * np.sin(wt + self.phase) + 0.0 * theta  # Eq. (5) [GuanTang]
        motion = self.transverse_ratio * self.amplitude * np.sin(
            wt + self.phase + self.transverse_phase
        )
        a_n = np.cos(self.transverse_direction) * motion + 0.0 * theta
        a_ia = np.sin(self.transverse_direction) * motion + 0.0 * theta
        axial = self.gravity + a_v
        # Eq. (6) [GuanTang]: a_p = a cos(theta), a_o = a sin(theta), plus e_n, e_i parts.
        a_p = axial * np.cos(theta) - a_n * np.sin(theta)
        a_o = axial * np.sin(theta) + a_n * np.cos(theta)
        return (a_ia, a_o, a_p), (a_v, a_n, a_ia)

    def simulate(self, sensor: Sensor, theta, *, rng: np.random.Generator | None = None,
                 trials: int | None = None) -> ShakerRecords:
        """Simulate records at direction angles ``theta`` (rad).

        Parameters
        ----------
        sensor : ErrorModel or LinearModel
            The accelerometer.
        theta : array_like, shape (m,)
            Direction angles, rad.
        rng : numpy.random.Generator, optional
            Source of noise; without it the records are noise-free.
        trials : int, optional
            Independent noise realisations stacked on a leading axis.

        Returns
        -------
        ShakerRecords
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        (a_i, a_o, a_p), (a_v, a_n, a_ia) = self.inputs(theta)
        lead = () if trials is None else (int(trials),)
        shape = (*lead, *a_v.shape)
        u = np.broadcast_to(sensor.output(a_i, a_o, a_p), shape)
        static = np.zeros_like(a_v) + self.gravity
        u_rest = None
        if self.rest:
            u_rest = np.broadcast_to(
                sensor.output(0.0 * static, static * np.sin(theta)[:, None],
                              static * np.cos(theta)[:, None]), shape)
        chans = {"ref": a_v, "ref_n": a_n, "ref_ia": a_ia}
        chans = {k: np.broadcast_to(v, shape) for k, v in chans.items()}
        sigma = sensor.sigma if self.noise is None else self.noise
        if rng is not None:
            scale = abs(sensor.K1) * sigma
            if scale > 0:
                u = u + rng.normal(0.0, scale, size=shape)
                if u_rest is not None:
                    u_rest = u_rest + rng.normal(0.0, scale, size=shape)
            if self.ref_noise > 0:
                chans = {k: v + rng.normal(0.0, self.ref_noise, size=shape)
                         for k, v in chans.items()}
        meta = {
            "sensor": "linear" if isinstance(sensor, LinearModel) else "inertial",
            "phase_rad": self.phase,
            "transverse_ratio": self.transverse_ratio,
            "transverse_phase_rad": self.transverse_phase,
            "transverse_direction_rad": self.transverse_direction,
        }
        return ShakerRecords(
            t=self.time(), theta=theta, ref=chans["ref"], u=np.array(u),
            frequency=self.frequency, sample_rate=self.sample_rate, amplitude=self.amplitude,
            gravity=self.gravity, output_unit=sensor.output_unit, scale_factor=float(sensor.K1),
            ref_n=chans["ref_n"] if self.measure_transverse else None,
            ref_ia=chans["ref_ia"] if self.measure_transverse else None,
            u_rest=None if u_rest is None else np.array(u_rest), metadata=meta,
        )


# ------------------------------------------------------------------ record files
KIND = "shaker"
"""``kind`` of shaker record files (see :mod:`accelcal.io.records`)."""

_REQUIRED_META = ("frequency_hz", "sample_rate_hz", "angle_deg", "amplitude_g", "gravity_g",
                  "output_unit")
_OPTIONAL = ("ref_n", "ref_ia", "u_rest")


def record_file_name(amplitude: float, angle_deg: float) -> str:
    """File name of one record in a directory: ``shaker_A5g_theta045.00.csv``."""
    return f"shaker_A{amplitude:g}g_theta{angle_deg:06.2f}.csv"


def _record_tables(records: ShakerRecords, extra: dict | None):
    if records.u.ndim != 2:
        raise AccelcalError("only records of shape (angles, samples) can be written to files")
    unit = records.output_unit
    units = {"t": "s", "ref": "g", "u": unit, "ref_n": "g", "ref_ia": "g", "u_rest": unit}
    for j, theta in enumerate(records.theta):
        angle = float(np.rad2deg(theta))
        cols = {"t": records.t, "ref": records.ref[j], "u": records.u[j]}
        for name in _OPTIONAL:
            arr = getattr(records, name)
            if arr is not None:
                cols[name] = arr[j]
        meta = {
            "frequency_hz": records.frequency, "sample_rate_hz": records.sample_rate,
            "angle_deg": angle, "amplitude_g": records.amplitude, "gravity_g": records.gravity,
            "output_unit": unit, "units": {k: units[k] for k in cols},
        }
        if records.scale_factor is not None:
            meta["scale_factor"] = records.scale_factor
        meta.update(records.metadata)
        meta.update(extra or {})
        yield angle, meta, cols


def write_records(records_list, out, *, extra: dict | None = None, suffix: str = ".csv") -> list:
    """Write shaker records, one file per angle (and amplitude).

    Parameters
    ----------
    records_list : ShakerRecords or list of ShakerRecords
        Records of shape ``(m, n)``, e.g. one per amplitude.
    out : path-like
        A directory (created if absent; files named by :func:`record_file_name`)
        or, for exactly one record, a file ending in ``.csv``.
    extra : dict, optional
        Further metadata written into every file (e.g. ``serial``,
        ``operator``, ``date``, ``local_gravity``).
    suffix : {".csv", ".parquet"}
        File type of the records written into a directory.

    Returns
    -------
    list of pathlib.Path
        The files written. A new directory appears whole or not at all.

    References
    ----------
    .. [1] Record format: :mod:`accelcal.io.records`; fields in docs/transverse.md.
    """
    import os
    import shutil
    import tempfile
    from pathlib import Path

    from accelcal.io.records import write_record

    if isinstance(records_list, ShakerRecords):
        records_list = [records_list]
    tables = [(rec.amplitude, *row) for rec in records_list
              for row in _record_tables(rec, extra)]
    out = Path(out)
    if out.suffix.lower() == ".csv":
        if len(tables) != 1:
            raise AccelcalError(
                f"--out {out} is one file but {len(tables)} records were made (one per angle "
                "and amplitude); give a directory, or one angle and one amplitude"
            )
        _, _, meta, cols = tables[0]
        write_record(out, KIND, meta, cols)
        return [out]
    if out.exists() and not out.is_dir():
        raise AccelcalError(f"--out {out} exists and is not a directory")
    if suffix not in (".csv", ".parquet"):
        raise AccelcalError(f"record file suffix {suffix!r} is not .csv or .parquet")
    names = [record_file_name(a, ang).removesuffix(".csv") + suffix for a, ang, _, _ in tables]
    if len(set(names)) != len(names):
        raise AccelcalError("two records would share a file name (repeated angle or amplitude)")
    if out.is_dir():
        for name, (_, _, meta, cols) in zip(names, tables, strict=True):
            write_record(out / name, KIND, meta, cols)
        return [out / n for n in names]
    if not out.parent.is_dir():
        raise AccelcalError(f"cannot write {out}: directory {out.parent} does not exist")
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        for name, (_, _, meta, cols) in zip(names, tables, strict=True):
            write_record(tmp / name, KIND, meta, cols)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out / n for n in names]


def read_records(path) -> list[ShakerRecords]:
    """Read shaker record files: a directory of them or one file.

    Records are grouped by amplitude (one :class:`ShakerRecords` per
    amplitude, angles sorted); within a group every file must share the
    frequency, sample rate, gravity, output unit, channels and time base.

    Raises
    ------
    AccelcalError
        For a missing path, an empty directory, malformed files, channels or
        files of different lengths, or inconsistent metadata (naming the file).

    References
    ----------
    .. [1] Record format: :mod:`accelcal.io.records`; fields in docs/transverse.md.
    """
    from pathlib import Path

    from accelcal.io.lab_metadata import check_lab_metadata
    from accelcal.io.records import read_record

    path = Path(path)
    if path.is_dir():
        files = sorted([*path.glob("*.csv"), *path.glob("*.parquet")])
        if not files:
            raise AccelcalError(f"{path}: no record files (*.csv, *.parquet) in the directory")
    elif path.exists():
        files = [path]
    else:
        raise AccelcalError(f"{path}: no such file or directory")
    groups: dict[float, list] = {}
    for f in files:
        meta, cols = read_record(f, KIND, required_metadata=_REQUIRED_META,
                                 required_columns=("t", "ref", "u"))
        for key in ("frequency_hz", "sample_rate_hz", "angle_deg", "amplitude_g", "gravity_g"):
            if isinstance(meta[key], bool) or not isinstance(meta[key], int | float):
                raise AccelcalError(f"{f}: metadata {key} must be a number")
        scale = meta.get("scale_factor")
        if scale is not None and (isinstance(scale, bool) or not isinstance(scale, int | float)
                                  or not np.isfinite(scale) or scale == 0):
            raise AccelcalError(f"{f}: metadata scale_factor must be a finite non-zero number")
        check_lab_metadata(meta, f)
        groups.setdefault(float(meta["amplitude_g"]), []).append((f, meta, cols))
    out = []
    for amp in sorted(groups):
        items = sorted(groups[amp], key=lambda x: float(x[1]["angle_deg"]))
        f0, meta0, cols0 = items[0]
        chans = [c for c in _OPTIONAL if c in cols0]
        for f, meta, cols in items[1:]:
            for key in ("frequency_hz", "sample_rate_hz", "gravity_g", "output_unit"):
                if meta[key] != meta0[key]:
                    raise AccelcalError(
                        f"{f}: {key} = {meta[key]!r} differs from {meta0[key]!r} in {f0}; "
                        "records of one amplitude must share it")
            if cols["t"].size != cols0["t"].size:
                raise AccelcalError(
                    f"{f}: {cols['t'].size} samples, but {f0} has {cols0['t'].size}; records "
                    "of one amplitude must have channels of equal length")
            if [c for c in _OPTIONAL if c in cols] != chans:
                raise AccelcalError(f"{f}: channels differ from those of {f0}")
        stack = {c: np.stack([it[2][c] for it in items]) for c in ("ref", "u", *chans)}
        scale = meta0.get("scale_factor")
        out.append(ShakerRecords(
            t=cols0["t"], theta=np.deg2rad([float(it[1]["angle_deg"]) for it in items]),
            ref=stack["ref"], u=stack["u"], frequency=float(meta0["frequency_hz"]),
            sample_rate=float(meta0["sample_rate_hz"]), amplitude=amp,
            gravity=float(meta0["gravity_g"]), output_unit=str(meta0["output_unit"]),
            scale_factor=None if scale is None else float(scale),
            ref_n=stack.get("ref_n"), ref_ia=stack.get("ref_ia"), u_rest=stack.get("u_rest"),
            metadata={k: v for k, v in meta0.items()
                      if k in ("axial_sensitivity", "sensor", "source", "serial",
                               "operator", "date", "local_gravity")},
        ))
    return out
