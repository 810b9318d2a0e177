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


def test_import_accelcal_loads_no_numpy_until_a_public_name_is_used():
    # The root's names are imported on first use: `accelcal --help` never loads numpy.
    assert "numpy" not in _loaded_after("import accelcal")
    loaded = _loaded_after("from accelcal import ErrorModel, Reduction, default_model")
    assert "numpy" in loaded
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_an_unknown_root_name_is_an_attribute_error():
    import pytest

    import accelcal

    assert {"ErrorModel", "Reduction", "default_model", "__version__"} <= set(dir(accelcal))
    assert set(accelcal.__all__) <= set(dir(accelcal))
    with pytest.raises(AttributeError, match="no_such_name"):
        accelcal.no_such_name  # noqa: B018
    assert accelcal.model.ErrorModel is accelcal.ErrorModel  # a submodule, imported on use


def test_help_loads_no_numpy():
    code = ("import sys\nfrom accelcal.cli import main\ntry:\n    main(['--help'])\n"
            "except SystemExit:\n    pass\nprint('NUMPY', 'numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.rstrip().endswith("NUMPY False")


def test_cli_app_import_does_not_load_plotting_or_tables():
    # What `accelcal --help` imports: typer and rich, but not the numeric extras.
    loaded = _loaded_after("import accelcal.cli.app")
    assert "typer" in loaded
    assert not loaded & {"matplotlib", "pandas", "scipy", "dask", "sqlalchemy"}


def test_noise_adev_on_a_record_imports_only_what_it_uses(tmp_path):
    """A command imports no module it does not use: ``noise adev`` on a Parquet record
    reads it with pyarrow and computes with numpy and scipy.special, and loads neither
    pandas (pyarrow's to_numpy shim), nor scipy.stats (one chi-square quantile), nor the
    plotting, tables or store libraries."""
    import numpy as np

    from accelcal.io.formats.noise import write_blocks

    path = tmp_path / "still.parquet"
    write_blocks(path, [np.random.default_rng(0).standard_normal((4096, 1))], rate=100.0,
                 unit="g")
    code = ("import sys\nfrom accelcal.cli import main\ntry:\n"
            f"    main(['noise', 'adev', {str(path)!r}])\nexcept SystemExit as e:\n"
            "    assert not e.code, e.code\n"
            "print('LOADED', ' '.join(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('pandas', 'matplotlib', 'sqlalchemy', 'jinja2', 'dask', 'h5py', 'nptdms') "
            "or m == 'scipy.stats')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.rstrip().splitlines()[-1].strip() == "LOADED", out.splitlines()[-1]
