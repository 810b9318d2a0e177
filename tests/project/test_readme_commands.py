"""The README's examples run in order, as a user runs them after the install.

Every ``sh`` block (but the two set-up commands, which make virtual
environments) and every ``python`` block of README.md runs in document order
in one empty directory, with ``accelcal`` the command of the package under
test, so no command may need a file the README never makes. The records
store is a file in that directory, not the user's.
"""

import importlib.util
import os
import re
import subprocess
import sys

import pytest

from helpers.paths import ROOT

README = ROOT / "README.md"
BLOCK = re.compile(r"(<!-- (?:main|test)-command -->\n)?```(sh|python)\n(.*?)```", re.DOTALL)
DASK_NOTE = "needs accelcal[dask]"


def steps(text: str) -> list[tuple[str, str]]:
    """(language, code) in document order: each command of a ``sh`` block, each python block.

    A command continued with a trailing backslash is joined into one line;
    blank and comment lines are dropped; the set-up blocks are left out.
    """
    out = []
    for match in BLOCK.finditer(text):
        setup, language, body = match.groups()
        if setup:
            continue
        if language == "python":
            out.append(("python", body))
            continue
        for line in body.replace("\\\n", " ").splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                out.append(("sh", line.strip()))
    return out


def test_steps_are_found_and_the_setup_commands_left_out():
    found = steps(README.read_text(encoding="utf-8"))
    commands = [code for language, code in found if language == "sh"]
    assert len(commands) > 30
    assert all(code.startswith("accelcal ") for code in commands)
    assert not any("venv" in code or "pip install" in code for code in commands)
    assert [language for language, _ in found].count("python") >= 2


def test_a_command_needing_dask_says_so():
    for _, code in steps(README.read_text(encoding="utf-8")):
        if "--workers" in code or "--scheduler" in code:
            assert DASK_NOTE in code, code


@pytest.fixture
def user_dir(tmp_path):
    """An empty directory and the environment of a user there: ``accelcal`` on PATH."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "accelcal"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m accelcal "$@"\n')
    shim.chmod(0o755)
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "ACCELCAL_DB"}
    env.update(PATH=f"{bin_dir}{os.pathsep}{env.get('PATH', '')}", MPLBACKEND="Agg",
               XDG_DATA_HOME=str(tmp_path / "data"), COLUMNS="200")
    return work, env


@pytest.mark.slow  # about 50 s of CPU: some 40 processes, a million-trial study
@pytest.mark.skipif(sys.platform == "win32", reason="the README's commands are POSIX shell")
def test_every_readme_command_runs_in_order(user_dir):
    work, env = user_dir
    has_dask = importlib.util.find_spec("dask") is not None
    for language, code in steps(README.read_text(encoding="utf-8")):
        if language == "sh" and DASK_NOTE in code and not has_dask:
            continue
        args = [sys.executable, "-c", code] if language == "python" else ["/bin/sh", "-c", code]
        done = subprocess.run(args, cwd=work, env=env, capture_output=True, text=True,
                              timeout=600, check=False)
        assert done.returncode == 0, f"{code}\n{done.stderr[-2000:]}"
        assert "Traceback" not in done.stderr, f"{code}\n{done.stderr[-2000:]}"
    assert (work / "corrected.csv").is_file()
    assert (work / "run.parquet").is_file()
    assert (work / "sn1.html").is_file()
    assert (work.parent / "data" / "accelcal" / "records.sqlite").is_file()  # not the user's
