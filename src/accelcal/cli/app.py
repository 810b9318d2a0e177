"""The top-level typer application and its command groups."""

import typer

from accelcal import __version__
from accelcal.cli import centrifuge as centrifuge_cmd
from accelcal.cli import demo as demo_cmd
from accelcal.cli import dividing_head as dividing_head_cmd
from accelcal.cli import importer as importer_cmd
from accelcal.cli import model as model_cmd
from accelcal.cli import noise as noise_cmd
from accelcal.cli import records as records_cmd
from accelcal.cli import report as report_cmd
from accelcal.cli import thermal as thermal_cmd
from accelcal.cli import transverse as transverse_cmd
from accelcal.cli import triad as triad_cmd
from accelcal.cli import tumble as tumble_cmd
from accelcal.cli import vre as vre_cmd

app = typer.Typer(
    name="accelcal",
    help=(
        "Test and calibrate inertial (pendulous) accelerometers: error model, "
        "rig simulators, reductions with uncertainty."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
app.add_typer(model_cmd.app, name="model")
app.add_typer(vre_cmd.app, name="vre")
app.add_typer(transverse_cmd.app, name="transverse")
app.add_typer(dividing_head_cmd.app, name="dividing-head")
app.add_typer(tumble_cmd.app, name="tumble")
app.add_typer(triad_cmd.app, name="triad")
app.add_typer(noise_cmd.app, name="noise")
app.add_typer(thermal_cmd.app, name="thermal")
app.add_typer(centrifuge_cmd.app, name="centrifuge")
app.command("demo")(demo_cmd.demo)
app.command("import")(importer_cmd.import_)
app.command("inspect")(importer_cmd.inspect)
app.add_typer(records_cmd.app, name="records")
app.command("report")(report_cmd.report)


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
