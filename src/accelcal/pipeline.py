"""A calibration campaign: simulate or take record files, reduce, record, store, report.

A campaign is a sequence of :class:`Stage` s, one per test. Each stage
writes its input record files (:attr:`Stage.simulate`, the way a laboratory
would: serial numbers, operator, date, local gravity in the files) and
reduces them (:attr:`Stage.reduce`) to :class:`Outcome` s: a
:class:`~accelcal.results.Reduction` with its calibration records. The rest
is the same for every method and lives here once: the records are written
(one JSON file each), added to the store, and every reduction becomes report
sections (:func:`accelcal.report.sections.reduction_sections`) in one
self-contained HTML report with its figures. ``accelcal report`` of the
records written goes through the same function, with the reduction rebuilt
from the records and the input files they name
(:mod:`accelcal.report.rebuild`), and gives the same sections. A new method
takes part by adding one stage.

References
----------
.. [1] JCGM 101:2008 (GUM-S1) and IEEE Std 1293-2018 for what each stage
   reports; see the method packages.
"""

import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError


@dataclass(frozen=True)
class Outcome:
    """One reduction of a campaign and what it produced.

    Attributes
    ----------
    reduction : accelcal.results.Reduction
    records : list of CalibrationRecord
        One per sensor.
    tag : str
        Short name for the record files (``head``, ``shaker-5g``, ...).
    context : dict
        Passed to the method's figures (e.g. ``truth``).
    """

    reduction: object
    records: list
    tag: str
    context: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Stage:
    """One test of a campaign.

    Attributes
    ----------
    name : str
        What the test is (``"indexing head"``), shown in the progress bar.
    simulate : callable
        ``simulate(data_dir, date, seed_sequence) -> path``: writes the
        test's record file(s) under ``data_dir`` and returns the file or
        directory.
    reduce : callable
        ``reduce(path) -> list of Outcome``.
    """

    name: str
    simulate: Callable
    reduce: Callable


@dataclass(frozen=True)
class CampaignResult:
    """What a campaign wrote.

    Attributes
    ----------
    out : pathlib.Path
        The output directory.
    data : list of pathlib.Path
        Input files or directories, one per stage.
    records : list of pathlib.Path
        Calibration records.
    report : pathlib.Path
        The HTML report.
    figures : list of pathlib.Path
        The report's figures as SVG files.
    store : str
        The store the records were added to (password hidden).
    record_ids : list of int
        Their ids in the store.
    seed : int
        The seed of the simulation.
    seconds : float
        Wall-clock time of the run.
    outcomes : list of Outcome
        Every reduction, in stage order.
    budgets : dict
        The uncertainty budgets the report states, ``(serial, method) ->
        list of Budget`` (empty without a ``budgets`` callable).
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
    outcomes: list = field(default_factory=list)
    budgets: dict = field(default_factory=dict)


def run_campaign(stages, out, *, db=None, seed: int | None = None, progress: bool = True,
                 title: str, subtitle: str = "", history_serial: str | None = None,
                 budgets=None) -> CampaignResult:
    """Run every stage, then write records, store them and write the report.

    Parameters
    ----------
    stages : sequence of Stage
    out : path-like
        Output directory (created): ``data/``, ``records/``, ``figures/``
        and ``report.html``.
    db : str, optional
        Store (SQLite path or database URL); default ``records.sqlite`` inside
        ``out``: a campaign never touches a laboratory's records store unless
        it is named here.
    seed : int, optional
        Seed of every simulated error and noise; default a fresh one (in the
        result and the report's subtitle, so a run can be repeated).
    progress : bool
        Show a progress bar on standard error.
    title, subtitle : str
        The report's heading; ``{seed}`` and ``{date}`` in the subtitle are
        filled in.
    history_serial : str, optional
        Add this serial number's history (by the first outcome's method)
        from the store to the report.
    budgets : callable, optional
        ``budgets(out, outcomes, data) -> {(serial, method): [Budget]}``:
        the uncertainty budgets the report states (summary's U and k, the
        annex), made after the reductions and kept in the result.

    Returns
    -------
    CampaignResult
    """
    from accelcal.calibration import now
    from accelcal.formatting import format_date
    from accelcal.store import Store
    from accelcal.validation import shown

    start = time.perf_counter()
    out = Path(out)
    if isinstance(seed, bool) or (seed is not None and (not isinstance(seed, int) or seed < 0)):
        raise AccelcalError(f"{shown(seed)} must be a non-negative integer",
                            parameter="seed")
    try:
        for sub in ("data", "records", "figures"):
            (out / sub).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccelcalError(f"{out}: cannot create the output directories ({exc})",
                            parameter="out") from None
    if db is None:
        db = str(out / "records.sqlite")
    date = now()
    if seed is None:  # a fresh, short seed the user can type back in
        seed = int(np.random.SeedSequence().entropy % 1_000_000)
    seeds = np.random.SeedSequence(seed).spawn(len(stages))
    names = [f"simulating: {s.name}" for s in stages] + [f"reducing: {s.name}" for s in stages]
    names += ["writing calibration records", "adding records to the store"]
    names += ["uncertainty budgets"] * (budgets is not None) + ["writing the report"]
    # The store is opened (created, checked, migrated) before anything is simulated: a store
    # that cannot be used (a directory, a file that is not a database, a newer schema) is
    # refused at once, not after the work.
    with Store(db) as store, _Steps(names, progress) as step:
        data = [step(s.simulate, out / "data", date, q)
                for s, q in zip(stages, seeds, strict=True)]
        outcomes = [o for s, path in zip(stages, data, strict=True) for o in step(s.reduce, path)]
        written = step(_write_records, out / "records", outcomes)
        store_url, ids = step(_store, store, [r for _, r in written])
        made = step(budgets, out, outcomes, data) if budgets is not None else {}
        report, figures = step(_report, out, store, outcomes, title,
                               subtitle.format(seed=seed, date=format_date(date)), history_serial,
                               made)
    return CampaignResult(out=out, data=data, records=[p for p, _ in written], report=report,
                          figures=figures, store=store_url, record_ids=ids, seed=seed,
                          seconds=time.perf_counter() - start, outcomes=outcomes, budgets=made)


class _Steps:
    """Runs named steps in order, advancing one rich progress task (or none).

    On a terminal the bar is drawn live and cleared if a step fails. Elsewhere
    (a pipe, a log) nothing is drawn while the steps run, and the bar's final
    state is printed once, after the last step succeeded: a failed run's
    standard error holds its one error line alone.
    """

    def __init__(self, names, enabled: bool) -> None:
        self.names = list(names)
        self.bar = None
        self.live = False
        if enabled:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            console = Console(stderr=True)
            self.live = console.is_terminal
            self.bar = Progress(TextColumn("[bold]{task.description:<40}"), BarColumn(),
                                TextColumn("{task.completed}/{task.total}"),
                                TimeElapsedColumn(), console=console)
            self.task = self.bar.add_task(self.names[0], total=len(self.names))
        self.done = 0

    def __enter__(self):
        if self.bar is not None and self.live:
            self.bar.__enter__()
        return self

    def __exit__(self, exc_type, *exc):
        if self.bar is None:
            return False
        if self.live:
            if exc_type is not None:  # clear the bar: the error line follows alone
                self.bar.live.transient = True
            self.bar.__exit__(exc_type, *exc)
        elif exc_type is None:
            self.bar.console.print(self.bar.get_renderable())
        return False

    def __call__(self, function, *args):
        if self.bar is not None:
            self.bar.update(self.task, description=self.names[self.done])
        result = function(*args)
        self.done += 1
        if self.bar is not None:
            self.bar.advance(self.task)
        return result


def _write_records(directory: Path, outcomes):
    from accelcal.calibration import save_records

    written = []
    for outcome in outcomes:
        for rec in outcome.records:
            path = directory / f"{_slug(rec.serial, lower=False)}-{outcome.tag}.json"
            written += [(p, rec) for p in save_records([rec], path)]
    return written


def _store(store, records):
    ids = store.add_many(records)
    return store.shown, ids


def _report(out: Path, store, outcomes, title: str, subtitle: str,  # noqa: PLR0917
            history_serial, budgets):
    from accelcal.io.atomic import write_text_atomic
    from accelcal.report import write_report
    from accelcal.report.sections import history_section, reduction_sections

    sections = []
    for o in outcomes:
        sections += reduction_sections(o.reduction, o.records, **o.context)
    chain = store.verify().status_line()  # the records reported were just stored
    if history_serial is not None and outcomes:
        history = history_section(store, history_serial, method=outcomes[0].reduction.method,
                                  chain=chain)
        if history is not None:
            sections.append(history)
    report = out / "report.html"
    write_report(report, sections, title=title, subtitle=subtitle,
                 budgets={key: [b.as_dict() for b in items] for key, items in budgets.items()},
                 records_chain=chain)
    figures = []
    main = [s for s in sections if not s.appendix]  # numbered as in the report
    for i, section in enumerate(main, 1):
        for j, fig in enumerate(section.figures, 1):
            path = out / "figures" / f"{i:02d}-{j}-{_slug(fig.title)}.svg"
            write_text_atomic(path, fig.svg)
            figures.append(path)
    return report, figures


def _slug(text: str, *, lower: bool = True) -> str:
    """A file-name-safe form of ``text``: ASCII letters and digits, other runs as ``-``."""
    text = re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-") or "x"
    return text.lower() if lower else text
