"""The test methods, one descriptor each: the unit of registration.

A :class:`Method` says, as plain data (strings and tuples), everything the
rest of the package needs to know about a method: its name and Reduction
family, the record kinds it owns and their format modules, its rig, its
command group and that group's help, its stage in the demo campaign, its
entry points (simulate, reduce, uncertainty, plan), its report section, its
documentation page and the key of its paper. Every registry is derived from
:data:`METHODS`:

- :data:`accelcal.methods.REGISTRY` (family -> method package);
- :data:`accelcal.io.formats.KINDS` (record kind -> format module);
- ``GROUPS`` of :mod:`accelcal.cli.app` (command group -> module, help);
- :func:`accelcal.demo.stages` (the demo's tests, in order);
- the help texts that list kinds or tests (``accelcal import --kind``,
  ``accelcal demo --help``), checked with the documentation by
  ``tests/project/test_descriptors.py``.

This module imports nothing from accelcal, only the standard library, so
that every floor can read it (io included) without pulling in the methods,
rigs or command line: the descriptors are kept here, in one module, rather
than beside each method package, because importing ``accelcal.methods.<m>``
runs its package ``__init__`` (numpy, the reductions), which the record
formats and ``accelcal --help`` must not pay for. Dotted paths are resolved
where they are used (:func:`resolve`).
"""

import importlib
from dataclasses import dataclass

VERBS = ("simulate", "reduce", "uncertainty", "plan")
"""The entry points a method may name."""

DEMO_SENSORS = ("four", "one", "triad")
"""Which of the demo's accelerometers a stage tests: the four sensors of
:data:`accelcal.demo.SERIALS`, the first of them, or the triad."""


@dataclass(frozen=True)
class Method:
    """One test method: what every registry, help text and doc table derives from.

    Attributes
    ----------
    name : str
        The method's name, also its command group (``accelcal <name>``).
    family : str
        The ``family`` of its :class:`~accelcal.results.Reduction` s.
    title : str
        What the method is, in a few words (the docs' link text).
    package : str
        Its package under :mod:`accelcal.methods`.
    kinds : tuple of str
        The record kinds it owns (the ``kind`` field of their files).
    formats : tuple of str
        The format module of each kind, in the order of ``kinds``.
    rig : str
        Its rig simulator's module.
    cli : str
        The module whose ``app`` is its command group.
    cli_help : str
        The group's help, as ``accelcal --help`` lists it (equal to the
        group's own).
    verbs : tuple of str
        The verbs of :data:`VERBS` its package defines (every method has
        ``simulate`` and ``reduce``); :attr:`entry_points` names them.
    report : str
        Dotted path of ``report_text(reduction)``, its report section's
        title and summary.
    docs : str
        Its documentation page, relative to the repository.
    paper : str
        Key of its paper in docs/references.md (the errata's heading).
    demo : str
        Module of its demo stage (``""``: no stage of its own).
    demo_order : int
        Position of the stage in the demo campaign, from 1.
    demo_sensors : str
        Which demo accelerometers the stage tests (:data:`DEMO_SENSORS`).
    demo_test : str
        The stage's test in a few words (the demo's help and subtitle).
    demo_callable : str
        Name of the stage builder, ``stage(sensors, lab) -> Stage``.
    budget_inputs : tuple of str
        The lab's input quantities its measurement model has
        (:data:`accelcal.budget.lab.QUANTITIES`), evaluated by its package's
        ``budget`` module; empty: no lab inputs modelled, a budget holds the
        Type A part and the priors only.
    """

    name: str
    family: str
    title: str
    package: str
    kinds: tuple[str, ...]
    formats: tuple[str, ...]
    rig: str
    cli: str
    cli_help: str
    verbs: tuple[str, ...]
    report: str
    docs: str
    paper: str
    demo: str = ""
    demo_order: int = 0
    demo_sensors: str = ""
    demo_test: str = ""
    demo_callable: str = "stage"
    budget_inputs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if len(self.kinds) != len(self.formats):
            raise ValueError(f"{self.name}: one format module per record kind")
        for verb in self.verbs:
            if verb not in VERBS:
                raise ValueError(f"{self.name}: entry point {verb!r} is not one of {VERBS}")
        if self.demo and self.demo_sensors not in DEMO_SENSORS:
            raise ValueError(f"{self.name}: demo_sensors must be one of {DEMO_SENSORS}")

    @property
    def entry_points(self) -> tuple[tuple[str, str], ...]:
        """``(verb, dotted path)`` of each verb: the package's function of that name."""
        return tuple((verb, f"{self.package}.{verb}") for verb in self.verbs)

    def entry(self, verb: str) -> tuple[str, ...]:
        """The dotted path of ``verb`` (empty when the method has none)."""
        return tuple(path for v, path in self.entry_points if v == verb)


def _m(package: str) -> str:
    return f"accelcal.methods.{package}"


_POSITIONED = ("local_gravity", "head_angle", "autocollimator", "head_axis_tilt", "daq_gain",
               "daq_offset", "daq_linearity", "load_resistor", "load_resistor_tc",
               "sensor_temperature")
"""The inputs of a test on static positions in the gravity field (tumble, indexing head)."""

METHODS: tuple[Method, ...] = (
    Method(
        name="vre", family="vre", title="vibration rectification", package=_m("vre"),
        kinds=("vibrafuge",), formats=("accelcal.io.formats.vibrafuge",),
        rig="accelcal.rigs.vibrafuge", cli="accelcal.cli.vre",
        cli_help=("Vibration rectification error (VRE) with asymmetry under overload + "
                  "vibration (vibrafuge): predict, simulate records, reduce them, identify "
                  "coefficients."),
        verbs=("simulate", "reduce", "uncertainty"),
        report="accelcal.methods.vre.report_text", docs="docs/vre.md", paper="Guan2021",
        demo="accelcal.methods.vre.demo", demo_order=3, demo_sensors="one",
        demo_test="vibrafuge grid",
        budget_inputs=("reference_sensitivity", "centrifuge_rate", "centrifuge_radius",
                       "daq_gain")),
    Method(
        name="transverse", family="transverse", title="transverse sensitivity",
        package=_m("transverse"), kinds=("shaker",), formats=("accelcal.io.formats.shaker",),
        rig="accelcal.rigs.shaker", cli="accelcal.cli.transverse",
        cli_help=("Transverse sensitivity of an accelerometer vibrated in its transverse plane "
                  "on a shaker (GuanTang, after ISO 16063-31): sweep, simulate records, "
                  "analyze, fit."),
        verbs=("simulate", "reduce", "uncertainty"),
        report="accelcal.methods.transverse.report_text", docs="docs/transverse.md",
        paper="GuanTang", demo="accelcal.methods.transverse.demo", demo_order=2,
        demo_sensors="one", demo_test="shaker transverse sweep",
        budget_inputs=("reference_sensitivity",)),
    Method(
        name="dividing-head", family="dividing-head", title="indexing head",
        package=_m("dividing_head"), kinds=("dividing-head",),
        formats=("accelcal.io.formats.dividing_head",), rig="accelcal.rigs.dividing_head",
        cli="accelcal.cli.dividing_head",
        cli_help=("Accelerometers on an indexing (dividing) head: simulate records, reduce "
                  "them (single-sensor, four-sensor separation, joint least squares, IEEE "
                  "tumble), and compare the methods by Monte Carlo (Dong2014, corrected)."),
        verbs=("simulate", "reduce", "uncertainty"),
        report="accelcal.methods.dividing_head.report_text", docs="docs/dividing-head.md",
        paper="Dong2014", demo="accelcal.methods.dividing_head.demo", demo_order=1,
        demo_sensors="four", demo_test="indexing head", budget_inputs=_POSITIONED),
    Method(
        name="tumble", family="tumble", title="multipoint tumble", package=_m("tumble"),
        kinds=("tumble",), formats=("accelcal.io.formats.tumble",), rig="accelcal.rigs.tumble",
        cli="accelcal.cli.tumble",
        cli_help=("Multipoint tumble (IEEE 1293 style): what a position set identifies, "
                  "simulated records, and the Fourier / least-squares reduction."),
        verbs=("simulate", "reduce", "plan"),
        report="accelcal.methods.tumble.report_text", docs="docs/tumble.md", paper="IEEE1293",
        budget_inputs=_POSITIONED),
    Method(
        name="triad", family="triad", title="accelerometer triad", package=_m("triad"),
        kinds=("triad",), formats=("accelcal.io.formats.triad",), rig="accelcal.rigs.triad",
        cli="accelcal.cli.triad",
        cli_help=("Accelerometer triads on static positions (Tedaldi 2014, Ferraris 1995): "
                  "static intervals, calibration with uncertainty (known or unknown "
                  "orientations), applying a calibration to a recording, simulated triads."),
        verbs=("simulate", "reduce", "uncertainty", "plan"),
        report="accelcal.methods.triad.report_text", docs="docs/triad.md", paper="Tedaldi2014",
        demo="accelcal.methods.triad.demo", demo_order=7, demo_sensors="triad",
        demo_test="triad on static positions", budget_inputs=("local_gravity",)),
    Method(
        name="noise", family="noise", title="noise and stability", package=_m("noise"),
        kinds=("noise",), formats=("accelcal.io.formats.noise",), rig="accelcal.rigs.noise",
        cli="accelcal.cli.noise",
        cli_help=("Noise and stability of still recordings: Allan deviations with confidence "
                  "intervals, IEEE 952 coefficients (Q, N, B, K, R), PSD, simulated records."),
        verbs=("simulate", "reduce"),
        report="accelcal.methods.noise.report_text", docs="docs/noise.md", paper="IEEE952",
        demo="accelcal.methods.noise.demo", demo_order=4, demo_sensors="one",
        demo_test="still recording", budget_inputs=("daq_gain",)),
    Method(
        name="thermal", family="thermal", title="temperature", package=_m("thermal"),
        kinds=("thermal",), formats=("accelcal.io.formats.thermal",), rig="accelcal.rigs.thermal",
        cli="accelcal.cli.thermal",
        cli_help=("Thermal-chamber tests (IEEE 1293 style): a multipoint tumble at each "
                  "temperature plateau, temperature coefficients with uncertainty, hysteresis, "
                  "warm-up, and temperature compensation of recordings."),
        verbs=("simulate", "reduce"),
        report="accelcal.methods.thermal.report_text", docs="docs/thermal.md", paper="IEEE1293",
        demo="accelcal.methods.thermal.demo", demo_order=5, demo_sensors="one",
        demo_test="thermal chamber", budget_inputs=_POSITIONED),
    Method(
        name="centrifuge", family="centrifuge", title="centrifuge", package=_m("centrifuge"),
        kinds=("centrifuge",), formats=("accelcal.io.formats.centrifuge",),
        rig="accelcal.rigs.centrifuge", cli="accelcal.cli.centrifuge",
        cli_help=("Precision centrifuge tests (IEEE 836): simulated records with the rig's "
                  "errors, reduction of K2, K3, K4 and the cross-coupling (alone or jointly "
                  "with a 1 g record), and test planning without data."),
        verbs=("simulate", "reduce", "plan"),
        report="accelcal.methods.centrifuge.report_text", docs="docs/centrifuge.md",
        paper="IEEE836", demo="accelcal.methods.centrifuge.demo", demo_order=6,
        demo_sensors="one", demo_test="centrifuge",
        budget_inputs=("local_gravity", "centrifuge_radius", "centrifuge_rate", "daq_gain",
                       "daq_offset", "daq_linearity", "load_resistor", "load_resistor_tc",
                       "sensor_temperature")),
    Method(
        name="acceptance", family="acceptance", title="acceptance tests",
        package=_m("acceptance"), kinds=("steps",), formats=("accelcal.io.formats.acceptance",),
        rig="accelcal.rigs.acceptance", cli="accelcal.cli.acceptance",
        cli_help=("Acceptance tests of pendulous accelerometers (IEEE 1293): threshold and "
                  "resolution by the 50 % rule with the decision's error probability, "
                  "hysteresis over the input cycle, input range and saturation, turn-on "
                  "repeatability; simulated records and their reduction; repeatability over a "
                  "serial's records and the shift between two; pass/fail against a "
                  "specification file."),
        verbs=("simulate", "reduce"),
        report="accelcal.methods.acceptance.report_text", docs="docs/acceptance.md",
        paper="IEEE1293", demo="accelcal.methods.acceptance.demo", demo_order=8,
        demo_sensors="one", demo_test="acceptance tests",
        budget_inputs=("local_gravity", "head_angle", "head_repeatability", "centrifuge_radius",
                       "centrifuge_rate", "coil_constant", "daq_gain", "daq_offset",
                       "daq_linearity", "daq_resolution", "sensor_temperature")),
    Method(
        name="response", family="response", title="frequency response",
        package=_m("response"), kinds=("response",), formats=("accelcal.io.formats.response",),
        rig="accelcal.rigs.shaker_response", cli="accelcal.cli.response",
        cli_help=("Frequency response of an accelerometer: by comparison with a reference on a "
                  "shaker (ISO 16063-21, stepped sine or broadband), by laser interferometry "
                  "(ISO 16063-11) or by gravity on a rotating table (ISO 16063-16): simulate "
                  "records, reduce them to magnitude and phase, fit the transfer function, "
                  "plan the test."),
        verbs=("simulate", "reduce", "plan"),
        report="accelcal.methods.response.report_text", docs="docs/response.md",
        paper="ISO16063-21", demo="accelcal.methods.response.demo", demo_order=9,
        demo_sensors="one", demo_test="shaker frequency response",
        budget_inputs=("reference_sensitivity", "reference_phase", "daq_gain",
                       "daq_linearity", "daq_gain_mismatch", "daq_delay_mismatch",
                       "transverse_motion", "transverse_sensitivity", "distortion",
                       "relative_motion", "sensor_temperature", "sensitivity_tc",
                       "frequency")),
)
"""Every test method, in the order ``accelcal --help`` lists their groups."""


def method(name: str) -> Method:
    """The descriptor of the method called ``name``.

    Raises
    ------
    KeyError
        For a name that is not a method's.
    """
    for m in METHODS:
        if m.name == name:
            return m
    raise KeyError(name)


def families() -> dict[str, str]:
    """Reduction family -> method package."""
    return {m.family: m.package for m in METHODS}


def kinds() -> dict[str, str]:
    """Record kind -> format module, in the methods' order."""
    return {k: f for m in METHODS for k, f in zip(m.kinds, m.formats, strict=True)}


def demo_methods() -> tuple[Method, ...]:
    """The methods with a demo stage, in the demo's order."""
    return tuple(sorted((m for m in METHODS if m.demo), key=lambda m: m.demo_order))


def listed(names, last: str = "or") -> str:
    """``a, b, c or d``: names as a sentence lists them."""
    names = list(names)
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} {last} {names[-1]}"


def resolve(path: str):
    """The object a dotted path names, attribute by attribute, importing modules on the way.

    ``accelcal.rigs.shaker.ShakerRig.simulate`` is the method ``simulate`` of
    the class ``ShakerRig`` of module ``accelcal.rigs.shaker``; a package's
    attribute comes before its submodule of the same name
    (``accelcal.methods.vre.identify`` is the function).
    """
    parts = path.split(".")
    obj = importlib.import_module(parts[0])
    for i, part in enumerate(parts[1:], start=2):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            obj = importlib.import_module(".".join(parts[:i]))
    return obj
