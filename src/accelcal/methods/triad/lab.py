"""The lab's path of a triad calibration: a recording in, the calibration out, in one call.

:func:`run` does what ``accelcal triad calibrate`` does between reading its
options and writing its files: it reads the recording (any format
:func:`accelcal.io.recordings.read_recording` reads), takes the local
gravity (given, WGS84 normal gravity from latitude and height [TR8350.2]_,
or the record's own), chooses the route (known orientations when the file
or a positions file gives them, else the gravity norm [Tedaldi2014]_), finds
the static intervals (with the threshold factor chosen by the calibration
residual when none is given) and reduces. The command line parses its
options, calls :func:`run` and prints the :class:`TriadRun`; a Python user
calls the same function.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., "A robust and easy to
   implement method for IMU calibration without external equipments", ICRA
   2014, sec. III (static detection, threshold by the residual).
.. [Ferraris1995] Ferraris F., Grimaldi U., Parvis M., "Procedure for
   effortless in-field calibration of three-axis rate gyros and
   accelerometers", Sensors and Materials 7(5), 1995 (known orientations).
.. [TR8350.2] NIMA TR8350.2, World Geodetic System 1984, 3rd ed., 2000.
"""

import dataclasses
from dataclasses import dataclass
from os import PathLike

import numpy as np

from accelcal.errors import AccelcalError

ORIENTATIONS = ("known", "unknown")
"""The routes: known orientations (linear least squares) or unknown (the gravity norm)."""


@dataclass(frozen=True)
class TriadRun:
    """A triad calibration run from a recording, as the command line prints it.

    Attributes
    ----------
    reduction : accelcal.results.Reduction
        The calibration (method ``triad/known-orientations`` or
        ``triad/gravity-norm``).
    recording : accelcal.io.recordings.Recording
        The recording read.
    intervals : accelcal.signal.static.StaticIntervals or None
        The static intervals the reduction used, when they were detected
        (None for positions the file labels itself).
    sweep : list of dict or None
        The threshold factor sweep (factor, intervals, rms_residual, note)
        when the factor was chosen by the residual.
    """

    reduction: object
    recording: object
    intervals: object = None
    sweep: list | None = None

    def norm_rows(self) -> list[dict]:
        """The norm residual ``|a| - g`` of every position before and after, m/s^2.

        One row per position: ``position``, ``norm_before``, ``norm_after``,
        and ``start_s``, ``stop_s`` when the positions are detected intervals.
        """
        obs = self.reduction.observations
        rows = [{"position": label, "norm_before": float(b), "norm_after": float(a)}
                for label, b, a in zip(self.reduction.provenance["labels"], obs["norm_before"],
                                       obs["norm_after"], strict=True)]
        if self.intervals is not None and len(self.intervals) == len(rows):
            for row, (t0, t1) in zip(rows, self.intervals.times, strict=True):
                row.update(start_s=float(t0), stop_s=float(t1))
        return rows

    def summary(self) -> dict:
        """``method``, ``gravity`` (m/s^2), ``positions``, ``dof``, ``condition_number``."""
        red = self.reduction
        cond = float(red.identifiability.condition_number) if red.identifiability else 0.0
        return {"method": red.method, "gravity": red.provenance["gravity"],
                "positions": len(red.provenance["labels"]), "dof": int(red.dof),
                "condition_number": cond if np.isfinite(cond) and cond else float("nan")}


def run(source, *, options=None, orientations: str | None = None, positions=None,
        gravity: float | None = None, latitude: float | None = None,
        height: float | None = None, quadratic: bool = False, init_static: float = 30.0,
        window: float = 1.0, factor: float | None = None, min_length: float = 2.0,
        estimator: str | None = None, fixture_tilt: float | None = None,
        priors="none", rails="auto") -> TriadRun:
    """Calibrate a triad from a recording, as ``accelcal triad calibrate`` does.

    Parameters
    ----------
    source : path-like or accelcal.io.recordings.Recording
        The recording: a file (CSV, Parquet, an imucal session, an imu_tk
        file or a triad record) or one already read.
    options : accelcal.io.recordings.InputOptions, optional
        How to read the file (columns, time, rate, unit, regions...).
    orientations : {"known", "unknown"}, optional
        The route; default: known when the file or ``positions`` gives the
        orientations, else unknown.
    positions : path-like, optional
        JSON list of the up vector of each detected static interval, in
        order: known orientations for any file.
    gravity : float, optional
        Local gravity, m/s^2 (measured).
    latitude, height : float, optional
        Geodetic latitude (deg) and height (m) for the WGS84 normal gravity
        [TR8350.2]_ instead of ``gravity``. Without either, the record's own
        ``local_gravity`` (or ``gravity``) metadata.
    quadratic : bool
        Fit per-axis quadratic terms.
    init_static, window, min_length : float
        Static detection: initial still period, moving-variance window and
        shortest interval kept, s.
    factor : float, optional
        Threshold factor of the detection; default: with unknown orientations
        the one of 2..10 whose calibration leaves the smallest norm residual
        [Tedaldi2014]_, else 2.
    estimator : {"least-squares", "pairs", "gls"}, optional
        Known orientations: the linear estimator
        (:mod:`accelcal.methods.triad.pairs`): least squares, per-axis pairs
        [Ferraris1995]_ (six positions; robust to a tilted fixture) or
        generalised least squares weighing each reading by the noise and
        the fixture tilt; default gls with ``fixture_tilt``, else least
        squares.
    fixture_tilt : float, optional
        Known orientations: standard uncertainty of each position's
        orientation about each horizontal axis, rad (Type B). The noise of
        each interval mean is then its samples' SD over the square root of
        their number (white noise), and the tilt's covariance is added.
    priors : {"none", "default"} or dict
        Each axis's pendulous error terms the triad model leaves out
        (:func:`accelcal.methods.triad.unestimated.with_type_b`): ``"none"``
        (the default: a triad is often a MEMS IMU, whose axes are not
        pendulous) lists the rows each term would move per unit term and
        propagates nothing; ``"default"`` bounds them by the embedded default
        accelerometer's priors, a dict by the user's, as Type B.
    rails : "auto", None or (float, float)
        Clipped samples (:class:`accelcal.signal.clipping.ClipFinder`): runs
        at the channels' extremes (``"auto"``), at or beyond the given rails
        (also taken from ``options.rails``), or none looked for (None). They
        are left out of the static intervals (an interval is cut around them,
        or dropped when too short) and of the known positions' means, and
        counted in ``recording.repairs`` and the reduction's provenance
        (``repairs``) and notes.

    Returns
    -------
    TriadRun

    Raises
    ------
    AccelcalError
        For inconsistent options, a recording that cannot be read, or too
        few positions; the message names the parameter.
    """
    from accelcal.io.recordings.repairs import Repairs
    from accelcal.signal.static import check_settings

    if orientations not in (None, *ORIENTATIONS):
        raise AccelcalError(f"{orientations!r} is not known or unknown", parameter="orientations")
    if positions is not None and orientations == "unknown":
        raise AccelcalError("a positions file gives known orientations; drop orientations "
                            "unknown", parameter="positions")
    for name, value in (("estimator", estimator), ("fixture_tilt", fixture_tilt)):
        if value is not None and orientations == "unknown":
            raise AccelcalError("applies to known orientations (the gravity norm does not "
                                "use them)", parameter=name)
    check_settings(init_static=init_static, window=window, min_length=min_length,
                   factor=2.0 if factor is None else factor)
    from accelcal.methods.triad.unestimated import check_priors

    check_priors(priors)
    if options is not None and options.rails is not None:  # left out here, not refused
        options, rails = dataclasses.replace(options, rails=None), options.rails
    rec = read(source, options)
    rec = dataclasses.replace(rec, repairs=Repairs.from_dict(rec.repairs.to_dict()))  # its own
    g = local_gravity(rec, gravity=gravity, latitude=latitude, height=height)
    check_magnitude(rec, g)
    exclude = clipped_samples(rec, rails)
    detect = (init_static, window, 2.0 if factor is None else factor, min_length, exclude)
    known, found = ((None, None) if orientations == "unknown"
                    else _known(rec, positions, detect, exclude))
    if orientations == "known" and known is None:
        raise AccelcalError(
            "known needs the positions' orientations: imucal labels (a 'part' column or "
            "regions), a triad record's positions, or a positions file", parameter="orientations")
    if known is not None:
        from accelcal.methods.triad.known import calibrate_known

        noise = (None if fixture_tilt is None
                 else known.noise_sd / np.sqrt(known.counts)[:, None])
        def again(means):
            return calibrate_known(means, known.up, g, input_unit=rec.unit, quadratic=quadratic,
                                   labels=known.labels, counts=known.counts, noise_sd=noise,
                                   estimator=estimator, fixture_tilt=fixture_tilt)

        red = _reduced(rec, found if found is not None else known, again, known.means, g,
                       known.up, known.labels, priors)
        return TriadRun(red, rec, found)
    if estimator is not None or fixture_tilt is not None:
        raise AccelcalError("applies to known orientations; the recording gives none (imucal "
                            "labels or regions, a triad record's positions, or a positions "
                            "file)", parameter="estimator" if estimator else "fixture_tilt")
    from accelcal.methods.triad.unknown import calibrate_unknown

    if factor is None:
        from accelcal.methods.triad.threshold import choose_factor

        choice = choose_factor(rec.values, rec.rate, g, init_static=init_static, window=window,
                               min_length=min_length, input_unit=rec.unit, quadratic=quadratic,
                               time=rec.time, exclude=exclude)
        found, sweep, labels = choice.intervals, choice.rows, None  # the sweep's P1..Pn
    else:
        found, sweep = detect_intervals(rec, *detect), None
        labels = [f"I{k + 1}" for k in range(len(found))]

    def again_unknown(means):
        return calibrate_unknown(means, g, input_unit=rec.unit, quadratic=quadratic,
                                 labels=labels, counts=found.counts)

    return TriadRun(_reduced(rec, found, again_unknown, found.means, g, None, labels, priors),
                    rec, found, sweep)


def clipped_samples(rec, rails="auto"):
    """The clipped samples of a triad recording (a bool mask), or None when there are none.

    ``rails`` as for :func:`run`; what is found goes into ``rec.repairs``.
    """
    from accelcal.signal.clipping import ClipFinder

    finder = ClipFinder(rec.values.shape[1], rails)
    mask = finder(rec.values)
    note_clipped(rec.repairs, finder)
    return mask if finder.count else None


def note_clipped(repairs, finder) -> None:
    """Count the clipped samples a :class:`~accelcal.signal.clipping.ClipFinder` found."""
    if finder.count:
        repairs.add(f"clipped samples ({finder.rule()})",
                    "left out of the static intervals and the fit",
                    np.asarray(finder.first) + 1, count=finder.count)


def note_excluded(repairs, excluded: dict) -> None:
    """Count the static intervals cut at and dropped for clipped samples.

    ``excluded``: :attr:`accelcal.signal.static.StaticIntervals.excluded`.
    """
    for what, key, action in (
            ("static intervals cut at clipped samples", "cut",
             "the clipped samples left out; the rest kept"),
            ("static intervals dropped for clipped samples", "dropped",
             "too short without the clipped samples; left out")):
        if excluded.get(key):
            repairs.add(what, action, np.asarray(excluded[f"{key}_at"]) + 1,
                        count=excluded[key])


def _reduced(rec, found, again, means, gravity, up, labels, priors):  # noqa: PLR0917
    """:func:`_bounded`, with what clipping cut and dropped in the repairs.

    The repairs go into the provenance and the notes; a refusal for too few
    positions says how many clipping dropped.
    """
    from accelcal.io.recordings.repairs import with_repairs

    excluded = getattr(found, "excluded", None) or {}
    note_excluded(rec.repairs, excluded)
    try:
        red = _bounded(again, means, gravity, up, labels, priors)
    except AccelcalError as exc:
        if not excluded.get("dropped"):
            raise
        raise AccelcalError(f"{exc.message}; {excluded['dropped']} static interval(s) were "
                            f"dropped for clipped samples ({excluded['samples']} samples at "
                            "the rails): give longer holds, a range that does not clip, or "
                            "--rails", parameter=exc.parameter) from None
    return with_repairs(red, rec.repairs.to_dict() if rec.repairs else None)


def _bounded(again, means, gravity, up, labels, priors):  # noqa: PLR0917
    """The reduction of ``means`` with each axis's pendulous terms as ``priors`` say."""
    from accelcal.methods.triad.unestimated import with_type_b

    return with_type_b(again(means), means, again, gravity=gravity, up=up, priors=priors,
                       labels=labels)


def read(source, options=None):
    """The triad recording of ``source`` (a path, read with ``options``, or a Recording)."""
    if not isinstance(source, str | PathLike):
        return source
    from accelcal.io.recordings import read_recording

    return read_recording(source, options, channels=3, what="triad recording")


PLAUSIBLE_RATIO = 2.0
"""The median magnitude of a recording in an acceleration unit must lie within this
factor of the local gravity: a still or slowly turned triad reads about 1 g, raw ADC
counts read as m/s^2 (imucal's raw sessions: some 2,000 per g) thousands."""


def check_magnitude(rec, gravity: float) -> None:
    """Refuse values in an acceleration unit whose median magnitude is not about ``gravity``.

    A raw output taken for an acceleration (counts read as m/s^2) would
    otherwise calibrate to a scale factor near -100 % and biases of
    thousands of g; a raw unit (counts, V, mV) is not checked: the
    calibration finds its scale.
    """
    from accelcal.io.recordings.options import ACCELERATION_UNITS

    if rec.unit not in ACCELERATION_UNITS or not len(rec.values):
        return
    step = max(1, len(rec.values) // 100_000)
    norm = np.linalg.norm(rec.values[::step], axis=1)
    median = float(np.median(norm)) * ACCELERATION_UNITS[rec.unit]
    if not gravity / PLAUSIBLE_RATIO <= median <= gravity * PLAUSIBLE_RATIO:
        raise AccelcalError(
            f"the recording's median magnitude is {median:.6g} m/s^2 as {rec.unit}, not about "
            f"the local gravity {gravity:.6g} m/s^2: the values are not in {rec.unit}; give "
            "their unit (counts, V or mV for a raw output, e.g. an imucal raw session in ADC "
            "counts; scale for a known conversion)", parameter="unit")


def detect_intervals(rec, init_static: float, window: float, factor: float,  # noqa: PLR0917
                     min_length: float, exclude=None):
    """The static intervals of a recording (:func:`accelcal.signal.static.detect_static`).

    ``exclude``: samples never static, e.g. :func:`clipped_samples`.
    """
    from accelcal.signal.static import detect_static

    return detect_static(rec.values, rec.rate, init_static=init_static, window=window,
                         factor=factor, min_length=min_length, time=rec.time, unit=rec.unit,
                         exclude=exclude)


def local_gravity(rec, *, gravity=None, latitude=None, height=None) -> float:
    """The local gravity, m/s^2: given, WGS84 normal gravity [TR8350.2]_, or the record's."""
    from accelcal.physics.gravity import check_gravity, normal_gravity

    if gravity is not None:
        if latitude is not None or height is not None:
            raise AccelcalError("give either gravity or latitude (and height), not both",
                                parameter="gravity")
        return check_gravity(gravity)
    if latitude is not None:
        return normal_gravity(latitude, 0.0 if height is None else height)
    if height is not None:
        raise AccelcalError("goes with latitude (WGS84 normal gravity)", parameter="height")
    value = rec.metadata.get("local_gravity", rec.metadata.get("gravity"))
    if value is None:
        raise AccelcalError("give the local gravity: gravity G (m/s^2, measured) or latitude "
                            "DEG and height M (WGS84 normal gravity)", parameter="gravity")
    return check_gravity(value)


def _known(rec, positions, detect, exclude=None):
    """Known positions (and the intervals detected for a positions file), or (None, None)."""
    from accelcal.methods.triad.imucal import listed_positions, positions_file, session_positions

    if positions is not None:
        found = detect_intervals(rec, *detect)
        return positions_file(positions, rec.values, found.start, found.stop), found
    known = session_positions(rec, exclude)
    if known is None and rec.metadata.get("positions"):
        known = listed_positions(rec.values, rec.metadata["positions"], "the record's positions",
                                 exclude=exclude)
    return known, None
