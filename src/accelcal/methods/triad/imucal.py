"""imucal sessions and calibrations: known orientations from its labels, and its JSON files.

imucal [1]_ records a Ferraris [2]_ session as one table with a ``part``
column, or with a regions JSON (``{"x_p": {"start": i, "end": j}, ...}``,
``end`` exclusive), and labels the static holds by the axis that points up:

=====  ================================================================
label  the sensor's specific force (imucal: "x-acc measures +1g")
=====  ================================================================
x_p    +g along +x: the x axis points up (away from the Earth)
x_a    +g along -x: the x axis points down
y_p    +g along +y;  ``y_a``: along -y
z_p    +g along +z;  ``z_a``: along -z
=====  ================================================================

(imucal's ``FerrarisCalibration`` docstring and ``compute``: the ``_p``
means enter with +grav, ``_a`` with -grav, Eq. (19)-(23) of [2]_.) So the
*up* vector of a hold, the unit vector of the specific force in the sensor
frame, is ``+e_i`` for ``i_p`` and ``-e_i`` for ``i_a``. The ``x_rot``,
``y_rot``, ``z_rot`` regions are rotations for the gyroscope and are not
static: they are ignored here, as are labels imucal does not define.

Known orientations for other files: a triad record's ``positions`` or a
JSON list of up vectors, one per detected static interval
(:func:`listed_positions`, :func:`positions_file`); :func:`apply_stream`
writes a calibrated copy of a recording.

A calibration goes both ways through imucal's JSON layout:
:func:`write_imucal` writes a ``FerrarisCalibrationInfo`` file (``K_a``,
``R_a``, ``b_a`` from :meth:`TriadCalibration.to_imucal
<accelcal.methods.triad.model.TriadCalibration.to_imucal>`; imucal's
``load_calibration_info`` reads it) and :func:`read_calibration` reads
either accelcal's or imucal's file.

References
----------
.. [1] imucal documentation (mad-lab-fau/imucal, v2.6): ``FerrarisCalibration``,
   ``ferraris_regions_from_section_list``, ``CalibrationInfo.to_json_file``
   and ``load_calibration_info``; https://imucal.readthedocs.io.
.. [2] F. Ferraris, U. Grimaldi, M. Parvis, "Procedure for effortless
   in-field calibration of three-axis rate gyros and accelerometers",
   Sensors and Materials 7(5), 1995, pp. 311-330.
"""

import json
from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import shown, shown_path

IMUCAL_UP = {"x_p": (1.0, 0.0, 0.0), "x_a": (-1.0, 0.0, 0.0),
             "y_p": (0.0, 1.0, 0.0), "y_a": (0.0, -1.0, 0.0),
             "z_p": (0.0, 0.0, 1.0), "z_a": (0.0, 0.0, -1.0)}
"""imucal's static labels -> the up vector (unit specific force) in the sensor frame."""

IMUCAL_FORMAT_VERSION = "2.0.0"
"""imucal's calibration file format written (``CalibrationInfo.CAL_FORMAT_VERSION``)."""

IDENTITY_GYRO = {"K_g": np.eye(3).tolist(), "R_g": np.eye(3).tolist(),
                 "K_ga": np.zeros((3, 3)).tolist(), "b_g": [0.0, 0.0, 0.0]}
"""Gyroscope terms of an exported file: identity (gyroscope data pass unchanged), so
imucal's ``calibrate`` runs; the file's comment says the gyroscope is not calibrated."""


@dataclass(frozen=True)
class KnownPositions:
    """Static holds with known orientation: label, up vector and the statistics of the samples.

    ``labels`` (imucal's ``x_p`` ...), ``up`` (unit specific-force direction in
    the sensor/fixture frame, ``(k, 3)``), ``means`` and ``noise_sd`` (mean and
    SD of one sample per axis, ``(k, 3)``, input unit), ``counts`` (samples)
    and ``spans`` (``(start, stop)``, or None for labels not in one run);
    ``excluded``: with excluded (clipped) samples, ``samples`` left out, the
    positions ``cut`` (kept without them) and ``dropped`` (fewer than 2 left).
    """

    labels: tuple
    up: np.ndarray
    means: np.ndarray
    noise_sd: np.ndarray
    counts: np.ndarray
    spans: tuple
    excluded: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.labels)


def _stats(label: str, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if len(samples) < 2:
        raise AccelcalError(f"position {shown(label)} has {len(samples)} sample(s); a static "
                            "hold needs at least 2 (better: seconds of them)")
    return samples.mean(axis=0), samples.std(axis=0, ddof=1)


def positions_from_spans(values, spans: dict, ups: dict, exclude=None) -> KnownPositions:
    """Known positions from sample ranges ``label -> (start, stop)`` and ``label -> up``.

    Labels without an up vector in ``ups`` are skipped; up vectors are
    normalised; ``exclude`` (bool per sample): samples left out of the
    statistics (clipped), a position left with fewer than 2 dropped. An
    AccelcalError for a range outside the samples, a hold of fewer than 2
    samples, a zero up vector, or no labelled hold at all.
    """
    u = np.asarray(values, dtype=float)
    labels, up, means, sds, counts, kept = [], [], [], [], [], []
    drop = _Drop(exclude)
    for label, (start, stop) in spans.items():
        if label not in ups:
            continue
        if not 0 <= start < stop <= len(u):
            raise AccelcalError(f"position {shown(label)}: samples {start}:{stop} are outside "
                                f"the recording's 0:{len(u)}")
        idx = drop.keep(np.arange(start, stop))
        if idx is None:
            continue
        mean, sd = _stats(label, u[idx])
        labels.append(label)
        up.append(_unit(ups[label], label))
        means.append(mean)
        sds.append(sd)
        counts.append(len(idx))
        kept.append((int(start), int(stop)))
    if not labels and drop.dropped:
        raise AccelcalError(f"every position with a known orientation lost its samples to "
                            f"clipping ({len(drop.dropped)} dropped)")
    if not labels:
        raise AccelcalError("no static position with a known orientation: the labels are "
                            f"{shown(', '.join(map(str, spans)), 120)}; expected "
                            + ", ".join(IMUCAL_UP))
    return KnownPositions(tuple(labels), np.array(up), np.array(means), np.array(sds),
                          np.array(counts), tuple(kept), drop.counts())


class _Drop:
    """Excluded samples left out of the positions, counted."""

    def __init__(self, exclude):
        self.exclude = None if exclude is None else np.asarray(exclude, dtype=bool)
        self.samples, self.cut, self.dropped = 0, [], []

    def keep(self, idx: np.ndarray):
        """The samples ``idx`` of one position not excluded; None: the position is dropped."""
        if self.exclude is None:
            return idx
        out = idx[~self.exclude[idx]]
        if out.size == idx.size:
            return idx
        self.samples += idx.size - out.size
        if out.size < 2:
            self.dropped.append(int(idx[0]))
            return None
        self.cut.append(int(idx[0]))
        return out

    def counts(self) -> dict:
        if self.exclude is None:
            return {}
        return {"samples": self.samples, "cut": len(self.cut), "dropped": len(self.dropped),
                "cut_at": self.cut[:5], "dropped_at": self.dropped[:5]}


def _unit(vector, label: str) -> np.ndarray:
    try:
        v = np.asarray(vector, dtype=float)
    except (TypeError, ValueError):
        v = np.full(1, np.nan)
    norm = float(np.linalg.norm(v)) if v.shape == (3,) and np.isfinite(v).all() else 0.0
    if norm == 0.0:
        raise AccelcalError(f"position {shown(label)}: the up vector must be three finite "
                            f"numbers, not all zero; got {shown(vector)}")
    return v / norm


def positions_from_labels(values, labels, exclude=None) -> KnownPositions:
    """Known positions from per-sample labels (imucal's ``part`` column).

    Every sample labelled ``x_p`` (...) belongs to that hold, in the order
    the labels first appear; other labels (``x_rot``, empty) are ignored;
    ``exclude`` as for :func:`positions_from_spans`.
    """
    u = np.asarray(values, dtype=float)
    lab = np.asarray(labels).astype(str)
    if lab.shape != (len(u),):
        raise AccelcalError(f"{lab.shape[0] if lab.ndim else 0} labels for {len(u)} samples")
    names, first = np.unique(lab, return_index=True)
    found = [str(n) for n in names[np.argsort(first)] if str(n) in IMUCAL_UP]
    if not found:
        raise AccelcalError("no static position with a known orientation: the 'part' column "
                            f"has {shown(', '.join(map(str, names[:20])), 120)}; expected "
                            + ", ".join(IMUCAL_UP))
    up, means, sds, counts, spans, names = [], [], [], [], [], []
    drop = _Drop(exclude)
    for name in found:
        idx = np.flatnonzero(lab == name)
        contiguous = idx[-1] - idx[0] + 1 == len(idx)
        span = (int(idx[0]), int(idx[-1]) + 1) if contiguous else None
        idx = drop.keep(idx)
        if idx is None:
            continue
        mean, sd = _stats(name, u[idx])
        names.append(name)
        up.append(IMUCAL_UP[name])
        means.append(mean)
        sds.append(sd)
        counts.append(len(idx))
        spans.append(span)
    if not names:
        raise AccelcalError(f"every position with a known orientation lost its samples to "
                            f"clipping ({len(drop.dropped)} dropped)")
    return KnownPositions(tuple(names), np.array(up), np.array(means), np.array(sds),
                          np.array(counts), tuple(spans), drop.counts())


def session_positions(recording, exclude=None) -> KnownPositions | None:
    """The known positions of an imucal session: its regions JSON, else its ``part`` labels.

    ``recording`` is a :class:`~accelcal.io.recordings.Recording`; None
    when it has neither regions nor labels; ``exclude``: samples left out
    (:func:`positions_from_spans`).
    """
    if recording.regions:
        return positions_from_spans(recording.values, recording.regions, IMUCAL_UP, exclude)
    if recording.labels is not None:
        return positions_from_labels(recording.values, recording.labels, exclude)
    return None


def listed_positions(values, items, where: str, start=None, stop=None,  # noqa: PLR0917
                     exclude=None) -> KnownPositions:
    """Known positions from a list: a triad record's ``positions`` or a ``--positions`` file.

    Each item is ``{"label", "up", "start", "stop"}`` (a record: sample range
    ``start:stop``), or, with ``start`` and ``stop`` given (the detected
    static intervals, in order), ``[x, y, z]`` or ``{"label", "up"}``: the
    unit specific-force direction in the fixture frame (``[0, 0, 1]``: z up);
    ``exclude`` as for :func:`positions_from_spans`.
    """
    if not isinstance(items, list) or not items:
        raise AccelcalError(f"{where} must be a non-empty JSON list of up vectors [x, y, z] "
                            '(or {"label": ..., "up": [x, y, z]}), one per static interval')
    if start is not None and len(items) != len(start):
        raise AccelcalError(f"{where} lists {len(items)} up vectors for the {len(start)} static "
                            "intervals detected; list them with 'accelcal triad detect'")
    spans, ups = {}, {}
    for k, item in enumerate(items):
        try:
            label = str(item.get("label", f"P{k + 1}")) if isinstance(item, dict) else f"P{k + 1}"
            span = ((int(start[k]), int(stop[k])) if start is not None
                    else (int(item["start"]), int(item["stop"])))
            up = item["up"] if isinstance(item, dict) else item
        except (KeyError, TypeError, ValueError):
            raise AccelcalError(f"{where}: item {k} must be " + (
                "[x, y, z] or an object with up" if start is not None
                else "an object with label, up, start and stop")) from None
        if label in spans:
            raise AccelcalError(f"{where}: label {shown(label)} repeats")
        spans[label], ups[label] = span, up
    return positions_from_spans(values, spans, ups, exclude)


MAX_POSITIONS_BYTES = 1 << 20
"""Largest ``--positions`` file read (1 MiB: tens of thousands of positions)."""


def positions_file(path, values, start, stop) -> KnownPositions:
    """Known positions from a JSON file of up vectors, one per static interval (``--positions``).

    See :func:`listed_positions`; ``start``, ``stop`` are the intervals of
    :func:`accelcal.signal.static.detect_static`.
    """
    from accelcal.io.limits import load_json, read_bounded

    where = f"positions file {shown_path(path)}"
    try:
        text = read_bounded(path, MAX_POSITIONS_BYTES, "positions file").decode("utf-8")
    except UnicodeDecodeError:
        raise AccelcalError(f"{where} is not UTF-8 JSON") from None
    return listed_positions(values, load_json(text, where), where, start, stop)


# ------------------------------------------------------------------- calibration files
def imucal_document(calibration, *, comment: str = "") -> dict:
    """The content of imucal's ``FerrarisCalibrationInfo`` JSON file for an accelcal calibration.

    ``K_a, R_a, b_a`` from :meth:`TriadCalibration.to_imucal`; the
    gyroscope terms are identity (:data:`IDENTITY_GYRO`): the file calibrates
    the accelerometer only, and its comment says so.
    """
    doc = {"acc_unit": "m/s^2", "gyr_unit": "deg/s", "from_acc_unit": calibration.input_unit,
           "from_gyr_unit": "deg/s",
           "comment": ("accelcal triad calibration (accelerometer only; gyroscope terms are "
                       "identity: gyroscope data pass unchanged)" + (f". {comment}" if comment
                                                                    else ""))}
    doc.update(calibration.to_imucal())
    doc.update(IDENTITY_GYRO)
    doc.update({"cal_type": "Ferraris", "_format_version": IMUCAL_FORMAT_VERSION})
    return doc


def write_imucal(calibration, path, *, comment: str = "") -> None:
    """Write :func:`imucal_document` to ``path`` atomically (imucal's loader reads it)."""
    from accelcal.io.atomic import write_text_atomic

    text = json.dumps(imucal_document(calibration, comment=comment), indent=4, allow_nan=False)
    write_text_atomic(path, text + "\n")


def read_calibration(path, *, input_unit: str | None = None):
    """A triad calibration from accelcal's JSON or imucal's (``cal_type``, ``K_a``...).

    Parameters
    ----------
    path : path-like
        The calibration file.
    input_unit : str, optional
        Unit of the raw data, for an imucal file whose ``from_acc_unit`` is
        not one of accelcal's units (imucal's ``"a.u."``: the data's own unit).

    Raises
    ------
    AccelcalError
        For a file that is neither, an imucal file whose output is not in
        m/s^2, or one whose input unit is unknown and not given.
    """
    from accelcal.io.limits import MAX_JSON_BYTES, load_json, read_bounded
    from accelcal.methods.triad.model import TriadCalibration, input_units

    where = f"calibration {shown_path(path)}"
    try:
        raw = read_bounded(path, MAX_JSON_BYTES, "calibration")
        text = raw.decode("utf-8")
    except OSError as exc:
        raise AccelcalError(f"cannot read {where}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise AccelcalError(f"{where} is not UTF-8 text; is it a calibration?") from None
    data = load_json(text, where)
    if not isinstance(data, dict) or "cal_type" not in data:
        return TriadCalibration.from_dict(data, where)
    if data.get("acc_unit", "m/s^2") != "m/s^2":
        raise AccelcalError(f"{where}: imucal acc_unit {shown(data.get('acc_unit'))} is not "
                            "m/s^2; accelcal's calibrations give m/s^2")
    unit = data.get("from_acc_unit")
    if unit not in input_units():
        if input_unit is None:
            raise AccelcalError(f"{where}: imucal from_acc_unit {shown(unit)} is not one of "
                                f"{', '.join(input_units())}; give the data's unit")
        unit = input_unit
    try:
        return TriadCalibration.from_imucal(data, input_unit=unit)
    except AccelcalError as exc:
        raise AccelcalError(f"{where}: {exc}") from None


# ------------------------------------------------------------ a calibrated copy of a recording
OUTPUT_CHANNELS = ("acc_x", "acc_y", "acc_z")
"""Names of the corrected columns written by :func:`apply_stream`."""


def apply_stream(blocks, source, channels, out, correct) -> None:
    """Write a calibrated copy of a recording, streamed: one row per input row, in order.

    ``blocks`` come from :func:`accelcal.io.recordings.iter_blocks` (checked
    samples), ``source`` from :func:`~accelcal.io.recordings.sources.open_source`
    (for the other columns); the ``channels`` become ``acc_x, acc_y, acc_z``
    with the values ``correct(rows (k, 3))``; every other column (time,
    labels) is copied as Arrow reads it (text as it is). ``out`` (CSV) is
    written atomically; memory is bounded by a block. Names and values are
    quoted only where they must be, as ``csv.writer`` (and every other CSV
    accelcal writes) quotes them: a copied time reads ``0.005``, not
    ``"0.005"``.
    """
    from accelcal.io.atomic import atomic_path

    others = [n for n in source.names if n not in channels]
    clash = sorted(set(others) & set(OUTPUT_CHANNELS))
    if clash:
        raise AccelcalError(f"the recording has a column {clash[0]} besides the channels "
                            f"{', '.join(channels)}; the output's acc_x, acc_y, acc_z would "
                            "repeat it: select those as the channels")
    rest = _Rows(_passthrough(source, others))
    with atomic_path(out) as tmp, open(tmp, "wb") as fh:
        for k, block in enumerate(blocks):
            table = _output_table(source.names, channels, correct(block.values),
                                  rest.take(len(block.values)))
            if k == 0:
                fh.write(_csv_lines([table.column_names]))
            _write_rows(fh, table)


def apply_repaired(blocks, out, correct) -> None:
    """Write a calibrated copy of a repaired recording, streamed: ``t`` and the channels.

    The rows are those the repairs left (rows dropped, sorted, filled or
    resampled: :mod:`accelcal.io.recordings.repairs`), no longer the file's
    row for row, so the recording's other columns are not copied: ``t``
    (s from the first sample; only for a recording with a time column) and
    ``acc_x, acc_y, acc_z`` from ``correct(rows (k, 3))``. ``out`` (CSV) is
    written atomically; memory is bounded by a block.
    """
    import pyarrow as pa
    from pyarrow import csv

    from accelcal.io.atomic import atomic_path

    with atomic_path(out) as tmp, open(tmp, "wb") as fh:
        for k, block in enumerate(blocks):
            acc = correct(block.values)
            cols = {} if block.time is None else {"t": block.time}
            cols |= {name: acc[:, j] for j, name in enumerate(OUTPUT_CHANNELS)}
            csv.write_csv(pa.table(cols), fh, csv.WriteOptions(include_header=k == 0,
                                                               quoting_style="none"))


_STRUCTURAL = '[,"\r\n]'
"""A character that makes a CSV field need quotes (``csv.writer``'s minimal quoting)."""


def _csv_lines(rows) -> bytes:
    """Rows through ``csv.writer`` (minimal quoting, newline line ends), as UTF-8."""
    import csv
    import io

    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue().encode("utf-8")


def _write_rows(fh, table) -> None:
    """The rows of an Arrow table appended to ``fh`` (binary), quoted only where needed.

    Arrow's writer, unquoted, is some seven times faster than the csv
    module; it quotes every text field or none, so a block whose text has
    a comma, a quote or a line break goes through ``csv.writer`` instead.
    """
    import pyarrow as pa
    import pyarrow.compute as pc
    from pyarrow import csv

    text = [c for c in table.columns if pa.types.is_string(c.type)
            or pa.types.is_large_string(c.type)]
    if not any(pc.any(pc.match_substring_regex(c, _STRUCTURAL)).as_py() for c in text):
        csv.write_csv(table, fh, csv.WriteOptions(include_header=False, quoting_style="none"))
        return
    fh.write(_csv_lines(zip(*(c.to_pylist() for c in table.columns), strict=True)))


def _passthrough(source, others):
    """The columns other than the channels, in batches (Arrow tables; text kept as it is)."""
    import pyarrow as pa

    from accelcal.io.recordings.sources import _arrow_batches, batches

    if not others:
        return
    if source.input_format == "imu_tk":  # a headerless table of numbers
        for batch in batches(source, others, [], 1 << 20):
            yield pa.table(batch)
        return
    for batch in _arrow_batches(source, [], others, 1 << 20):
        yield pa.Table.from_batches([batch])


class _Rows:
    """Rows taken in order from a stream of Arrow tables, whatever its batch sizes."""

    def __init__(self, tables) -> None:
        self.tables = iter(tables)
        self.pending = None

    def take(self, n: int):
        import pyarrow as pa

        parts = []
        while n > 0:
            if self.pending is None or self.pending.num_rows == 0:
                self.pending = next(self.tables, None)
                if self.pending is None:
                    break
            part = self.pending.slice(0, n)
            self.pending = self.pending.slice(part.num_rows)
            parts.append(part)
            n -= part.num_rows
        return pa.concat_tables(parts) if parts else None


def _output_table(names, channels, a, rest):
    import pyarrow as pa

    columns, out_names = [], []
    for name in names:
        if name in channels:
            k = list(channels).index(name)
            columns.append(pa.array(a[:, k]))
            out_names.append(OUTPUT_CHANNELS[k])
        elif rest is not None and name in rest.column_names:
            columns.append(rest.column(name))
            out_names.append(name)
    return pa.table(columns, names=out_names)
