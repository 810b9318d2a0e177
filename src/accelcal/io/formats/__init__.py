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

KINDS = {
    "dividing-head": "accelcal.io.formats.dividing_head",
    "shaker": "accelcal.io.formats.shaker",
    "vibrafuge": "accelcal.io.formats.vibrafuge",
    "tumble": "accelcal.io.formats.tumble",
    "triad": "accelcal.io.formats.triad",
    "noise": "accelcal.io.formats.noise",
    "thermal": "accelcal.io.formats.thermal",
    "centrifuge": "accelcal.io.formats.centrifuge",
}
"""Record kind -> format module (imported where used)."""

