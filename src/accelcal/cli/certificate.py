"""``accelcal certificate``: a calibration certificate from records and the lab file."""

from pathlib import Path

import typer


def certificate(
    records: list[Path] = typer.Argument(
        ..., help="Calibration record files (JSON, from a reduction's --record); one page of "
        "results per serial number."),
    *,
    lab: Path = typer.Option(..., "--lab", help="The lab file (TOML): laboratory, signatory, "
                             "customer, environment and the standards with their "
                             "certificates and due dates (examples/lab.toml)."),
    out: Path = typer.Option(..., "--out", help="HTML file to write (self-contained)."),
    pdf: Path | None = typer.Option(None, "--pdf", help="Also print it to this PDF file "
                                    "(needs WeasyPrint: the pdf extra of accelcal)."),
    json_out: Path | None = typer.Option(
        None, "--json", help="Also write the machine-readable certificate (JSON; its schema: "
        "accelcal/certificate/schema/certificate.schema.json)."),
    xml: Path | None = typer.Option(
        None, "--xml", help="Also write it as XML in the structure of PTB's Digital "
        "Calibration Certificate (DCC 3.3)."),
    spec: Path | None = typer.Option(
        None, "--spec", help="Specification file (TOML) with tolerance limits: adds a "
        "statement of conformity per limited result."),
    decision_rule: str | None = typer.Option(
        None, "--decision-rule", help="simple or guarded acceptance (JCGM 106, ILAC-G8); "
        "default the specification's own, else simple."),
    number: str | None = typer.Option(
        None, "--number", help="Certificate number; default derived from the records and the "
        "lab file (the same inputs give the same number)."),
    issued: str | None = typer.Option(
        None, "--issued", help="Date of issue, ISO 8601 (default today, UTC); give it to "
        "reissue a certificate identically."),
    make: str = typer.Option("", "--make", help="The item's manufacturer."),
    model: str = typer.Option("", "--model", help="The item's model."),
    received: str = typer.Option("", "--received", help="Date of receipt of the item, "
                                 "ISO 8601."),
    country: str = typer.Option("", "--country", help="The laboratory's country, ISO 3166-1 "
                                "alpha-2 (for the DCC)."),
    allow_expired: bool = typer.Option(
        False, "--allow-expired", help="Issue even if a standard was past its due date on a "
        "calibration date; the certificate then says so on every page of results."),
    data: list[Path] = typer.Option(
        [], "--data", help="A directory holding the records' input files (found by name and "
        "SHA-256, also two levels deep), for the budgets' inputs that enter through the data. "
        "Repeatable."),
    phase_at: str = typer.Option(
        "", "--phase-at", help="Frequencies, Hz (list), of a fitted frequency response's "
        "phase and group delay; default the measured response's reference frequency."),
    keep_budgets: bool = typer.Option(
        False, "--keep-budgets", help="Write the budgets, the lab file's SHA-256 and the "
        "standards used into each record file, so the records (and the store) keep them and "
        "the certificate can be reissued from them."),
    db: str | None = typer.Option(
        None, "--db", help="A records store (SQLite path or database URL, as the records "
        "commands take it; only when given: $ACCELCAL_DB alone does not make a certificate "
        "depend on a store): each record file is looked up in "
        "it by its content hash and the store's hash chain verified; the certificate says "
        "'verified in store ... (n records, chain intact)'. A record not found or a chain "
        "broken refuses the certificate (one line) unless --allow-unverified."),
    allow_unverified: bool = typer.Option(
        False, "--allow-unverified", help="With --db: issue although the store did not "
        "verify the records; the certificate then says 'NOT verified' and why."),
) -> None:
    """Issue a calibration certificate (ISO/IEC 17025 7.8): HTML, and PDF, JSON or DCC XML.

    The certificate names the laboratory, the customer, the item, the dates, the
    method, the conditions, the results in the field's units (µg, ppm, µrad,
    µg/g²) with their expanded uncertainty U, k and the coverage probability,
    the standards' certificates and due dates, the statement of conformity
    (with --spec) and the signatory, with the uncertainty budgets as an annex.
    A frequency response (accelcal response reduce/fit --record) gets its
    magnitude, deviation and phase per frequency with U and k, the fitted
    model's phase and group delay (--phase-at) and a Bode figure.
    A standard past its due date refuses the certificate unless
    --allow-expired. Every input is checked before anything is written.
    """
    import datetime as dt

    from accelcal.certificate import Item, issue
    from accelcal.cli.common import parse_grid

    result = issue(records, lab, out=out, pdf=pdf, json_out=json_out, xml=xml, spec_path=spec,
                   rule=decision_rule, number=number,
                   issued=issued or dt.datetime.now(dt.UTC).date().isoformat(),
                   item=Item(make, model, received), allow_expired=allow_expired,
                   keep_budgets=keep_budgets, country=country, search=data,
                   phase_at=parse_grid(phase_at, "--phase-at") if phase_at else (),
                   store=db,
                   allow_unverified=allow_unverified)
    doc = result.document
    typer.echo(f"certificate {doc['number']} issued {doc['issued']}: "
               f"{', '.join(i['serial'] for i in doc['items'])}")
    if doc["expired_standards"]:
        typer.echo(f"warning: issued with expired standard(s): "
                   f"{', '.join(doc['expired_standards'])}", err=True)
    for item in doc["items"]:
        stated = item["results"] + [p for c in item.get("response", ()) for p in c["points"]]
        for r in stated:
            if r["conformity"] is not None:
                typer.echo(f"{item['serial']} {statement(r['conformity'])}")
    for path in result.files:
        typer.echo(f"wrote {path}")


def statement(s: dict) -> str:
    """One line of a statement of conformity: result, limits, zone, decision, risk."""
    from accelcal.formatting import format_std, format_unit, format_value

    def limit(x, none):
        return none if x is None else f"{x:g}"

    lo, hi = s["acceptance"]
    return (f"{s['quantity']} = {format_value(s['estimate'], s['u'] or None)} ± "
            f"{format_std(s['U'])} {format_unit(s['unit'])}; "
            f"tolerance [{limit(s['lower'], '-inf')}, "
            f"{limit(s['upper'], 'inf')}], acceptance zone "
            f"[{'-inf' if lo is None else format_value(lo, s['u'] or None)}, "
            f"{'inf' if hi is None else format_value(hi, s['u'] or None)}] "
            f"(guard band {format_std(s['guard']) if s['guard'] else '0'}); {s['rule']}: "
            f"{s['statement']}; {risk_text(s)}")


def risk_text(s: dict) -> str:
    """The decision's specific risk: of a false accept, or of a false reject for a reject."""
    if s["outcome"] == "reject":
        return f"specific risk of a false reject {s['conforming']:.2g}"
    return f"specific risk of a false accept {s['false_accept_risk']:.2g}"
