"""Options ``--serial`` and ``--operator`` of the commands that write calibration records."""

import typer

SERIAL = typer.Option(
    None, "--serial",
    help="Serial number for --record (default: the input files' 'serial' metadata).",
)
SERIALS = typer.Option(
    None, "--serial",
    help="Serial numbers for --record, one per sensor column, comma separated (default: the "
         "file's 'serial' metadata).",
)
OPERATOR = typer.Option(
    None, "--operator",
    help="Operator for --record (default: the input files' 'operator' metadata).",
)


def lab_info_for(record_out, files, *, serial: str | None, operator: str | None,
                 sensors: int | None = None):
    """Laboratory metadata for ``--record`` (None without it).

    Raises
    ------
    AccelcalError
        If ``--serial`` or ``--operator`` is given without ``--record``, or the
        files' metadata disagree (:func:`accelcal.calibration.lab_info`).
    """
    from accelcal.errors import AccelcalError

    if record_out is None:
        if serial is not None or operator is not None:
            raise AccelcalError("--serial and --operator go with --record FILE")
        return None
    from accelcal.calibration import lab_info

    return lab_info(files, sensors=sensors, serial=serial, operator=operator)
