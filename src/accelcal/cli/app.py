"""The top-level typer application and its command groups.

Command groups are imported when a command of theirs runs (or a tree of
every command is asked for), not to list them: ``accelcal --help`` shows
each group from its entry in :data:`GROUPS`, so the start-up costs the
commands' modules nothing. A method's group comes from its descriptor
(:mod:`accelcal.catalog`: its module, whose ``app`` is the group, and its
help, which a test keeps equal to the group's own); a group that is not a
method adds one line to :data:`GROUPS`.
"""

import importlib

import typer
from typer.core import TyperGroup

from accelcal import __version__
from accelcal.catalog import METHODS
from accelcal.cli import budget as budget_cmd
from accelcal.cli import demo as demo_cmd
from accelcal.cli import importer as importer_cmd
from accelcal.cli import report as report_cmd
from accelcal.cli.help_format import bare_flags

bare_flags()

GROUPS: dict[str, tuple[str, str]] = {
    "model": ("accelcal.cli.model", (
        "Show, create and evaluate accelerometer error models (model files are JSON).")),
    **{m.name: (m.cli, m.cli_help) for m in METHODS},
    "records": ("accelcal.cli.records", (
        "Store calibration records and follow each serial number: history, repeatability "
        "and drift. Default store: an SQLite file in the user data directory "
        "($ACCELCAL_DB overrides it).")),
}
"""Command group name -> (module whose ``app`` is the group, the group's help): the two
groups that are not methods (``model``, ``records``), and each method's from its
descriptor (:data:`accelcal.catalog.METHODS`)."""


class LazyGroup(TyperGroup):
    """The root command: the groups of :data:`GROUPS` are imported on first use.

    Listing the commands (help) shows a stand-in carrying the group's help;
    running one, or reading :attr:`commands` (the whole tree), imports it.
    """

    @property
    def commands(self) -> dict:
        """Every command and group, the groups imported."""
        for name in GROUPS:
            self._load(name)
        return self._commands

    @commands.setter
    def commands(self, value) -> None:
        self._commands = dict(value)

    def add_command(self, cmd, name: str | None = None) -> None:  # noqa: D102
        self._commands[name or cmd.name] = cmd

    def list_commands(self, ctx) -> list[str]:  # noqa: D102
        return [*self._commands, *(n for n in GROUPS if n not in self._commands)]

    def get_command(self, ctx, cmd_name: str):  # noqa: D102
        if cmd_name in self._commands or cmd_name not in GROUPS:
            return self._commands.get(cmd_name)
        return TyperGroup(name=cmd_name, help=GROUPS[cmd_name][1])

    def resolve_command(self, ctx, args):  # noqa: D102
        if args and args[0] in GROUPS:
            self._load(args[0])
        return super().resolve_command(ctx, args)

    def _load(self, name: str) -> None:
        if name not in self._commands:
            group = typer.main.get_group(importlib.import_module(GROUPS[name][0]).app)
            group.name = name
            self._commands[name] = group


app = typer.Typer(
    name="accelcal",
    cls=LazyGroup,
    help=(
        "Test and calibrate inertial (pendulous) accelerometers: error model, "
        "rig simulators, reductions with uncertainty."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
app.command("demo")(demo_cmd.demo)
app.command("import")(importer_cmd.import_)
app.command("inspect")(importer_cmd.inspect)
app.command("report")(report_cmd.report)
app.command("budget")(budget_cmd.budget)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"accelcal {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Test and calibrate inertial (pendulous) accelerometers."""
