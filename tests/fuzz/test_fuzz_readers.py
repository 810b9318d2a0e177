"""Mutation fuzz of every reader (issue 11): bad files give an AccelcalError, nothing else.

A corpus of mutants is built from valid files (the examples in
``examples/data`` and files the formats' writers produce): byte flips and
truncations, deleted and duplicated lines, metadata values replaced by
extreme or ill-typed JSON (1e308, NaN, huge integers, booleans, null, [],
100,000-deep nesting, 1 MB strings, control characters, wrong units and
format versions), cells replaced by extreme numbers or text, missing and
extra columns, time running backwards. For every mutant the reader must
either return or raise :class:`~accelcal.errors.AccelcalError` (never
another exception, never a warning) within :data:`TIME_LIMIT` seconds, and
write nothing. A mutant a reader accepts then goes through the command that
consumes such files (``READERS[...].command``): exit status 0 with no
non-finite number in its JSON output, or 2 with one ``accelcal: error:``
line; never a traceback.

A reader added later joins with one line in :data:`READERS`.
"""

import contextlib
import io
import json
import math
import random
import re
import shutil
import signal
import sys
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from helpers.cli import unstated_uncertainty
from helpers.paths import EXAMPLES, FIXTURES, REAL_IMUCAL

pytestmark = pytest.mark.fuzz  # the whole module: the fuzz tier (docs/testing.md)

TIME_LIMIT = 5.0
"""Seconds one read may take (the CLI stage: :data:`COMMAND_TIME_LIMIT`)."""

COMMAND_TIME_LIMIT = 20.0

MAX_MESSAGE_CHARS = 1000
"""Longest error message accepted: a message quotes values shortened, not whole (issue 11,
class 5); and it is one line."""


# ------------------------------------------------------------------------------ seeds
def _example(*parts) -> Callable[[Path], tuple[Path, Path]]:
    """A seed copied from examples/data: (path to read, file to mutate)."""

    def make(tmp: Path):
        src = EXAMPLES.joinpath(*parts)
        if src.is_dir():
            shutil.copytree(src, tmp / src.name)
            target = tmp / src.name
            return target, sorted(target.iterdir())[0]
        shutil.copy(src, tmp / src.name)
        return tmp / src.name, tmp / src.name

    return make


SHAKER_ANGLES = ("000", "090", "180", "270")
"""Four of the example's twelve angles: enough for every route, a third of the reading."""


def _shaker(suffix: str):
    def make(tmp: Path):
        from accelcal.io.formats.shaker import read_records, write_records

        out = tmp / "shaker"
        out.mkdir()
        for angle in SHAKER_ANGLES:
            shutil.copy(EXAMPLES / "shaker" / f"shaker_A5g_theta{angle}.00.csv", out)
        if suffix == ".csv":
            return out, sorted(out.iterdir())[0]
        (records,) = read_records(out)
        shutil.rmtree(out)
        files = write_records([records], out, suffix=suffix)
        return out, sorted(files)[0]

    return make


def _vibrafuge_parquet(tmp: Path):
    from accelcal.io.formats.vibrafuge import read_vibrafuge, write_vibrafuge
    from accelcal.io.lab_metadata import read_metadata

    meta = read_metadata(EXAMPLES / "vibrafuge.csv")
    lab = {k: meta[k] for k in ("serial", "operator", "date", "local_gravity") if k in meta}
    path = tmp / "vibrafuge.parquet"
    write_vibrafuge(path, read_vibrafuge(EXAMPLES / "vibrafuge.csv"), provenance=lab)
    return path, path


def _tumble(suffix: str):
    def make(tmp: Path):
        from accelcal.defaults import default_model
        from accelcal.io.formats import tumble
        from accelcal.rigs.tumble import simulate, uniform_positions

        rec = simulate(uniform_positions(12, 0.1), default_model(), rotation_axis="OA",
                       noise=1e-5, repeats=2, seed=1)
        rec = type(rec)(rec.angles_rad, rec.outputs, rec.rotation_axis, rec.output_unit,
                        {**rec.metadata, "serial": "ACC-0001", "operator": "J. Smith",
                         "date": "2026-11-20T09:30:00+00:00", "local_gravity": 9.80122})
        path = tmp / f"tumble{suffix}"
        tumble.write(path, rec)
        return path, path

    return make


def _triad(suffix: str):
    def make(tmp: Path):
        from accelcal.io.formats import triad
        from accelcal.methods.triad import TriadCalibration
        from accelcal.rigs.triad import simulate

        cal = TriadCalibration(bias=(0.02, -0.01, 0.03), scale=(1.01, 0.99, 1.002),
                               angles=(1e-3, -2e-3, 5e-4))
        rec = simulate(cal, 12, rate=20.0, dwell=1.0, motion=0.5, still=2.0, noise_sd=1e-3,
                       seed=2)
        path = tmp / f"triad{suffix}"
        triad.write(path, rec)
        return path, path

    return make


def _noise(suffix: str):
    def make(tmp: Path):
        from accelcal.io.formats import noise
        from accelcal.rigs.noise import simulate

        rec = simulate(N=2e-5, B=3e-6, rate=50.0, duration=40.0, seed=1)
        rec = type(rec)(rec.values, rec.rate, rec.unit, rec.channels,
                        {**rec.metadata, "serial": "ACC-0001", "operator": "J. Smith",
                         "date": "2026-11-20T09:30:00+00:00"})
        path = tmp / f"noise{suffix}"
        noise.write(path, rec)
        return path, path

    return make


def _thermal(suffix: str):
    def make(tmp: Path):
        import dataclasses

        from accelcal.defaults import default_model
        from accelcal.io.formats import thermal
        from accelcal.rigs.thermal import DEFAULT_TEMPERATURE, Programme, simulate

        rec = simulate(default_model().replace(temperature=DEFAULT_TEMPERATURE),
                       Programme(setpoints=(-20.0, 10.0, 40.0, 25.0, -5.0), warmup=600.0,
                                 points=8, dwell=20.0), seed=1)
        rec = dataclasses.replace(rec, metadata={**rec.metadata, "serial": "ACC-0001",
                                                 "operator": "J. Smith",
                                                 "date": "2026-11-20T09:30:00+00:00"})
        path = tmp / f"thermal{suffix}"
        thermal.write(path, rec)
        return path, path

    return make


def _steps(suffix: str):
    def make(tmp: Path):
        import dataclasses

        from accelcal.io.formats import acceptance
        from accelcal.rigs.acceptance import simulate

        rec = simulate("threshold", increments=(1.0, 3.0, 6.0), dwell=2.0, seed=1)
        rec = dataclasses.replace(rec, metadata={**rec.metadata, "serial": "ACC-0001"})
        path = tmp / f"steps{suffix}"
        acceptance.write(path, rec)
        return path, path

    return make


def _centrifuge(suffix: str):
    def make(tmp: Path):
        import dataclasses

        from accelcal.defaults import default_model
        from accelcal.io.formats import centrifuge
        from accelcal.rigs.centrifuge import simulate

        rec = simulate(default_model(), ("IA-in", "IA-out", "IA-tan"), (5.0, 20.0, 35.0, 50.0),
                       readings=2, spinup=1, seed=1,
                       survey={"radius_error": {"value": 0.0, "sd": 1e-4}})
        rec = dataclasses.replace(rec, metadata={**rec.metadata, "serial": "ACC-0001",
                                                 "operator": "J. Smith",
                                                 "date": "2026-11-20T09:30:00+00:00",
                                                 "local_gravity": 9.80122})
        path = tmp / f"centrifuge{suffix}"
        centrifuge.write(path, rec)
        return path, path

    return make


def _response(suffix: str):
    def make(tmp: Path):
        from accelcal.io.formats import response
        from accelcal.rigs.shaker_response import simulate

        rec = simulate(frequencies=(20.0, 80.0, 315.0), periods=5, seed=1,
                       metadata={"serial": "ACC-0001"})
        path = tmp / f"response{suffix}"
        response.write(path, rec)
        return path, path

    return make


# ------------------------------------------------------------------------------ readers
def _head(path):
    from accelcal.io.formats.dividing_head import read_head_record

    return read_head_record(path)


def _shaker_read(path):
    from accelcal.io.formats.shaker import read_records

    return read_records(path)


def _vibrafuge(path):
    from accelcal.io.formats.vibrafuge import read_vibrafuge

    return read_vibrafuge(path)


def _tumble_read(path):
    from accelcal.io.formats.tumble import read

    return read(path)


def _recording(**options):
    def read(path):
        from accelcal.io.recordings import InputOptions, read_recording

        return read_recording(path, InputOptions(**options), channels=3)

    return read


def _imucal_seed(tmp: Path):
    """The real imucal session's first 1,500 rows, labelled in a ``part`` column."""
    import pandas as pd

    real = REAL_IMUCAL
    df = pd.read_csv(real / "example_ferraris_session.csv", nrows=1500)
    df["part"] = np.where(np.arange(len(df)) < 800, "x_p", "x_a")
    path = tmp / "session.csv"
    df.to_csv(path, index=False)
    return path, path


def _daq_seed(suffix: str):
    def make(tmp: Path):
        import pandas as pd

        rng = np.random.default_rng(5)
        df = pd.DataFrame({"time_ms": np.arange(300) * 10.0, "X": rng.normal(0, 1, 300),
                           "Y": rng.normal(0, 1, 300), "Z": rng.normal(1, 1, 300)})
        path = tmp / f"daq{suffix}"
        if suffix == ".csv":
            df.to_csv(path, index=False, sep=";")
        else:
            df.to_parquet(path)
        return path, path

    return make


def _imu_tk_seed(tmp: Path):
    rng = np.random.default_rng(6)
    data = np.column_stack([np.arange(300) * 0.01, rng.normal(0, 3000, (300, 3))])
    path = tmp / "acc.txt"
    np.savetxt(path, data, fmt="%.9g", delimiter=" ")
    return path, path


def _noise_read(path):
    from accelcal.io.formats.noise import read

    return read(path)


def _thermal_read(path):
    from accelcal.io.formats.thermal import read

    return read(path)


def _steps_read(path):
    from accelcal.io.formats.acceptance import read

    return read(path)


def _centrifuge_read(path):
    from accelcal.io.formats.centrifuge import read

    return read(path)


def _response_read(path):
    from accelcal.io.formats.response import read

    return read(path)


def _triad_read(path):
    from accelcal.io.formats.triad import read

    return read(path)


def _daq_binary_seed(fmt: str):
    """A DAQ file written by its own library (helpers/daq_files.py): TDMS, HDF5, MAT v5, v7.3."""

    def make(tmp: Path):
        from helpers import daq_files

        acc, temp = daq_files.signals(n=600)
        writer, name = {"tdms": (daq_files.write_tdms, "run.tdms"),
                        "hdf5": (daq_files.write_hdf5, "run.h5"),
                        "mat": (daq_files.write_mat5, "run.mat"),
                        "mat73": (daq_files.write_mat73, "run73.mat")}[fmt]
        path = tmp / name
        writer(path, acc, temp)
        return path, path

    return make


def _model(path):
    from accelcal.model import ErrorModel

    return ErrorModel.load(path)


def _calibration_record(path):
    from accelcal.io.calibration_record import CalibrationRecord

    return CalibrationRecord.load(path)


def _lab(path):
    from accelcal.io.lab_metadata import read_lab_metadata

    return read_lab_metadata(path)


@dataclass(frozen=True)
class Reader:
    """One reader under fuzz.

    Attributes
    ----------
    read : callable
        ``read(path)``: the reader.
    seed : callable
        ``seed(tmp_dir) -> (path to read, file to mutate)``: writes a valid input.
    form : str
        ``"csv"``, ``"parquet"`` (record files) or ``"json"`` (documents).
    command : tuple of str, optional
        The command that consumes such a file, ``{file}`` and ``{out}`` (an
        output directory) substituted; run on every mutant the reader accepts.
    """

    read: Callable
    seed: Callable
    form: str
    command: tuple[str, ...] | None = None


_HEAD_CMD = ("dividing-head", "reduce", "{file}", "--format", "json",
             "--record", "{out}/rec.json")
_SHAKER_CMD = ("transverse", "fit", "{file}", "--format", "json", "--record", "{out}/rec.json")
_VRE_CMD = ("vre", "fit", "{file}", "--format", "json", "--record", "{out}/rec.json")
_TUMBLE_CMD = ("tumble", "reduce", "{file}", "--format", "json")
_NOISE_CMD = ("noise", "fit", "{file}", "--format", "json")
_CENTRIFUGE_CMD = ("centrifuge", "reduce", "{file}", "--format", "json", "--record",
                   "{out}/rec.json")
_STEPS_CMD = ("acceptance", "reduce", "{file}", "--format", "json")
_RESPONSE_CMD = ("response", "reduce", "{file}", "--format", "json")
_THERMAL_CMD = ("thermal", "reduce", "{file}", "--format", "json", "--record", "{out}/rec.json")

READERS: dict[str, Reader] = {
    "dividing-head.csv": Reader(_head, _example("indexing_head.csv"), "csv", _HEAD_CMD),
    "dividing-head.parquet": Reader(_head, _example("indexing_head.parquet"), "parquet",
                                    _HEAD_CMD),
    "shaker.csv": Reader(_shaker_read, _shaker(".csv"), "csv", _SHAKER_CMD),
    "shaker.parquet": Reader(_shaker_read, _shaker(".parquet"), "parquet", _SHAKER_CMD),
    "vibrafuge.csv": Reader(_vibrafuge, _example("vibrafuge.csv"), "csv", _VRE_CMD),
    "vibrafuge.parquet": Reader(_vibrafuge, _vibrafuge_parquet, "parquet", _VRE_CMD),
    "tumble.csv": Reader(_tumble_read, _tumble(".csv"), "csv", _TUMBLE_CMD),
    "tumble.parquet": Reader(_tumble_read, _tumble(".parquet"), "parquet", _TUMBLE_CMD),
    "noise.csv": Reader(_noise_read, _noise(".csv"), "csv", _NOISE_CMD),
    "noise.parquet": Reader(_noise_read, _noise(".parquet"), "parquet", _NOISE_CMD),
    "centrifuge.csv": Reader(_centrifuge_read, _centrifuge(".csv"), "csv", _CENTRIFUGE_CMD),
    "centrifuge.parquet": Reader(_centrifuge_read, _centrifuge(".parquet"), "parquet",
                                 _CENTRIFUGE_CMD),
    "thermal.csv": Reader(_thermal_read, _thermal(".csv"), "csv", _THERMAL_CMD),
    "thermal.parquet": Reader(_thermal_read, _thermal(".parquet"), "parquet", _THERMAL_CMD),
    "steps.csv": Reader(_steps_read, _steps(".csv"), "csv", _STEPS_CMD),
    "steps.parquet": Reader(_steps_read, _steps(".parquet"), "parquet", _STEPS_CMD),
    "response.csv": Reader(_response_read, _response(".csv"), "csv", _RESPONSE_CMD),
    "response.parquet": Reader(_response_read, _response(".parquet"), "parquet",
                               _RESPONSE_CMD),
    "triad.csv": Reader(_triad_read, _triad(".csv"), "csv"),
    "triad.parquet": Reader(_triad_read, _triad(".parquet"), "parquet"),
    "model": Reader(_model, _example("model.json"), "json",
                    ("model", "show", "{file}", "--format", "json")),
    "calibration-record": Reader(_calibration_record, _example("calibration_record.json"),
                                 "json", ("report", "{file}", "--out", "{out}/report.html")),
    "calibration-record.v1": Reader(_calibration_record,
                                    lambda tmp: (shutil.copy(FIXTURES / "calibration_record_v1"
                                                             ".json", tmp / "r.json"),) * 2,
                                    "json", ("records", "add", "{file}", "--db",
                                             "{out}/store.sqlite")),
    "recording.imucal": Reader(_recording(rate=102.4), _imucal_seed, "table"),
    "recording.csv": Reader(_recording(columns=("X", "Y", "Z"), time="time_ms", time_unit="ms",
                                       unit="g", delimiter=";"), _daq_seed(".csv"), "table"),
    "recording.parquet": Reader(_recording(columns=("X", "Y", "Z"), time="time_ms",
                                           time_unit="ms", unit="g"), _daq_seed(".parquet"),
                                "parquet"),
    "recording.imu_tk": Reader(_recording(unit="counts"), _imu_tk_seed, "text"),
    "recording.tdms": Reader(_recording(columns=("Accel/X", "Accel/Y", "Accel/Z")),
                             _daq_binary_seed("tdms"), "binary"),
    "recording.hdf5": Reader(_recording(columns=("daq/acc[0]", "daq/acc[1]", "daq/acc[2]"),
                                        time="daq/t"), _daq_binary_seed("hdf5"), "binary"),
    "recording.mat": Reader(_recording(columns=("data[0]", "data[1]", "data[2]"), rate=1000.0,
                                       unit="g"), _daq_binary_seed("mat"), "binary"),
    "recording.mat73": Reader(_recording(columns=("data[0]", "data[1]", "data[2]"),
                                         rate=1000.0, unit="g"), _daq_binary_seed("mat73"),
                              "binary"),
    "lab-metadata.csv": Reader(_lab, _example("indexing_head.csv"), "csv"),
    "lab-metadata.parquet": Reader(_lab, _example("indexing_head.parquet"), "parquet"),
}
"""Reader name -> :class:`Reader`. A new reader (or record kind) adds one line."""


# ------------------------------------------------------------------------------ mutations
DEEP = "[" * 100_000
LONG = '"' + "x" * 1_000_000 + '"'
EVIL_JSON = (
    "1e308", "-1e308", "NaN", "Infinity", "1e400", "9" * 400, "-1", "0", "2", "true", "null",
    "[]", '{"a": [1, {"b": null}]}', '""', '"x"', "[1e308, -1e308]", DEEP, LONG,
    '"\\u0000\\u001b[31m\\n\\u202e"', '"A/B\\\\C"',
)
"""Raw JSON texts that replace metadata values one at a time."""

EVIL_CELLS = (
    "1e308", "-1e308", "nan", "inf", "-Infinity", "1e400", "9" * 400, "1e-400", "true", "null",
    "", "[]", "0x10", "1_000", "\x00\x1b[31m", "x" * 1_000_000,
)
"""Cell texts that replace one CSV cell at a time (the Parquet equivalents: numbers)."""

EVIL_NUMBERS = (1e308, -1e308, math.nan, math.inf, -math.inf, 0.0, -1.0, 5e-324)


@dataclass(frozen=True)
class Mutant:
    """One mutated file: what was done, and how to make its bytes (lazily)."""

    description: str
    make: Callable[[bytes], bytes]


def _with_sentinel(doc, path, raw: str | None) -> str:
    """``doc`` as JSON text with the value at ``path`` replaced by raw text (None: deleted)."""
    doc = json.loads(json.dumps(doc))
    node = doc
    for key in path[:-1]:
        node = node[key]
    if raw is None:
        del node[path[-1]]
        return json.dumps(doc)
    node[path[-1]] = "@@SENTINEL@@"
    return json.dumps(doc).replace('"@@SENTINEL@@"', raw)


def _paths(doc, depth: int = 3, prefix=()) -> list[tuple]:
    """Paths of every value of a JSON document to ``depth`` (lists: first and last item)."""
    out = []
    if depth == 0:
        return out
    if isinstance(doc, dict):
        items = list(doc.items())
    elif isinstance(doc, list) and doc:
        items = sorted({0: doc[0], len(doc) - 1: doc[-1]}.items())
    else:
        return out
    for key, value in items:
        out.append((*prefix, key))
        out.extend(_paths(value, depth - 1, (*prefix, key)))
    return out


def _byte_mutants(seed: int) -> list[Mutant]:
    rng = random.Random(seed)
    out = [Mutant("empty file", lambda b: b""),
           Mutant("1 MB of NUL bytes", lambda b: b"\x00" * 2**20),
           Mutant("one 1 MB line prepended", lambda b: b"x" * 2**20 + b"\n" + b),
           Mutant("garbage appended", lambda b: b + b"\xff\xfe\x00\x1b[31m,,,\n")]
    for frac in (0.001, 0.01, 0.05, 0.2, 0.5, 0.9, 0.999):
        out.append(Mutant(f"truncated at {frac:.1%}", lambda b, f=frac: b[:int(len(b) * f)]))
    for i in range(24):
        pos_frac, flips = rng.random(), rng.choice((1, 1, 2, 8))
        values = [rng.randrange(256) for _ in range(flips)]

        def flip(b, pf=pos_frac, vals=tuple(values)):
            b = bytearray(b)
            for j, v in enumerate(vals):
                b[min(int(len(b) * pf) + 7 * j, len(b) - 1)] ^= v or 0xFF
            return bytes(b)

        out.append(Mutant(f"byte flip #{i} at {pos_frac:.3f} x{flips}", flip))
    return out


def _line_mutants(data: bytes) -> list[Mutant]:
    n = data.count(b"\n")
    picks = sorted({0, 1, 2, 3, 4, n // 2, n - 1} - {-1})
    out = []
    for i in picks:
        out.append(Mutant(f"line {i + 1} deleted",
                          lambda b, i=i: b"\n".join(x for j, x in enumerate(b.split(b"\n"))
                                                    if j != i)))
        out.append(Mutant(f"line {i + 1} duplicated",
                          lambda b, i=i: b"\n".join(y for j, x in enumerate(b.split(b"\n"))
                                                    for y in ((x, x) if j == i else (x,)))))
    out += [
        Mutant("data rows deleted", lambda b: b"\n".join(b.split(b"\n")[:3]) + b"\n"),
        Mutant("only one data row", lambda b: b"\n".join(b.split(b"\n")[:4]) + b"\n"),
        Mutant("data rows duplicated",
               lambda b: b + b"\n".join(b.split(b"\n")[3:])),
        Mutant("data rows reversed (time backwards)",
               lambda b: b"\n".join(b.split(b"\n")[:3] + b.split(b"\n")[3:][::-1]) + b"\n"),
        Mutant("CRLF line ends", lambda b: b.replace(b"\n", b"\r\n")),
        Mutant("CR line ends", lambda b: b.replace(b"\n", b"\r")),
        Mutant("no final newline", lambda b: b.rstrip(b"\n")),
        Mutant("marker line lower-cased", lambda b: b.replace(b"accelcal record", b"ACCELCAL", 1)),
    ]
    return out


def _csv_parts(data: bytes) -> tuple[bytes, dict, list[str], list[bytes]]:
    lines = data.split(b"\n")
    return lines[0], json.loads(lines[1][2:]), lines[2].decode().split(","), lines[3:]


def _csv_join(marker, meta_text: str, names, rows) -> bytes:
    return b"\n".join([marker, b"# " + meta_text.encode("utf-8", "surrogatepass"),
                       ",".join(names).encode("utf-8", "surrogatepass"), *rows])


def _metadata_mutants(meta: dict, rebuild: Callable[[str], bytes]) -> list[Mutant]:
    """Every metadata value (to depth 3) replaced by every evil JSON text; keys deleted,
    added; ``format_version``, ``kind`` and ``units`` abused."""
    out = []
    for path in _paths(meta):
        where = ".".join(map(str, path))
        values = EVIL_JSON if len(path) == 1 else EVIL_JSON[::3]
        for raw in values:
            out.append(Mutant(f"metadata {where} = {raw[:30]}",
                              lambda b, p=path, r=raw: rebuild(_with_sentinel(meta, p, r))))
        out.append(Mutant(f"metadata {where} deleted",
                          lambda b, p=path: rebuild(_with_sentinel(meta, p, None))))
    for raw in ('"x"', DEEP, "1e308", "NaN"):
        out.append(Mutant(f"metadata extra key = {raw[:30]}",
                          lambda b, r=raw: rebuild(_with_sentinel({**meta, "zz_extra": 0},
                                                                  ("zz_extra",), r))))
    units = meta.get("units")
    if isinstance(units, dict):
        for name in units:
            for raw in ('"furlong"', '"g"', '"deg"', '"1"', "null", "-1", '""'):
                out.append(Mutant(f"units.{name} = {raw}",
                                  lambda b, n=name, r=raw: rebuild(
                                      _with_sentinel(meta, ("units", n), r))))
    out.append(Mutant("metadata is a list", lambda b: rebuild("[1, 2]")))
    out.append(Mutant("metadata is not JSON", lambda b: rebuild("{not json")))
    out.append(Mutant("metadata has duplicate keys",
                      lambda b: rebuild(json.dumps(meta)[:-1] + ', "format_version": 2}')))
    return out


def _cell_mutants(names, rows, rebuild_rows: Callable[[list[str], list[bytes]], bytes]):
    """Cells replaced by evil text (first and middle row, every column); columns dropped,
    added, renamed, duplicated."""
    out = []
    body = [r for r in rows if r.strip()]
    for col, name in enumerate(names):
        for row in sorted({0, len(body) // 2}):
            for cell in EVIL_CELLS:
                def make(b, col=col, row=row, cell=cell):
                    new = list(body)
                    cells = new[row].decode().split(",")
                    cells[col] = cell
                    new[row] = ",".join(cells).encode("utf-8", "surrogatepass")
                    return rebuild_rows(names, [*new, b""])

                out.append(Mutant(f"cell {name}[{row}] = {cell[:20]!r}", make))

        def drop(b, col=col):
            new_names = [n for j, n in enumerate(names) if j != col]
            new = [b",".join(c for j, c in enumerate(r.split(b",")) if j != col) for r in body]
            return rebuild_rows(new_names, [*new, b""])

        out.append(Mutant(f"column {name} deleted", drop))
        out.append(Mutant(f"column {name} renamed",
                          lambda b, col=col: rebuild_rows(
                              [n + "_x" if j == col else n for j, n in enumerate(names)],
                              [*body, b""])))
        out.append(Mutant(f"column {name} named twice",
                          lambda b, col=col, twin=name: rebuild_rows(
                              [twin if j == (col + 1) % len(names) else n
                               for j, n in enumerate(names)], [*body, b""])))
    out.append(Mutant("extra column", lambda b: rebuild_rows(
        [*names, "extra"], [r + b",1" for r in body] + [b""])))
    out.append(Mutant("extra cells, no extra name", lambda b: rebuild_rows(
        names, [r + b",1" for r in body] + [b""])))
    return out


def csv_mutants(data: bytes) -> list[Mutant]:
    marker, meta, names, rows = _csv_parts(data)
    out = _byte_mutants(1) + _line_mutants(data)
    out += _metadata_mutants(meta, lambda text: _csv_join(marker, text, names, rows))
    out += _cell_mutants(names, rows,
                         lambda nn, rr: _csv_join(marker, json.dumps(meta), nn, rr))
    return out


def parquet_mutants(data: bytes) -> list[Mutant]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(io.BytesIO(data))
    own = table.schema.metadata and b"accelcal" in table.schema.metadata
    meta = json.loads(table.schema.metadata[b"accelcal"]) if own else {}

    def write(t) -> bytes:
        sink = io.BytesIO()
        pq.write_table(t, sink)
        return sink.getvalue()

    def rebuild(text: str) -> bytes:
        return write(table.replace_schema_metadata({"accelcal": text}))

    out = _byte_mutants(2) + (_metadata_mutants(meta, rebuild) if own else [])
    keep = table.schema.metadata
    for name in table.column_names:
        col = table.column(name).to_numpy()
        for value in EVIL_NUMBERS:
            for row in sorted({0, col.size // 2}):
                def cell(b, name=name, row=row, value=value, col=col):
                    new = np.array(col, dtype=float)
                    new[row] = value
                    return write(table.set_column(table.column_names.index(name), name,
                                                  pa.array(new)).replace_schema_metadata(keep))

                out.append(Mutant(f"cell {name}[{row}] = {value!r}", cell))
        for label, array in (("as strings", pa.array([str(v) for v in col])),
                             ("as int64", pa.array(np.zeros(col.size, dtype=np.int64))),
                             ("as booleans", pa.array(np.zeros(col.size, dtype=bool))),
                             ("all null", pa.nulls(col.size, pa.float64())),
                             ("with a null", pa.array([None, *col[1:].tolist()],
                                                      type=pa.float64())),
                             ("as lists", pa.array([[float(v)] for v in col])),
                             ("reversed", pa.array(np.asarray(col)[::-1]))):
            out.append(Mutant(f"column {name} {label}",
                              lambda b, name=name, array=array: write(table.set_column(
                                  table.column_names.index(name), name, array
                              ).replace_schema_metadata(keep))))
        out.append(Mutant(f"column {name} deleted", lambda b, name=name: write(
            table.drop_columns([name]).replace_schema_metadata(keep))))
    out.append(Mutant("extra column", lambda b: write(
        table.append_column("extra", pa.array(np.ones(table.num_rows)))
        .replace_schema_metadata(keep))))
    out.append(Mutant("no rows", lambda b: write(table.slice(0, 0))))
    out.append(Mutant("one row", lambda b: write(table.slice(0, 1))))
    out.append(Mutant("no schema metadata", lambda b: write(table.replace_schema_metadata({}))))
    out.append(Mutant("rows reversed (time backwards)", lambda b: write(
        table.take(pa.array(np.arange(table.num_rows)[::-1])))))
    return out


def json_mutants(data: bytes) -> list[Mutant]:
    doc = json.loads(data)

    def rebuild(text: str) -> bytes:
        return text.encode("utf-8", "surrogatepass")

    out = _byte_mutants(3) + _metadata_mutants(doc, rebuild)
    out += [
        Mutant("document nested 100,000 deep", lambda b: DEEP.encode()),
        Mutant("document wrapped in a list", lambda b: b"[" + b + b"]"),
        Mutant("trailing garbage", lambda b: b + b"}}"),
        Mutant("UTF-16", lambda b: b.decode().encode("utf-16")),
        Mutant("BOM", lambda b: b"\xef\xbb\xbf" + b),
    ]
    return out


def table_mutants(data: bytes) -> list[Mutant]:
    """A lab's table (a header line, then rows; no accelcal metadata)."""
    text = data.decode()
    delimiter = ";" if ";" in text.split("\n")[0] else ","
    lines = data.split(b"\n")
    names = lines[0].decode().split(delimiter)

    def rebuild_rows(nn, rows):
        body = [r.replace(b",", delimiter.encode()) for r in rows]
        return b"\n".join([delimiter.join(nn).encode("utf-8", "surrogatepass"), *body])

    rows = [r.replace(delimiter.encode(), b",") for r in lines[1:]]
    return _byte_mutants(4) + _line_mutants(data) + _cell_mutants(names, rows, rebuild_rows)


def text_mutants(data: bytes) -> list[Mutant]:
    """A headerless text table (imu_tk): bytes, lines and cells."""
    lines = data.split(b"\n")
    width = len(lines[0].split())
    names = [f"c{k}" for k in range(width)]
    rows = [b",".join(r.split()) for r in lines]
    return (_byte_mutants(5) + _line_mutants(data)
            + _cell_mutants(names, rows, lambda nn, rr: b"\n".join(r.replace(b",", b" ")
                                                                   for r in rr)))


def binary_mutants(data: bytes) -> list[Mutant]:
    """A DAQ's binary file (TDMS, HDF5, MAT): truncations and byte flips (96 of them)."""
    flips = [m for seed in (7, 8, 9) for m in _byte_mutants(seed)
             if m.description.startswith("byte flip")]
    return _byte_mutants(6) + [Mutant(f"{m.description} (set {k // 24 + 2})", m.make)
                               for k, m in enumerate(flips)]


MUTANTS = {"csv": csv_mutants, "parquet": parquet_mutants, "json": json_mutants,
           "table": table_mutants, "text": text_mutants, "binary": binary_mutants}


# ------------------------------------------------------------------------------ running
class _Timeout(BaseException):
    """Raised by the alarm: a BaseException, so no reader's ``except Exception`` eats it."""


@contextlib.contextmanager
def time_limit(seconds: float):
    def alarm(signum, frame):
        raise _Timeout

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def snapshot(directory: Path) -> dict:
    return {str(p.relative_to(directory)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(directory.rglob("*"))}


def _last_lines(exc: BaseException, n: int = 3) -> str:
    lines = traceback.format_exception(exc)
    return " | ".join(line.strip().replace("\n", " ") for line in lines[-n:])[:600]


def read_one(reader: Reader, target: Path, root: Path) -> tuple[str | None, object]:
    """Run the reader once: (problem or None, result or None)."""
    before = snapshot(root)
    start = time.perf_counter()
    result = None
    problem = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with time_limit(TIME_LIMIT):
                result = reader.read(target)
        except AccelcalError as exc:
            text = str(exc)
            if "\n" in text or len(text) > MAX_MESSAGE_CHARS:
                problem = (f"AccelcalError message of {len(text)} characters, "
                           f"{text.count(chr(10)) + 1} lines: {text[:120]!r}")
        except _Timeout:
            problem = f"no answer within {TIME_LIMIT} s"
        except Exception as exc:
            problem = f"{type(exc).__name__}: {_last_lines(exc)}"
    if problem is None and caught:
        w = caught[0]
        problem = f"warning {w.category.__name__}: {w.message} ({Path(w.filename).name}:{w.lineno})"
    elapsed = time.perf_counter() - start
    if problem is None and elapsed > TIME_LIMIT:
        problem = f"took {elapsed:.1f} s"
    if problem is None and snapshot(root) != before:
        problem = "the reader wrote or changed files"
    return problem, result


_NON_FINITE = re.compile(r"\b(NaN|-?Infinity|-?inf|nan)\b")


def run_command(reader: Reader, target: Path, out: Path, capsys) -> str | None:
    """The consuming command on an accepted file: a problem, or None."""
    from accelcal.cli import main

    args = [a.format(file=target, out=out) for a in reader.command]
    capsys.readouterr()
    code = None
    problem = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with time_limit(COMMAND_TIME_LIMIT):
                main(args)
        except SystemExit as exc:
            code = exc.code
        except _Timeout:
            problem = f"no answer within {COMMAND_TIME_LIMIT} s"
        except BaseException as exc:
            problem = f"{type(exc).__name__}: {_last_lines(exc)}"
    stdout, stderr = capsys.readouterr()
    if problem:
        return problem
    if caught:
        w = caught[0]
        return f"warning {w.category.__name__}: {w.message} ({Path(w.filename).name}:{w.lineno})"
    if code == 2:
        if not stderr.startswith("accelcal: error: ") or stderr.count("\n") != 1:
            return f"exit 2 but stderr is {stderr[:300]!r}"
        return None
    if code not in (0, None):
        return f"exit {code}: {stderr[-300:]!r}"
    if "Traceback" in stderr:
        return f"traceback on stderr: {stderr[-300:]!r}"
    bad = _NON_FINITE.search(stdout)
    if bad:
        i = bad.start()
        return ("exit 0 with a non-finite number in the output: "
                f"...{stdout[max(0, i - 80):i + 20]!r}")
    return unstated_uncertainty(stdout)


def fuzz(reader_name: str, tmp_path: Path, capsys, select: Callable[[str], bool]) -> list[str]:
    reader = READERS[reader_name]
    seed_dir = tmp_path / "seed"
    seed_dir.mkdir()
    target, victim = reader.seed(seed_dir)
    original = victim.read_bytes()
    problem, _ = read_one(reader, target, seed_dir)
    assert problem is None, f"the valid seed file fails: {problem}"
    failures = []
    for mutant in MUTANTS[reader.form](original):
        if not select(mutant.description):
            continue
        victim.write_bytes(mutant.make(original))
        problem, result = read_one(reader, target, seed_dir)
        if problem is None and result is not None and reader.command:
            out = tmp_path / "out"
            out.mkdir(exist_ok=True)
            problem = run_command(reader, target, out, capsys)
            if problem:
                problem = f"`accelcal {' '.join(reader.command)}`: {problem}"
            shutil.rmtree(out)
        if problem:
            failures.append(f"{reader_name} / {mutant.description}: {problem}")
    victim.write_bytes(original)
    return failures


FAMILIES = {
    "bytes": lambda d: d.startswith(("empty", "1 MB", "one 1 MB", "garbage", "truncated",
                                     "byte flip")),
    "lines": lambda d: d.startswith(("line", "data rows", "only one", "CR", "no final",
                                     "marker", "document", "trailing", "UTF-16", "BOM")),
    "metadata": lambda d: d.startswith(("metadata", "units")),
    "cells": lambda d: d.startswith(("cell", "column", "extra", "no rows", "one row",
                                     "no schema", "rows reversed")),
}
"""Mutation families: one test per reader and family (descriptions by prefix)."""


@pytest.mark.slow
@pytest.mark.parametrize("family", list(FAMILIES))
@pytest.mark.parametrize("reader", list(READERS))
def test_reader_refuses_bad_files_cleanly(reader, family, tmp_path, capsys):
    failures = fuzz(reader, tmp_path, capsys, FAMILIES[family])
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(failures[:200])


@pytest.mark.parametrize("form", list(MUTANTS))
def test_every_mutant_belongs_to_one_family(form, tmp_path):
    reader = next(r for r in READERS.values() if r.form == form)
    _, victim = reader.seed(tmp_path)
    for m in MUTANTS[form](victim.read_bytes()):
        assert sum(f(m.description) for f in FAMILIES.values()) == 1, m.description


def test_every_record_kind_has_readers():
    from accelcal.io.formats import KINDS

    for kind in KINDS:
        for suffix in ("csv", "parquet"):
            assert f"{kind}.{suffix}" in READERS, f"{kind}.{suffix}: add a line to READERS"


def test_the_checks_catch_what_they_should(tmp_path, monkeypatch):
    target = tmp_path / "f.csv"
    target.write_text("x")

    def writes(path):
        (Path(path).parent / "side.txt").write_text("y")

    def wrong_error(path):
        raise ValueError("boom")

    def hangs(path):
        time.sleep(10)

    def warns(path):
        return np.float64(1e308) * 10

    def long_message(path):
        raise AccelcalError("x" * 5000)

    monkeypatch.setattr(sys.modules[__name__], "TIME_LIMIT", 0.2)
    for read, expected in ((writes, "wrote or changed"), (wrong_error, "ValueError"),
                           (hangs, "no answer"), (warns, "RuntimeWarning"),
                           (long_message, "5000 characters")):
        problem, _ = read_one(Reader(read, None, "csv"), target, tmp_path)
        assert problem is not None, read.__name__
        assert expected in problem, problem
    assert read_one(Reader(lambda p: 1, None, "csv"), target, tmp_path) == (None, 1)
    rows = json.dumps([{"coefficient": "K1", "estimate": 1.0, "std": None, "status": "fitted"}])
    assert "no finite std" in unstated_uncertainty(rows)
    assert unstated_uncertainty(json.dumps([{"std": None, "status": "not identifiable"}])) is None
