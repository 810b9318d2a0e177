"""The top-level typer application and its command groups."""

import typer

from accelcal import __version__
from accelcal.cli import model as model_cmd

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
