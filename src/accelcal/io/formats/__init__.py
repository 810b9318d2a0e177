"""Record formats: one reader and writer per record kind, arrays in and out.

Each module here holds one kind of record file (its data type, ``write``
and ``read``), on top of the shared container of :mod:`accelcal.io.records`
(CSV with a JSON metadata header line, or Parquet with the metadata in the
schema). The layer imports nothing from :mod:`accelcal.methods`,
:mod:`accelcal.rigs` or :mod:`accelcal.cli`: rigs produce these data types,
methods reduce them, the command line reads and writes them.

:data:`KINDS` maps a record kind (the ``kind`` field of a file's metadata)
to its module; a new kind adds one line here.
"""

import importlib

KINDS = {
    "dividing-head": "accelcal.io.formats.dividing_head",
    "shaker": "accelcal.io.formats.shaker",
    "vibrafuge": "accelcal.io.formats.vibrafuge",
    "tumble": "accelcal.io.formats.tumble",
}
"""Record kind -> format module (imported on first use)."""


def format_module(kind: str):
    """The format module of record ``kind``.

    Raises
    ------
    accelcal.errors.AccelcalError
        For an unknown kind.
    """
    from accelcal.errors import AccelcalError

    if kind not in KINDS:
        raise AccelcalError(f"unknown record kind {kind!r}; known: {', '.join(KINDS)}",
                            parameter="kind")
    return importlib.import_module(KINDS[kind])
