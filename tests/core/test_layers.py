"""The floors of the package, read from its imports.

Every module of ``src/accelcal`` is parsed with :mod:`ast` (nothing is
imported); every ``import`` and ``from ... import`` at module level and
inside functions is resolved relative to the package. The floors, bottom up
(docs/api.md, "Floors"):

1. ground: the package root, ``errors``, ``validation`` (standard library only);
2. base: ``units``, ``terms``, ``formatting``, ``resources``, ``work``, ``identifiability``, and the
   method descriptors and ids (``catalog``, ``method_ids``), plain data every floor reads;
3. ``physics``: frames, positions, geometry, normal gravity;
4. the domain model: ``model``, ``results`` and the numeric helpers beside them;
5. ``io``;
6. ``signal`` and ``plotting``;
7. ``rigs`` and ``methods`` side by side, and ``calibration``;
8. the top: the store, reports, the campaign, the demo, the command line.

A module-level import never runs up a floor. A few imports inside
functions do (convenience entry points such as ``Reduction.plot`` or
``ErrorModel.save``): they are listed in :data:`LAZY_UP` with their reason,
and a new one fails until it is moved down or listed.
"""

import ast
import importlib.util
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

FLOORS = (
    ("ground", ("accelcal", "accelcal.errors", "accelcal.validation")),
    ("base", ("accelcal.units", "accelcal.terms", "accelcal.formatting", "accelcal.resources",
              "accelcal.work", "accelcal.identifiability", "accelcal.catalog",
              "accelcal.method_ids")),
    ("physics", ("accelcal.physics",)),
    ("domain model", ("accelcal.model", "accelcal.defaults", "accelcal.engineering",
                      "accelcal.aliasing", "accelcal.interval", "accelcal.outputs",
                      "accelcal.results",
                      "accelcal.polar", "accelcal.fitting",
                      "accelcal.uncertainty", "accelcal.montecarlo", "accelcal.parallel")),
    ("io", ("accelcal.io",)),
    ("signal", ("accelcal.signal", "accelcal.plotting")),
    ("rigs and methods", ("accelcal.rigs", "accelcal.methods", "accelcal.calibration",
                          "accelcal.budget")),
    ("top", ("accelcal.store", "accelcal.report", "accelcal.certificate", "accelcal.pipeline",
             "accelcal.demo", "accelcal.cli")),
)
"""Floors bottom up, each a tuple of modules and packages (a package holds its submodules)."""

LAZY_UP = {
    ("accelcal.model", "accelcal.io.model_file"):
        "ErrorModel.to_dict/from_dict/to_json/from_json/save/load: the model file is io's",
    ("accelcal.results", "accelcal.io.limits"): "Reduction.from_json: io's bounded JSON reader",
    ("accelcal.resources", "accelcal.io.limits"):
        "available_memory: the process's memory limit is io's limits (memory_limit)",
    ("accelcal.results", "accelcal.calibration"): "Reduction.to_records",
    ("accelcal.results", "accelcal.methods"): "Reduction.figures: the method's figures",
    ("accelcal.results", "accelcal.plotting"): "Reduction.plot",
    **{(f"accelcal.methods.{m}.demo", "accelcal.pipeline"): "the method's demo stage"
       for m in ("acceptance", "centrifuge", "dividing_head", "noise", "response", "thermal",
                 "transverse",
                 "triad", "vre")},
}
"""Imports inside functions that run up a floor, with the reason each is allowed."""

DOMAIN_MODEL = ("accelcal.model", "accelcal.terms", "accelcal.units", "accelcal.results")


@dataclass(frozen=True)
class Import:
    """One imported accelcal module: who imports it, where, and whether only when called."""

    source: str
    target: str
    line: int
    lazy: bool


def find_modules(root: Path, package: str = "accelcal") -> dict[str, Path]:
    """Every module under ``root`` (the package's directory), by dotted name."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = [package, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def read_imports(name: str, path: Path, modules, package: str = "accelcal") -> list[Import]:
    """The package's modules that ``name`` imports, at module level and inside functions.

    ``from X import a`` imports ``X.a`` when that is a module, else ``X``;
    relative imports are resolved against the importing module's package.
    """
    here = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []

    def visit(node, lazy):
        for child in ast.iter_child_nodes(node):
            inner = lazy or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
            if isinstance(child, ast.Import):
                found.extend(Import(name, a.name, child.lineno, lazy) for a in child.names
                             if a.name.split(".")[0] == package)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = here.split(".")[: len(here.split(".")) - child.level + 1]
                    target = ".".join([*base, *([child.module] if child.module else [])])
                else:
                    target = child.module or ""
                if target.split(".")[0] != package:
                    continue
                for a in child.names:
                    sub = f"{target}.{a.name}"
                    found.append(Import(name, sub if sub in modules else target, child.lineno,
                                        lazy))
            else:
                visit(child, inner)

    visit(ast.parse(path.read_text(encoding="utf-8"), str(path)), False)
    return found


def import_graph(root: Path, package: str = "accelcal") -> tuple[dict, list[Import]]:
    modules = find_modules(root, package)
    imports = [imp for name, path in modules.items()
               for imp in read_imports(name, path, modules, package)]
    return modules, imports


def find_cycle(nodes, imports) -> list[str] | None:
    """One import cycle (``[a, b, ..., a]``) among ``nodes``, or None (depth-first search)."""
    edges = {n: sorted({i.target for i in imports if i.source == n and i.target != n
                        and i.target in nodes}) for n in nodes}
    state, stack = {}, []

    def dfs(node):
        state[node] = "open"
        stack.append(node)
        for nxt in edges[node]:
            if state.get(nxt) == "open":
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state and (cycle := dfs(nxt)):
                return cycle
        state[node] = "done"
        stack.pop()
        return None

    for node in sorted(nodes):
        if node not in state and (cycle := dfs(node)):
            return cycle
    return None


def floor_of(module: str) -> int:
    """Index in :data:`FLOORS` of a module (anything unlisted is on the top floor)."""
    for k, (_, members) in enumerate(FLOORS):
        if any(module == m or (m != "accelcal" and module.startswith(m + "."))
               for m in members):
            return k
    return len(FLOORS) - 1


def _within(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


@pytest.fixture(scope="module")
def graph():
    spec = importlib.util.find_spec("accelcal")
    return import_graph(Path(spec.origin).parent)


def test_every_import_resolves_to_a_module(graph):
    modules, imports = graph
    assert len(modules) > 150
    assert len(imports) > 500
    missing = sorted({(i.source, i.target) for i in imports if i.target not in modules})
    assert missing == []


def test_no_import_cycle(graph):
    modules, imports = graph
    cycle = find_cycle(set(modules), imports)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_no_rig_imports_a_method(graph):
    _, imports = graph
    bad = sorted({f"{i.source}:{i.line} imports {i.target}" for i in imports
                  if _within(i.source, "accelcal.rigs") and _within(i.target, "accelcal.methods")})
    assert bad == [], "rigs import the physics, never a method: " + "; ".join(bad)


def test_signal_and_domain_model_import_nothing_from_io(graph):
    _, imports = graph
    bad = sorted({f"{i.source}:{i.line} imports {i.target}" for i in imports
                  if (_within(i.source, "accelcal.signal") or i.source in DOMAIN_MODEL)
                  and _within(i.target, "accelcal.io") and (i.source, i.target) not in LAZY_UP})
    assert bad == []
    # The allowed ones are file entry points (ErrorModel.save, Reduction.from_json, ...),
    # and only inside them.
    assert all(i.lazy for i in imports if (i.source, i.target) in LAZY_UP)


def test_ground_floor_imports_only_errors_and_the_standard_library(graph):
    modules, imports = graph
    ground = FLOORS[0][1]
    inside = {(i.source, i.target) for i in imports if i.source in ground}
    assert inside <= {("accelcal.validation", "accelcal.errors")}
    for name in ground:
        tree = ast.parse(modules[name].read_text(encoding="utf-8"))
        tops = {a.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                for a in node.names}
        tops |= {node.module.split(".")[0] for node in ast.walk(tree)
                 if isinstance(node, ast.ImportFrom) and node.module and not node.level}
        assert tops - {"accelcal"} <= set(sys.stdlib_module_names), name


def test_physics_imports_only_the_floors_below_it(graph):
    _, imports = graph
    physics = floor_of("accelcal.physics")
    bad = [f"{i.source} imports {i.target}" for i in imports
           if _within(i.source, "accelcal.physics") and floor_of(i.target) > physics]
    assert bad == []


def test_no_module_level_import_runs_up_a_floor(graph):
    _, imports = graph
    bad = sorted({f"{i.source}:{i.line} ({FLOORS[floor_of(i.source)][0]}) imports {i.target} "
                  f"({FLOORS[floor_of(i.target)][0]})" for i in imports
                  if floor_of(i.target) > floor_of(i.source) and not i.lazy})
    assert bad == []


def test_imports_inside_functions_run_up_only_where_listed(graph):
    _, imports = graph
    up = {(i.source, i.target) for i in imports if floor_of(i.target) > floor_of(i.source)}
    assert up - set(LAZY_UP) == set(), ("an import runs up a floor: move the piece it needs "
                                        "down a floor, or list it in LAZY_UP with its reason")


def test_lower_floors_load_no_io_and_no_method_when_imported():
    """At run time too, where parent packages' ``__init__`` modules are imported as well."""
    code = ("import sys\n"
            "import accelcal.model, accelcal.results, accelcal.signal.static, "
            "accelcal.signal.allan, accelcal.signal.sinefit, accelcal.signal.periods, "
            "accelcal.physics.tumble, accelcal.physics.centrifuge, accelcal.physics.gravity\n"
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('accelcal.'))))\n")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.split()
    assert {"accelcal.model", "accelcal.physics.tumble", "accelcal.signal.allan"} <= set(loaded)
    assert [m for m in loaded if m.startswith(("accelcal.io", "accelcal.methods",
                                               "accelcal.rigs"))] == []


# ------------------------------------------------------- the reader, on a known package
def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_reader_resolves_relative_and_lazy_imports_and_finds_a_cycle(tmp_path):
    root = _package(tmp_path, {
        "__init__.py": "",
        "low.py": "import json\n",
        "sub/__init__.py": "from . import a\n",
        "sub/a.py": "from ..low import x\nfrom pkg.sub import b\n",
        "sub/b.py": "def f():\n    from .a import y\n",
    })
    modules, imports = import_graph(root, "pkg")
    got = {(i.source, i.target, i.lazy) for i in imports}
    assert got == {("pkg.sub", "pkg.sub.a", False), ("pkg.sub.a", "pkg.low", False),
                   ("pkg.sub.a", "pkg.sub.b", False), ("pkg.sub.b", "pkg.sub.a", True)}
    assert find_cycle(set(modules), imports) == ["pkg.sub.a", "pkg.sub.b", "pkg.sub.a"]
    acyclic = [i for i in imports if not i.lazy]
    assert find_cycle(set(modules), acyclic) is None


def test_floors_place_packages_and_modules():
    assert floor_of("accelcal") == 0
    assert floor_of("accelcal.validation") == 0
    assert floor_of("accelcal.physics.gravity") == 2
    assert floor_of("accelcal.io.recordings.sources") == 4
    assert floor_of("accelcal.rigs.tumble") == floor_of("accelcal.methods.tumble.reduce")
    assert floor_of("accelcal.modelling") == len(FLOORS) - 1  # a prefix is not a package
