"""Record formats: one reader and writer per record kind, arrays in and out.

Each module here holds one kind of record file (its data type, ``write``
and ``read``), on top of the shared container of :mod:`accelcal.io.records`
(CSV with a JSON metadata header line, or Parquet with the metadata in the
schema), and declares how a lab's recording becomes a record of its kind
(``IMPORT``, an :class:`ImportLayout`). The layer imports nothing from
:mod:`accelcal.methods`, :mod:`accelcal.rigs` or :mod:`accelcal.cli`: rigs
produce these data types, methods reduce them, the command line reads and
writes them.

:data:`KINDS` maps a record kind (the ``kind`` field of a file's metadata)
to its module; it is derived from the methods' descriptors
(:data:`accelcal.catalog.METHODS`): a new kind is named there.
"""

from dataclasses import dataclass

from accelcal.catalog import kinds as _kinds

KINDS = _kinds()
"""Record kind -> format module (imported where used)."""

OUTPUT_POLICIES = ("g", "input", "recorded")
"""How an import records a sensor output's unit (:attr:`ImportLayout.outputs`)."""

STATED = ("rate", "sample_rate_hz", "unit", "input_unit", "output_unit", "sensors")
"""The metadata a recording itself can state (:attr:`ImportLayout.states`)."""


@dataclass(frozen=True)
class ImportLayout:
    """How ``accelcal import`` makes a record of a kind from a recording's channels.

    Each format module declares one as ``IMPORT``;
    :func:`accelcal.io.recordings.kinds.layout` reads it, so that adding a
    kind adds no branch there.

    Attributes
    ----------
    reader : str
        Name of the module's reader, ``reader(path)``, that validates the
        record written.
    time : bool
        The record has a time column ``t`` (s), made from the recording's
        time or ``j / rate`` when the channel map gives none.
    restart : str
        Column at whose change of value the made time restarts at 0
        (``"point"``: a vibrafuge record's test points), or ``""``.
    stream : bool
        A long still or slowly turned recording, one row per sample: a
        record longer than a block is validated by streaming it.
    outputs : str
        The record unit of a sensor output (:data:`OUTPUT_POLICIES`):
        ``"g"``, accelerations to g and electrical outputs (V, mV, mA) kept;
        ``"input"``, the recording's unit kept (``1`` where the record has
        none); ``"recorded"``, as the kind's reader takes it (accelerations
        in the g family to g, counts as ``1``).
    fixed_names : bool
        Columns named ``t``, ``angle``, ``ref`` ... have their fixed units
        (s, deg, g ...); False: every column is a sensor output.
    states : tuple of str
        The metadata the recording itself states (:data:`STATED`), in the
        order the record's header writes them: ``rate`` and
        ``sample_rate_hz`` (Hz), ``unit`` (the outputs' unit, counts for
        ``1``), ``input_unit`` (the first output channel's unit),
        ``output_unit`` (the outputs' record unit) and ``sensors`` (the
        output columns). The rest comes from the user and the reader checks
        it all.
    """

    reader: str = "read"
    time: bool = False
    restart: str = ""
    stream: bool = False
    outputs: str = "g"
    fixed_names: bool = True
    states: tuple[str, ...] = ("output_unit",)

    def __post_init__(self) -> None:
        if self.outputs not in OUTPUT_POLICIES:
            raise ValueError(f"outputs must be one of {OUTPUT_POLICIES}")
        if not set(self.states) <= set(STATED):
            raise ValueError(f"states must be among {STATED}")
