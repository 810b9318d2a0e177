"""Calibration certificates: from calibration records and a lab file to a signed document.

:func:`issue` reads the records and the lab file, builds the certificate's
content (:mod:`accelcal.certificate.content`: ISO/IEC 17025 7.8), and
writes it as HTML, and on request as PDF (:mod:`.render`), as JSON (the
machine-readable certificate, ``schema/certificate.schema.json``) and as
XML in the structure of PTB's Digital Calibration Certificate (:mod:`.dcc`).
A frequency response's points and fitted model are
:mod:`accelcal.certificate.response`'s.
docs/certificate.md shows the use and the content map.
"""

import json
from dataclasses import dataclass
from pathlib import Path

from accelcal.certificate.content import (
    NOT_FROM_A_STORE,
    Item,
    build,
    engine_budgets,
    kept_budgets,
    record_budgets,
    with_budgets,
)
from accelcal.errors import AccelcalError

__all__ = ["Issued", "Item", "build", "issue", "schema", "to_json"]


@dataclass(frozen=True)
class Issued:
    """What :func:`issue` wrote: the certificate document and the files."""

    document: dict
    files: tuple[Path, ...]


def schema() -> dict:
    """The JSON Schema of the certificate document (draft 2020-12)."""
    from importlib.resources import files

    return json.loads(files("accelcal.certificate").joinpath(
        "schema/certificate.schema.json").read_text(encoding="utf-8"))


def to_json(document: dict) -> str:
    """The certificate document as JSON text (sorted as built, UTF-8, one final newline)."""
    return json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def issue(record_paths, lab_path, *, out, issued: str, pdf=None, json_out=None, xml=None,
          spec_path=None, rule: str | None = None, number: str | None = None,
          item: Item | None = None, allow_expired: bool = False, keep_budgets: bool = False,
          country: str = "", search=(), budgets=None, phase_at=(), store=None,
          allow_unverified: bool = False) -> Issued:
    """Issue a certificate: read, check, build, then write every file asked for.

    Parameters
    ----------
    record_paths : sequence of path-like
        Calibration record files (JSON).
    lab_path : path-like
        The lab file (TOML, :func:`accelcal.budget.lab.load_lab`).
    out : path-like
        The HTML file.
    issued : str
        Date of issue (ISO 8601).
    pdf, json_out, xml : path-like, optional
        The PDF, the JSON certificate and the DCC XML.
    spec_path : path-like, optional
        A specification (:func:`accelcal.conformity.load_spec`) for the
        statements of conformity, by ``rule`` (default the spec's).
    number : str, optional
        The certificate's number (default derived from the records and the
        lab file).
    item : Item, optional
        Make, model and date of receipt (default: not stated).
    allow_expired : bool
        Issue with standards past their due date (the certificate says so).
    country : str
        The laboratory's country (ISO 3166-1 alpha-2), for the DCC.
    search : sequence of path-like
        More directories holding the records' input files (the budgets'
        inputs that enter through the data need them).
    budgets : list, optional
        The budgets of each record (a list of :meth:`Budget.as_dict` per
        record, or None), when the caller has them: the records are then not
        reduced again for them.
    phase_at : sequence of float
        Frequencies (Hz) of a fitted frequency response's phase and group
        delay (default: the reference frequency of the serial's response).
    keep_budgets : bool
        Write the budgets, the lab file's hash and the standards used into
        each record file (atomically), so that the records (and a store that
        keeps them) hold what the certificate was issued from.
    store : str or path-like, optional
        A records store (``--db``): each record file is looked up in it by
        its content hash and its hash chain verified
        (:func:`accelcal.certificate.provenance.store_provenance`); the
        certificate's ``records_chain`` says the outcome. A record not found
        or a chain broken refuses the certificate unless ``allow_unverified``
        (it then says ``NOT verified`` and why).
    allow_unverified : bool
        Issue although the store did not verify the records.

    Returns
    -------
    Issued

    Raises
    ------
    AccelcalError
        Bad input of any kind (one line); nothing is written then.
    """
    from accelcal import __version__
    from accelcal.budget.lab import load_lab
    from accelcal.certificate.dcc import to_dcc
    from accelcal.certificate.render import render_html, write_pdf
    from accelcal.io.atomic import write_text_atomic
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.validation import shown_path

    for d in search:
        if not Path(d).is_dir():
            raise AccelcalError(f"--data {shown_path(d)}: not a directory; give the directory "
                                "holding the records' input files", parameter="data")
    lab = load_lab(lab_path)
    records = [CalibrationRecord.load(p) for p in record_paths]
    records_chain = NOT_FROM_A_STORE
    if store is not None:
        from accelcal.certificate.provenance import store_provenance

        found = store_provenance(records, [shown_path(p) for p in record_paths], store)
        if not found.verified and not allow_unverified:
            raise AccelcalError(f"records {found.statement}; --allow-unverified "
                                "(allow_unverified=True) issues the certificate with this "
                                "statement", parameter="db")
        records_chain = found.statement
    spec = None
    if spec_path is not None:
        from accelcal.conformity import load_spec

        spec = load_spec(spec_path)
    fresh = list(budgets) if budgets is not None else [None] * len(records)
    need = [i for i, r in enumerate(records) if kept_budgets(r, lab) is None and not fresh[i]]
    made = engine_budgets([record_paths[i] for i in need], [records[i] for i in need], lab,
                          search) if need else []
    for i, made_i in zip(need, made, strict=True):
        fresh[i] = made_i
    document = build(records, lab, issued=issued, number=number, item=item or Item(), spec=spec,
                     rule=rule, allow_expired=allow_expired,
                     software=f"accelcal {__version__}", country=country, budgets=fresh,
                     phase_at=phase_at, records_chain=records_chain)
    html = render_html(document)
    written = []
    if pdf is not None:
        write_pdf(html, pdf)
        written.append(Path(pdf))
    write_text_atomic(out, html)
    written.append(Path(out))
    if json_out is not None:
        write_text_atomic(json_out, to_json(document))
        written.append(Path(json_out))
    if xml is not None:
        write_text_atomic(xml, to_dcc(document))
        written.append(Path(xml))
    if keep_budgets:
        stated = record_budgets(records, lab, fresh)
        for path, record, its_budgets in zip(record_paths, records, stated, strict=True):
            kept = with_budgets(record, lab, its_budgets)
            if kept is not record:
                kept.save(path)
                written.append(Path(path))
    return Issued(document, tuple(written))
