"""`import accelcal` stays light; the command line imports no numeric extras for --help."""

import subprocess
import sys

HEAVY = ("matplotlib", "pandas", "dask", "distributed", "sqlalchemy", "jinja2",
         "typer", "click", "rich", "scipy")


def _loaded_after(statement: str) -> set[str]:
    code = (
        f"import sys; {statement}; "
        "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_import_accelcal_loads_no_heavy_module():
    loaded = _loaded_after("import accelcal")
    assert "accelcal" in loaded
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_cli_app_import_does_not_load_plotting_or_tables():
    # What `accelcal --help` imports: typer and rich, but not the numeric extras.
    loaded = _loaded_after("import accelcal.cli.app")
    assert "typer" in loaded
    assert not loaded & {"matplotlib", "pandas", "scipy", "dask", "sqlalchemy"}
