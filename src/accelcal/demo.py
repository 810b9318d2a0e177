"""The end-to-end demonstration: a simulated calibration campaign, reduced and reported.

:func:`run` runs the campaign of :mod:`accelcal.pipeline` with one stage per
test method, on the embedded default accelerometer (serial ``ACC-0001``)
and three companions: every input file is written the way a laboratory
would (record files with serial numbers, operator, date and local gravity),
read back, reduced, recorded (one calibration record per sensor and test),
stored, and reported in one self-contained HTML report with its figures.
The stages, each in its method's package:

1. indexing head (:mod:`accelcal.methods.dividing_head.demo`, Dong2014):
   four sensors, 24 positions, joint reduction;
2. shaker (:mod:`accelcal.methods.transverse.demo`, GuanTang): 5 g along 12
   directions; cross-axis coefficients from the w and 2w phasors;
3. vibrafuge (:mod:`accelcal.methods.vre.demo`, Guan2021): overloads 1, 2,
   4 g times amplitudes 5..10 g; K2, K3, K0', K1';
4. still recording (:mod:`accelcal.methods.noise.demo`, IEEE 952): Allan
   deviation with confidence intervals and the noise coefficients;
5. thermal chamber (:mod:`accelcal.methods.thermal.demo`): multipoint
   tumbles at temperature plateaus, the temperature coefficients, hysteresis
   and warm-up, and the compensation model;
6. centrifuge (:mod:`accelcal.methods.centrifuge.demo`, IEEE 836): levels
   up to 50 g with IA inward, outward and tangential, reduced jointly with a
   1 g tumble of the same sensor (K2, K3, K4, cross-coupling, radius error);
7. triad (:mod:`accelcal.methods.triad.demo`, Tedaldi2014): a three-axis
   housing on 18 static positions, bias, scale factor and non-orthogonality
   by the known-orientation and the gravity-norm routes;
8. acceptance tests (:mod:`accelcal.methods.acceptance.demo`, IEEE 1293):
   the threshold on the indexing head, the input range on a centrifuge
   (saturation, clipping, the bias after the overload) and eight turn-ons;
9. shaker frequency response (:mod:`accelcal.methods.response.demo`, ISO
   16063-21): a stepped-sine comparison with a reference, 10 Hz to 1.25
   kHz, and the second-order fit (|S(80 Hz)| and the bandwidth in the
   store's history).

Before the report, :func:`demo_budgets` writes the demo's lab file (a copy
of examples/lab.toml kept in the package) and makes the uncertainty budgets
of the indexing-head sensors (:func:`head_budgets`) and of the frequency
response (each step's magnitude and phase, the fitted model): the report
states them (the summary's U and k, an annex). After the campaign,
:func:`certify` shows the budget of one result and writes a calibration
certificate of the indexing-head sensors and the frequency response (HTML,
JSON, and PDF where WeasyPrint is installed) from the same budgets.

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

from dataclasses import dataclass, replace
from pathlib import Path

from accelcal.certificate.content import Item
from accelcal.io.atomic import write_text_atomic
from accelcal.pipeline import CampaignResult

SERIALS = ("ACC-0001", "ACC-0002", "ACC-0003", "ACC-0004")
"""Serial numbers of the demo's four accelerometers (ACC-0001 is the default model)."""

TRIAD_SERIAL = "IMU-0001"
"""Serial number of the demo's accelerometer triad (one housing of three axes)."""

OPERATOR = "accelcal demo"
LOCAL_GRAVITY = 9.80665
"""Local gravity written into the demo files, m/s^2 (standard gravity)."""


def lab(date: str, serial) -> dict:
    """The laboratory metadata the demo writes into its files (marked as simulated)."""
    return {"serial": serial, "operator": OPERATOR, "date": date, "local_gravity": LOCAL_GRAVITY,
            "simulated": True}


def stages() -> list:
    """The demo's tests, in order: each method's stage, named by its descriptor.

    A method takes part in the demo through its descriptor
    (:data:`accelcal.catalog.METHODS`: ``demo``, ``demo_order``,
    ``demo_sensors``); its stage builder gets the sensors it tests and
    :func:`lab`.
    """
    import importlib

    from accelcal.catalog import demo_methods

    sensors = {"four": SERIALS, "one": SERIALS[0], "triad": TRIAD_SERIAL}
    return [getattr(importlib.import_module(m.demo), m.demo_callable)(sensors[m.demo_sensors], lab)
            for m in demo_methods()]


def run(out="accelcal-demo", *, db=None, seed: int | None = None, progress: bool = True
        ) -> CampaignResult:
    """Simulate, reduce, record, store and report the demo campaign.

    Parameters
    ----------
    out : path-like
        Output directory (created): ``data/``, ``records/``, ``figures/``,
        ``report.html`` and the store ``records.sqlite``.
    db : str, optional
        Store (SQLite path or database URL); default ``records.sqlite`` inside
        ``out``, never the user's records store (simulated calibrations must
        not mix with a laboratory's).
    seed : int, optional
        Seed of every simulated error and noise; default a fresh one (written
        to the result and the report, so a run can be repeated exactly).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    accelcal.pipeline.CampaignResult
    """
    from accelcal.catalog import demo_methods, listed
    from accelcal.pipeline import run_campaign

    return run_campaign(
        stages(), out, db=db, seed=seed, progress=progress,
        title="Accelerometer calibration campaign (demo)",
        subtitle=(f"Simulated campaign of {', '.join(SERIALS)} and the triad {TRIAD_SERIAL}: "
                  f"{listed((m.demo_test for m in demo_methods()), 'and')}; "
                  f"operator {OPERATOR}, date {{date}}, seed {{seed}}."),
        history_serial=SERIALS[0], budgets=demo_budgets,
    )


def head_budgets(out, outcomes, data) -> dict:
    """Write the demo's lab file and make the budgets of the indexing head's sensors.

    Parameters
    ----------
    out : path-like
        The campaign's output directory (``lab.toml`` is written there).
    outcomes : list of Outcome
        The campaign's reductions, in stage order.
    data : list of path
        The input file of each stage.

    Returns
    -------
    dict
        ``(serial, method) -> list of Budget``, named by the records' serial
        numbers (the report's summary and annex, the certificate).
    """
    from importlib.resources import files

    from accelcal.budget import budgets
    from accelcal.budget.lab import load_lab
    from accelcal.catalog import demo_methods

    lab_path = Path(out) / "lab.toml"
    write_text_atomic(lab_path, files("accelcal.certificate").joinpath(
        "example_lab.toml").read_text(encoding="utf-8"))
    head = next(o for o in outcomes if o.reduction.family == "dividing-head")
    stage = [m.family for m in demo_methods()].index("dividing-head")  # data: one per stage
    made: dict = {}
    for b in budgets(head.reduction, load_lab(lab_path), records=data[stage]):
        record = head.records[b.sensor]
        made.setdefault((record.serial, record.method), []).append(
            replace(b, serial=record.serial))
    return made


RESPONSE_DATA = "response.parquet"
"""The frequency response stage's record file (:mod:`accelcal.methods.response.demo`)."""


def demo_budgets(out, outcomes, data) -> dict:
    """:func:`head_budgets`, then the frequency response's budgets (when the campaign has it).

    The stepped-sine comparison's (magnitude in % and phase in degrees of
    each step) and the model fit's, from the response record file and the
    lab file :func:`head_budgets` wrote; same return as it.
    """
    from accelcal.budget import budgets
    from accelcal.budget.lab import load_lab

    made = head_budgets(out, outcomes, data)
    files = [p for p in data if Path(p).name == RESPONSE_DATA]
    if not files:
        return made
    lab_file = load_lab(Path(out) / "lab.toml")
    for outcome in outcomes:
        if outcome.reduction.family != "response":
            continue
        for b in budgets(outcome.reduction, lab_file, records=files[0]):
            record = outcome.records[b.sensor]
            made.setdefault((record.serial, record.method), []).append(
                replace(b, serial=record.serial))
    return made


def _certified_records(result: CampaignResult):
    """The records the demo's certificate states: the indexing head's, the response's."""
    out, start = [], 0
    for outcome in result.outcomes:
        n = len(outcome.records)
        if outcome.reduction.family in ("dividing-head", "response"):
            out += zip(result.records[start:start + n], outcome.records, strict=True)
        start += n
    return out


@dataclass(frozen=True)
class Certified:
    """What :func:`certify` wrote: the lab file, one budget as text, the certificate's files."""

    lab: Path
    budget: str
    number: str
    files: tuple[Path, ...]


def certify(result: CampaignResult, *, pdf: bool = True) -> Certified:
    """The demo's lab file, the budget of the first bias, and the campaign's certificate.

    The certificate states the indexing head's sensors and the frequency
    response (when the campaign has it). The budgets are the result's
    (:func:`demo_budgets`, made for the report), made here only for a
    result without them.

    Parameters
    ----------
    result : CampaignResult
        A run of :func:`run`.
    pdf : bool
        Also print the certificate to PDF when WeasyPrint is installed.

    Returns
    -------
    Certified
    """
    import datetime as dt

    from accelcal.budget.render import render_budgets
    from accelcal.certificate import issue
    from accelcal.certificate.render import pdf_available

    out = Path(result.out)
    lab_path = out / "lab.toml"
    made = result.budgets or demo_budgets(out, result.outcomes, result.data)
    head = next(o for o in result.outcomes if o.reduction.family == "dividing-head")
    certified = _certified_records(result)
    paths = [path for path, _ in certified]
    by_record = [[b.as_dict() for b in made.get((r.serial, r.method), ())]
                 for _, r in certified]
    with_pdf = pdf and pdf_available()
    issued = issue(paths, lab_path, out=out / "certificate.html",
                   pdf=out / "certificate.pdf" if with_pdf else None,
                   json_out=out / "certificate.json",
                   issued=dt.datetime.now(dt.UTC).date().isoformat(),
                   item=Item(make="accelcal demo", model="simulated pendulous accelerometer"),
                   budgets=by_record)
    first = made[(head.records[0].serial, head.records[0].method)][0]
    return Certified(lab_path, render_budgets([first], "table"), issued.document["number"],
                     issued.files)
