"""The end-to-end demonstration: a simulated calibration campaign, reduced and reported.

:func:`run` simulates three tests of the embedded default accelerometer
(serial ``ACC-0001``) and three companions, writes every input file the way
a laboratory would (record files with serial numbers, operator, date and
local gravity), reads them back, reduces them, writes one calibration record
per sensor and test, adds the records to the store and writes a
self-contained HTML report with its figures:

1. indexing head (Dong2014): four sensors at mount phases 0, 90, 180 and
   270 deg, 24 positions, head error uniform within ±2 arcsec plus the first
   harmonic Dong2014 measured (given in the file as measured, SD 5e-7 rad),
   output noise 2.8e-6 V (Dong2014 Table 1); joint reduction;
2. shaker (GuanTang): 5 g at 160 Hz along 12 directions 30 deg apart, 16
   periods at 10240 Hz; k_o, k_p, k_oo, k_pp, k_op from the w and 2w
   phasors;
3. vibrafuge (Guan2021): overloads 1, 2, 4 g times amplitudes 5..10 g at
   50 Hz, 1 s records at 5000 Hz; K2, K3, K0', K1' by weighted least squares.

The four sensors on the head are the default accelerometer and three
variants whose indexing-head coefficients (K_F, K_I, K_O, K_IO, K_II) are
Dong2014 Table 1's sensors 2-4; their other terms are the default's. The
shaker and the vibrafuge test ``ACC-0001`` only. Terms outside Dong2014
eq. (5) (Koo, Kpp, K3, the asymmetry) fold into the head's K_F, K_I and
K_II by a few µV, as they would in a real test: the head reports the
eq. (5) projection of each sensor.

Every run is stamped with the current time (microseconds), which goes into
the files' ``date`` and so into the records: running the demo twice adds
new, distinct records to the store, and the report then shows the history.
Without a seed each run draws fresh errors and noise (the seed is printed,
so a run can be repeated), and the history shows a repeatability.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, Table 1.
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021.
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers.
"""

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError

SERIALS = ("ACC-0001", "ACC-0002", "ACC-0003", "ACC-0004")
"""Serial numbers of the demo's four accelerometers (ACC-0001 is the default model)."""

OPERATOR = "accelcal demo"
LOCAL_GRAVITY = 9.80665
"""Local gravity written into the demo files, m/s^2 (standard gravity)."""

HEAD_POSITIONS = 24
HEAD_ANGLE_ERROR_ARCSEC = 2.0
FIRST_HARMONIC_SD_RAD = 5e-7
"""SD of the measured first harmonic (Dong2014 section 3 gives 5e-7 rad)."""

SHAKER = {"amplitude": 5.0, "frequency": 160.0, "sample_rate": 10240.0, "periods": 16.0}
SHAKER_ANGLES_DEG = np.arange(0.0, 360.0, 30.0)
VRE_OVERLOADS = (1.0, 2.0, 4.0)
VRE_AMPLITUDES = (5.0, 6.0, 7.0, 8.0, 9.0, 10.0)
VRE = {"frequency": 50.0, "sample_rate": 5000.0, "duration": 1.0}

STAGES = (
    "simulating the indexing head", "simulating the shaker sweep",
    "simulating the vibrafuge grid", "reducing the indexing head",
    "reducing the shaker records", "reducing the vibrafuge records",
    "writing calibration records", "adding records to the store", "writing the report",
)


@dataclass(frozen=True)
class DemoResult:
    """What the demo wrote.

    Attributes
    ----------
    out : pathlib.Path
        The output directory.
    data : list of pathlib.Path
        Input files (the indexing-head file, the shaker directory, the
        vibrafuge file).
    records : list of pathlib.Path
        Calibration records.
    report : pathlib.Path
        The HTML report.
    figures : list of pathlib.Path
        The report's figures as SVG files.
    store : str
        The store the records were added to.
    record_ids : list of int
        Their ids in the store.
    seed : int
        The seed of the simulation.
    seconds : float
        Wall-clock time of the run.
    """

    out: Path
    data: list
    records: list
    report: Path
    figures: list
    store: str
    record_ids: list = field(default_factory=list)
    seed: int = 0
    seconds: float = 0.0


def head_models():
    """The four sensors on the head: the default model and Dong2014 Table 1's sensors 2-4.

    References
    ----------
    .. [1] Dong2014, Table 1 (B_z): K_F, K_I, K_O, K_IO, K_II of sensors 2-4.
    """
    from accelcal.defaults import default_model
    from accelcal.model import ErrorModel
    from accelcal.rigs.dividing_head import DONG2014_TABLE1

    base = default_model()
    models = [base]
    for row in DONG2014_TABLE1[1:]:
        dong = ErrorModel.from_dong2014(**row)
        models.append(base.replace(K0=dong.K0, K1=dong.K1, Ko=dong.Ko, Kio=dong.Kio, K2=dong.K2))
    return tuple(models)


def _lab(date: str, serial) -> dict:
    return {"serial": serial, "operator": OPERATOR, "date": date, "local_gravity": LOCAL_GRAVITY}


def _progress(enabled: bool):
    """A rich progress bar on stderr (a no-op stand-in when disabled)."""
    if not enabled:
        return None
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("[bold]{task.description:<32}"), BarColumn(),
                    TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(),
                    console=Console(stderr=True))


def run(out="accelcal-demo", *, db=None, seed: int | None = None, progress: bool = True
        ) -> DemoResult:
    """Simulate, reduce, record, store and report a full calibration campaign.

    Parameters
    ----------
    out : path-like
        Output directory (created): ``data/``, ``records/``, ``figures/`` and
        ``report.html``.
    db : str, optional
        Store (SQLite path or database URL); default the user's store.
    seed : int, optional
        Seed of every simulated error and noise; default a fresh one (written
        to the result and the report, so a run can be repeated exactly).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    DemoResult
    """
    from accelcal.calibration import now

    start = time.perf_counter()
    out = Path(out)
    try:
        for sub in ("data", "records", "figures"):
            (out / sub).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccelcalError(f"--out {out}: cannot create the demo directories ({exc})") from None
    date = now()
    if seed is None:  # a fresh, short seed the user can type back in
        seed = int(np.random.SeedSequence().entropy % 1_000_000)
    seeds = np.random.SeedSequence(seed).spawn(3)
    bar = _progress(progress)
    steps = _Steps(bar)
    with bar if bar is not None else _Null():
        head_file = steps(STAGES[0], _simulate_head, out / "data" / "indexing_head.csv", date,
                          seeds[0])
        shaker_dir = steps(STAGES[1], _simulate_shaker, out / "data" / "shaker", date, seeds[1])
        vre_file = steps(STAGES[2], _simulate_vibrafuge, out / "data" / "vibrafuge.csv", date,
                         seeds[2])
        head = steps(STAGES[3], _reduce_head, head_file)
        shaker = steps(STAGES[4], _reduce_shaker, shaker_dir)
        vre = steps(STAGES[5], _reduce_vibrafuge, vre_file)
        records = steps(STAGES[6], _write_records, out / "records", head, shaker, vre)
        store_url, ids = steps(STAGES[7], _store, db, [r for _, r in records])
        report, figures = steps(STAGES[8], lambda: _report(out, db, head, shaker, vre,
                                                           seed=seed))
    return DemoResult(out=out, data=[head_file, shaker_dir, vre_file],
                      records=[p for p, _ in records], report=report, figures=figures,
                      store=store_url, record_ids=ids, seed=seed,
                      seconds=time.perf_counter() - start)


class _Null:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class _Steps:
    """Runs the stages in order, advancing one progress task."""

    def __init__(self, bar) -> None:
        self.bar = bar
        self.task = None if bar is None else bar.add_task(STAGES[0], total=len(STAGES))

    def __call__(self, stage, function, *args):
        if self.bar is not None:
            self.bar.update(self.task, description=stage)
        result = function(*args)
        if self.bar is not None:
            self.bar.advance(self.task)
        return result


# ---------------------------------------------------------------- simulation
def _simulate_head(path: Path, date: str, seed) -> Path:
    import json

    from accelcal.io.dividing_head import write_head_record
    from accelcal.rigs.dividing_head import (
        DONG2014_FIRST_HARMONIC,
        DONG2014_NOISE_V,
        AngleErrorProfile,
        DividingHeadRig,
        simulate,
    )
    from accelcal.units import ARCSEC

    models = head_models()
    rig = DividingHeadRig.uniform(
        HEAD_POSITIONS, models, angle_error=AngleErrorProfile.uniform(
            HEAD_ANGLE_ERROR_ARCSEC * ARCSEC),
        first_harmonic=DONG2014_FIRST_HARMONIC, noise=DONG2014_NOISE_V,
    )
    sim = simulate(rig, np.random.default_rng(seed))
    write_head_record(
        path, rig.positions, sim.outputs, rig.mounts, sensors=[f"U{k + 1}" for k in range(4)],
        output_unit="V", nominal_scale_factors=[m.K1 for m in models],
        first_harmonic=DONG2014_FIRST_HARMONIC, first_harmonic_sd=FIRST_HARMONIC_SD_RAD,
        simulation={"models": [json.loads(m.to_json()) for m in models],
                    "eta_rad": rig.eta.tolist(), "angle_error_rad": sim.d_alpha.tolist(),
                    "seed": str(seed.entropy),
                    "description": "accelcal demo: uniform +-2 arcsec head error plus "
                                   "Dong2014's first harmonic, noise 2.8e-6 V"},
        lab=_lab(date, list(SERIALS)),
    )
    return path


def _simulate_shaker(directory: Path, date: str, seed) -> Path:
    import shutil

    from accelcal.defaults import default_model
    from accelcal.methods.transverse import axial_sensitivity
    from accelcal.rigs.shaker import ShakerRig, write_records

    model = default_model()
    records = ShakerRig(**SHAKER).simulate(model, np.deg2rad(SHAKER_ANGLES_DEG),
                                           rng=np.random.default_rng(seed))
    if directory.exists():
        shutil.rmtree(directory)
    extra = {"axial_sensitivity": {d: axial_sensitivity(model, d) for d in ("eq20", "symmetric")},
             "source": "accelcal demo", **_lab(date, SERIALS[0])}
    write_records(records, directory, extra=extra)
    return directory


def _simulate_vibrafuge(path: Path, date: str, seed) -> Path:
    from accelcal.defaults import default_model
    from accelcal.methods.vre_records import write_vibrafuge
    from accelcal.rigs.vibrafuge import simulate

    model = default_model()
    b, a = (x.ravel() for x in np.meshgrid(VRE_OVERLOADS, VRE_AMPLITUDES, indexing="ij"))
    run_ = simulate(model, b, a, rng=np.random.default_rng(seed), **VRE)
    write_vibrafuge(path, run_, provenance={"simulated_model": model.terms(),
                                            **_lab(date, SERIALS[0])})
    return path


# ----------------------------------------------------------------- reduction
@dataclass(frozen=True)
class _Head:
    file: Path
    record: object
    result: object
    records: list


def _reduce_head(path: Path) -> _Head:
    from accelcal.calibration import head_records, lab_info
    from accelcal.io.dividing_head import read_head_record
    from accelcal.methods.dividing_head import reduce

    rec = read_head_record(path)
    result = reduce(rec.data(), "joint", first_harmonic=tuple(rec.first_harmonic),
                    first_harmonic_sd=rec.first_harmonic_sd)
    info = lab_info([path], sensors=len(rec.sensors))
    return _Head(path, rec, result, head_records(result, info, sensor_names=rec.sensors,
                                                 input_files=[path]))


def _reduce_shaker(directory: Path):
    from accelcal.calibration import lab_info, shaker_files, transverse_record
    from accelcal.methods.transverse import identify
    from accelcal.rigs.shaker import read_records

    files = shaker_files(directory)
    info = lab_info([f for group in files.values() for f in group])
    out = []
    for rec in read_records(directory):
        est = identify(rec, route="2w")
        out.append((rec, est, transverse_record(est, info, amplitude=rec.amplitude,
                                                input_files=files[rec.amplitude])))
    return out


def _reduce_vibrafuge(path: Path):
    from accelcal.calibration import lab_info, vre_record
    from accelcal.methods.vre import PAPER_TERMS, identify
    from accelcal.methods.vre_records import read_vibrafuge, reduce_run

    measurement = reduce_run(read_vibrafuge(path))
    fit = identify(measurement.overload, measurement.amplitude, measurement.vre,
                   measurement.uncertainty, direction=measurement.direction, terms=PAPER_TERMS)
    return measurement, fit, vre_record(fit, lab_info([path]), input_files=[path])


# ------------------------------------------------------- records, store, report
def _write_records(directory: Path, head: _Head, shaker, vre):
    from accelcal.calibration import save_records

    written = []
    for rec in head.records:
        written += [(p, rec) for p in save_records([rec], directory / f"{rec.serial}-head.json")]
    for _, _, rec in shaker:
        written += [(p, rec) for p in save_records(
            [rec], directory / f"{rec.serial}-shaker-{_amp(rec)}.json")]
    written += [(p, vre[2]) for p in save_records([vre[2]], directory /
                                                  f"{vre[2].serial}-vibrafuge.json")]
    return written


def _amp(record) -> str:
    note = next((n for n in record.notes if n.startswith("shaker vibration amplitude")), "")
    return note.removeprefix("shaker vibration amplitude ").replace(" ", "")


def _store(db, records):
    import sqlalchemy as sa

    from accelcal.store import Store

    with Store(db) as store:
        ids = [store.add(r) for r in records]
        return sa.make_url(store.url).render_as_string(hide_password=True), ids


def _report(out: Path, db, head: _Head, shaker, vre, *, seed: int):
    from accelcal.io.atomic import write_text_atomic
    from accelcal.report import write_report
    from accelcal.report.sections import (
        head_sections,
        history_section,
        transverse_section,
        vre_section,
    )
    from accelcal.store import Store

    truth = None
    if head.record.simulation:
        truth = np.asarray(head.record.simulation["angle_error_rad"], dtype=float)
    sections = head_sections(head.result, head.records, sensor_names=head.record.sensors,
                             positions=head.record.positions, truth=truth)
    sections += [transverse_section(est, rec, records) for records, est, rec in shaker]
    measurement, fit, record = vre
    sections.append(vre_section(fit, record, measurement))
    with Store(db) as store:
        history = history_section(store, SERIALS[0], method=head.records[0].method)
    if history is not None:
        sections.append(history)
    report = out / "report.html"
    write_report(report, sections, title="Accelerometer calibration campaign (demo)",
                 subtitle=f"Simulated campaign of {', '.join(SERIALS)}: indexing head, shaker "
                          "transverse sweep and vibrafuge grid; operator "
                          f"{OPERATOR}, date {head.records[0].date}, seed {seed}.")
    figures = []
    for i, section in enumerate(sections, 1):
        for j, fig in enumerate(section.figures, 1):
            path = out / "figures" / f"{i:02d}-{j}-{_slug(fig.title)}.svg"
            write_text_atomic(path, fig.svg)
            figures.append(path)
    return report, figures


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in text.lower()).strip("-")
