"""The methods' descriptors (accelcal.catalog) against what is derived from them and the docs.

Every registry (methods.REGISTRY, io.formats.KINDS, the command groups, the
demo's stages) is derived from the descriptors; the help texts that list
kinds or tests, docs/api.md, docs/data-formats.md and the README are checked
against them here, so they cannot drift apart again. The last tests follow
docs/api.md's "Adding a method" checklist for every descriptor.
"""

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

from accelcal.catalog import METHODS, VERBS, demo_methods, listed, resolve
from helpers.paths import ROOT, TESTS

NAMES = [m.name for m in METHODS]


def _text(name: str) -> str:
    return (ROOT / name).read_text(encoding="utf-8")


def _help(args, capsys, monkeypatch) -> str:
    """``accelcal ARGS`` (a help), its box drawing removed and white space made single."""
    from accelcal.cli import main

    monkeypatch.setenv("COLUMNS", "120")
    with pytest.raises(SystemExit) as exc:
        main(list(args))
    assert exc.value.code == 0
    out = capsys.readouterr().out
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", out).split())


def _section(text: str, heading: str) -> str:
    start = text.index(f"\n{heading}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else None]


# ------------------------------------------------------------------------------ registries
def test_names_families_kinds_and_groups_are_unique():
    for values in ([m.name for m in METHODS], [m.family for m in METHODS],
                   [k for m in METHODS for k in m.kinds], [m.cli for m in METHODS],
                   [m.demo_order for m in demo_methods()]):
        assert len(values) == len(set(values)), values


def test_registries_are_derived_from_the_descriptors():
    from accelcal.cli.app import GROUPS
    from accelcal.io.formats import KINDS
    from accelcal.methods import REGISTRY

    assert {m.family: m.package for m in METHODS} == REGISTRY
    assert {k: f for m in METHODS for k, f in zip(m.kinds, m.formats, strict=True)} == KINDS
    assert {n: v for n, v in GROUPS.items() if n in NAMES} == {m.name: (m.cli, m.cli_help)
                                                               for m in METHODS}
    assert set(GROUPS) - set(NAMES) == {"model", "records"}  # the groups that are not methods


def test_a_descriptor_refuses_an_unknown_verb_and_unpaired_formats():
    import dataclasses

    head = METHODS[0]
    with pytest.raises(ValueError, match="entry point"):
        dataclasses.replace(head, verbs=("fit",))
    with pytest.raises(ValueError, match="one format module per record kind"):
        dataclasses.replace(head, formats=())


def test_the_demo_runs_one_stage_per_descriptor_in_its_order():
    from accelcal.demo import stages

    found = stages()
    assert [s.simulate.func.__module__ for s in found] == [m.demo for m in demo_methods()]
    assert [m.demo_order for m in demo_methods()] == list(range(1, len(found) + 1))
    assert found[0].simulate.keywords["serials"] == ("ACC-0001", "ACC-0002", "ACC-0003",
                                                     "ACC-0004")
    triad = [m.name for m in demo_methods()].index("triad")
    assert found[triad].simulate.keywords["serial"] == "IMU-0001"


def test_the_catalog_and_formats_package_stay_light():
    code = ("import sys, accelcal.catalog, accelcal.io.formats\n"
            "print(sorted(m for m in sys.modules if m == 'numpy' or m.startswith("
            "('accelcal.methods', 'accelcal.rigs', 'accelcal.cli'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


# ------------------------------------------------------------------------------ help texts
def test_root_help_lists_every_method_group_with_its_help(capsys, monkeypatch):
    text = _help(["--help"], capsys, monkeypatch)
    for m in METHODS:
        assert f" {m.name} {' '.join(m.cli_help.split())}" in text, m.name


def test_import_and_inspect_help_list_every_record_kind(capsys, monkeypatch):
    kinds = listed(sorted(k for m in METHODS for k in m.kinds))
    text = _help(["import", "--help"], capsys, monkeypatch)
    assert f"Record kind: {kinds} (default: the mapping file's)." in text
    text = _help(["inspect", "--help"], capsys, monkeypatch)
    assert f"a record of kind {kinds} (--channels" in text


def test_demo_help_names_every_test_it_runs(capsys, monkeypatch):
    text = _help(["demo", "--help"], capsys, monkeypatch)
    tests = listed((f"{m.demo_test} ({m.paper})" for m in demo_methods()), "and")
    assert f"The tests, in order: {tests}." in text
    assert len(demo_methods()) == 8


# ------------------------------------------------------------------------------ documents
def test_api_md_describes_every_method():
    text = _text("docs/api.md")
    table_row = next(line for line in text.splitlines() if line.startswith("| `family`"))
    methods = _section(text, "## The methods")
    for m in METHODS:
        assert f'`"{m.family}"`' in table_row, m.family
        for module in (m.package, m.rig, *m.formats):
            assert f"`{module}`" in methods, module
    assert "`accelcal.catalog`" in text


def test_api_md_adding_a_method_is_the_checklist():
    steps = _section(_text("docs/api.md"), "## Adding a method")
    for item in ("a package", "a format", "a rig", "a contract subclass", "one descriptor",
                 "`IMPORT`", "(ReductionContract)", "`accelcal.catalog.METHODS`",
                 "docs/errata.md", "documentation page", "tests/project/test_descriptors.py"):
        assert item in steps, item


def test_data_formats_md_documents_every_kind():
    text = _text("docs/data-formats.md")
    kind_row = next(line for line in text.splitlines() if line.startswith("| `kind` |"))
    for m in METHODS:
        for kind, module in zip(m.kinds, m.formats, strict=True):
            assert re.search(rf"^### .*\(`{re.escape(kind)}`\)$", text, re.M), kind
            assert f"| `{kind}` | `{module}` |" in text, kind
            assert f"`{kind}`" in kind_row, kind
        assert f"({Path(m.docs).name})" in text, m.docs


def test_readme_names_every_method_its_page_and_its_commands():
    text = _text("README.md")
    for m in METHODS:
        assert f"[{m.title}]({m.docs})" in text, m.name
        assert f"\naccelcal {m.name} " in text, m.name
    setup = " ".join(text[: text.index("<!-- main-command -->")].split())
    for m in demo_methods():
        assert m.demo_test in setup, m.demo_test


# -------------------------------------------------------- the checklist, for every method
def _contract_files() -> dict[str, str]:
    """Test file (relative path) -> source, for files defining a ReductionContract subclass."""
    found = {}
    for path in sorted(TESTS.rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        if "ReductionContract" not in source:
            continue
        bases = {"ReductionContract"}
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ClassDef) and any(
                    getattr(b, "id", None) in bases for b in node.bases):
                bases.add(node.name)
        if len(bases) > 1:
            found[path.relative_to(TESTS).as_posix()] = source
    return found


CONTRACTS = _contract_files()


@pytest.mark.parametrize("name", NAMES)
def test_package_has_what_the_generic_paths_call(name):
    from accelcal.catalog import method

    m = method(name)
    package = importlib.import_module(m.package)
    assert callable(package.figures)
    assert isinstance(package.ERRATA, tuple)
    assert resolve(m.report) is package.report_text
    if m.demo:  # a method whose records the demo writes: its report rebuilds their figures
        assert callable(package.from_inputs)
    for verb, path in m.entry_points:
        assert verb in VERBS
        assert callable(resolve(path)), path
    assert not {v for v in VERBS if v not in m.verbs and hasattr(package, v)}, \
        "a verb the package defines is missing from its descriptor"
    assert m.entry("reduce"), "every method reduces"
    importlib.import_module(m.rig)
    group = importlib.import_module(m.cli).app
    assert group.info.help == m.cli_help


@pytest.mark.parametrize("name", NAMES)
def test_a_contract_subclass_exists_for_the_family(name):
    from accelcal.catalog import method

    stem = method(name).package.rsplit(".", 1)[1]
    assert any(stem in path for path in CONTRACTS), f"no ReductionContract subclass for {stem}"


@pytest.mark.parametrize("name", NAMES)
def test_docs_page_references_and_errata(name):
    from accelcal.catalog import method

    m = method(name)
    page = ROOT / m.docs
    assert page.is_file(), m.docs
    assert f"accelcal {m.name}" in page.read_text(encoding="utf-8")
    assert re.search(rf"^\| {re.escape(m.paper)} \|", _text("docs/references.md"), re.M), m.paper
    if importlib.import_module(m.package).ERRATA:
        headings = [h.replace(" ", "") for h in re.findall(r"^## (.*)$", _text("docs/errata.md"),
                                                           re.M)]
        assert any(m.paper in h for h in headings), f"docs/errata.md has no {m.paper} section"


SIMULATE_ARGS = {"noise": ["--rate", "50", "--duration", "60"]}
"""Options a method's ``simulate`` command needs besides ``--out`` (default none)."""


@pytest.mark.parametrize("name", NAMES)
def test_format_reads_what_the_method_writes(name, tmp_path, capsys):
    from accelcal.catalog import method
    from accelcal.cli import main
    from accelcal.io.formats import ImportLayout
    from accelcal.io.recordings.kinds import validator

    m = method(name)
    for kind, path in zip(m.kinds, m.formats, strict=True):
        module = importlib.import_module(path)
        assert kind == module.KIND
        assert isinstance(module.IMPORT, ImportLayout)
        assert any(n.startswith("write") and callable(getattr(module, n)) for n in vars(module))
    kind = m.kinds[0]
    out = tmp_path / "run"  # a directory for a kind of one file per record
    with pytest.raises(SystemExit) as exc:
        main([m.name, "simulate", *SIMULATE_ARGS.get(m.name, []), "--out",
              str(out) if kind == "shaker" else f"{out}.csv"])
    assert exc.value.code == 0, capsys.readouterr().err
    written = sorted(out.iterdir())[0] if out.is_dir() else Path(f"{out}.csv")
    data = validator(kind)(written)
    module = importlib.import_module(m.formats[0])
    if hasattr(module, "write") and hasattr(module, "read"):  # write(path, data) round trip
        module.write(tmp_path / "again.csv", data)
        module.write(tmp_path / "twice.csv", module.read(tmp_path / "again.csv"))
        assert (tmp_path / "again.csv").read_bytes() == (tmp_path / "twice.csv").read_bytes()
