"""A DAQ layout written once: the mapping file (TOML or JSON) of ``accelcal import``.

A lab's acquisition system writes the same channels to the same places in
every file; the mapping file says once how to read them and what record to
make. Fields (all optional; command-line options override them)::

    input_format = "tdms"            # auto, csv, parquet, tdms, hdf5, mat, ...
    kind = "noise"                   # the record kind
    rate = 1000.0                    # or: time = "Time/t", time_unit = "s"
    unit = "g"                       # unit of the channels (unless each says its own)
    scale = 1.0                      # file value x scale = value in unit
    delimiter = ";"                  # a CSV's field delimiter

    [channels]                       # record column = the file's channel
    acc_x = "Accel/X"
    acc_y = { channel = "Accel/Y", unit = "V", scale = 0.5 }

    [temperature]                    # channels summarised in the provenance
    case = { channel = "Temp/Case", unit = "degC" }

    [metadata]                       # the record's other metadata
    serial = "SN-1234"
    operator = "A. Lab"

JSON files hold the same object. The file is read bounded
(:data:`~accelcal.io.limits.MAX_JSON_BYTES`) and every field is checked;
an unknown field is refused with the known ones, so a misspelt key is
never ignored.

References
----------
.. [TOML] TOML v1.0.0 specification (https://toml.io); Python's :mod:`tomllib`.
"""

from dataclasses import dataclass, field
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.limits import MAX_JSON_BYTES, MAX_JSON_DEPTH, json_depth, load_json, read_bounded
from accelcal.validation import is_finite_number, shown, shown_name

OPTION_FIELDS = ("input_format", "rate", "time", "time_unit", "unit", "scale", "delimiter")
"""Fields that are :class:`~accelcal.io.recordings.InputOptions` parameters."""

FIELDS = (*OPTION_FIELDS, "kind", "channels", "temperature", "metadata")


@dataclass(frozen=True)
class Mapping:
    """A mapping file's contents.

    Attributes
    ----------
    options : dict
        :class:`~accelcal.io.recordings.InputOptions` parameters (``units`` and
        ``scales`` per channel included).
    kind : str or None
    channels : dict
        Record column -> channel.
    temperature : dict
        Name -> temperature channel.
    metadata : dict
    """

    options: dict = field(default_factory=dict)
    kind: str | None = None
    channels: dict = field(default_factory=dict)
    temperature: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)


def load_mapping(path) -> Mapping:
    """Read and check a mapping file (``.toml``, or JSON).

    Raises
    ------
    AccelcalError
        One line naming the file and the field.
    """
    import tomllib

    path = Path(path)
    name = shown_name(path.name)
    try:
        text = read_bounded(path, MAX_JSON_BYTES, "mapping file").decode("utf-8")
    except UnicodeDecodeError:
        raise AccelcalError(f"mapping file {name} is not UTF-8 text", parameter="mapping"
                            ) from None
    except OSError as exc:
        raise AccelcalError(f"cannot read mapping file {name}: "
                            f"{exc.strerror or exc.__class__.__name__}", parameter="mapping"
                            ) from None
    if not text.strip():
        raise AccelcalError(f"mapping file {name} is empty; write the DAQ layout in it "
                            "(docs/daq.md)", parameter="mapping")
    if path.suffix.lower() == ".toml" or not text.lstrip().startswith("{"):
        if json_depth(text) > MAX_JSON_DEPTH:  # tomllib recurses once per level
            raise AccelcalError(f"mapping file {name} nests deeper than {MAX_JSON_DEPTH} "
                                "levels; a mapping nests 2", parameter="mapping")
        try:
            doc = tomllib.loads(text)
        except RecursionError:
            raise AccelcalError(f"mapping file {name} nests too deeply", parameter="mapping"
                                ) from None
        except tomllib.TOMLDecodeError as exc:
            raise AccelcalError(f"mapping file {name} is not TOML: {exc}", parameter="mapping"
                                ) from None
    else:
        doc = load_json(text, f"mapping file {name}")
    return parse_mapping(doc, f"mapping file {name}")


def parse_mapping(doc, where: str) -> Mapping:
    """Check a mapping document (a dict) and split it into a :class:`Mapping`."""
    if not isinstance(doc, dict):
        raise AccelcalError(f"{where} must hold a table of fields", parameter="mapping")
    unknown = [k for k in doc if k not in FIELDS]
    if unknown:
        raise AccelcalError(f"{where}: unknown field(s) {shown(', '.join(map(str, unknown)))}; "
                            "the fields are " + ", ".join(FIELDS), parameter="mapping")
    options = {k: doc[k] for k in OPTION_FIELDS if k in doc}
    for key in ("input_format", "time", "time_unit", "unit", "delimiter"):
        if key in options and not isinstance(options[key], str):
            raise AccelcalError(f"{where}: {key} must be text, got {shown(options[key])}",
                                parameter="mapping")
    for key in ("rate", "scale"):
        if key in options and not is_finite_number(options[key]):
            raise AccelcalError(f"{where}: {key} must be a number, got {shown(options[key])}",
                                parameter="mapping")
    kind = doc.get("kind")
    if kind is not None and not isinstance(kind, str):
        raise AccelcalError(f"{where}: kind must be text", parameter="mapping")
    channels, units, scales = _channels(doc.get("channels", {}), where, "channels")
    temperature, t_units, _ = _channels(doc.get("temperature", {}), where, "temperature")
    units |= t_units
    if units:
        options["units"] = units
    if scales:
        options["scales"] = scales
    metadata = doc.get("metadata", {})
    if not isinstance(metadata, dict):
        raise AccelcalError(f"{where}: metadata must be a table", parameter="mapping")
    return Mapping(options, kind, channels, temperature, metadata)


def _channels(table, where: str, what: str) -> tuple[dict, dict, dict]:
    if not isinstance(table, dict):
        raise AccelcalError(f"{where}: {what} must be a table of column = channel",
                            parameter="mapping")
    channels, units, scales = {}, {}, {}
    for col, spec in table.items():
        if isinstance(spec, str):
            channels[col] = spec
            continue
        extra = sorted(set(spec) - {"channel", "unit", "scale"}) if isinstance(spec, dict) \
            else None
        if extra is None or extra or not isinstance(spec.get("channel"), str):
            raise AccelcalError(
                f"{where}: {what}.{shown_name(col)} must be a channel name or "
                '{ channel = "...", unit = "...", scale = ... }', parameter="mapping")
        channels[col] = spec["channel"]
        if "unit" in spec:
            units[spec["channel"]] = spec["unit"]
        if "scale" in spec:
            if not is_finite_number(spec["scale"]):
                raise AccelcalError(f"{where}: {what}.{shown_name(col)}.scale must be a number, "
                                    f"got {shown(spec['scale'])}", parameter="mapping")
            scales[spec["channel"]] = spec["scale"]
    return channels, units, scales
