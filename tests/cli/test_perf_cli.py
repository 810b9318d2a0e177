"""`accelcal --help` lists every group without importing them (issue 16: start-up time)."""

import importlib
import subprocess
import sys

import typer

from accelcal.cli.app import GROUPS, app


def test_each_group_help_in_the_table_is_the_groups_own():
    for name, (module, text) in GROUPS.items():
        assert importlib.import_module(module).app.info.help == text, name


def test_help_lists_every_group_and_imports_none_of_them():
    modules = sorted(m for m, _ in GROUPS.values())
    code = (
        "import sys\n"
        "from accelcal.cli import main\n"
        "try:\n"
        "    main(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        f"print('LOADED', sorted(set({modules!r}) & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={"COLUMNS": "200", "PATH": ""}).stdout
    assert out.rstrip().endswith("LOADED []")
    listing = out[: out.index("LOADED")]
    for name in (*GROUPS, "demo", "import", "inspect", "report"):
        assert f" {name} " in listing, name


def test_the_command_tree_holds_every_group_with_its_commands():
    root = typer.main.get_command(app)
    assert set(GROUPS) <= set(root.commands)
    vre = root.commands["vre"]
    assert {"fit", "reduce", "simulate"} <= set(vre.commands)
    assert vre.help == GROUPS["vre"][1]
