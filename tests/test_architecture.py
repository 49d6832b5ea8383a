"""docs/ARCHITECTURE.md names every module of the package and of the command line.

A module is named by its path below the package, as the document writes it (``engine.py``,
``planning/core/task.py``, ``cli/app.py``); a package's ``__init__.py`` is named by the package's
folder (``planning/``). A new module without a line in the document fails here.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "ARCHITECTURE.md"


def modules() -> list[str]:
    """Every module's name as the document should write it."""
    names = []
    for package, prefix in (("frcontrol", ""), ("cli", "cli/")):
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = path.relative_to(ROOT / package).as_posix()
            if relative == "__init__.py" or relative == "__main__.py":
                continue
            if relative.endswith("/__init__.py"):
                relative = relative.removesuffix("__init__.py")
            names.append(prefix + relative)
    return names


def named(text: str, module: str) -> bool:
    """The document names ``module`` in full, or by its last parts under a heading of its folder
    (``core/task.py`` for ``planning/core/task.py``), or as a bare file name in backticks."""
    parts = module.split("/")
    candidates = {"/".join(parts[k:]) for k in range(len(parts)) if "/".join(parts[k:])}
    return any(re.search(r"(?<![\w/.])" + re.escape(c) + r"(?![\w])", text) for c in candidates)


def test_every_module_is_named():
    text = DOC.read_text(encoding="utf-8")
    found = modules()
    assert len(found) > 40, found
    missing = [m for m in found if not named(text, m)]
    assert not missing, f"docs/ARCHITECTURE.md does not name: {', '.join(missing)}"


def test_the_check_can_fail():
    assert named("`engine.py` builds", "engine.py")
    assert not named("`engine.py` builds", "engines.py")
    assert named("planning/core/task.py", "planning/core/task.py")
    assert named("`core/task.py` reads", "planning/core/task.py")
    assert not named("`task.py` is elsewhere", "planning/core/tasks.py")


LAYERS: list[tuple[str, ...]] = [
    ("errors", "jsonable", "records"),
    ("scene_schema",),
    ("kernel", "_kernel"),
    ("model", "urdf", "plane", "drives", "springs", "cholesky"),
    ("scene", "scene_source", "scene_tables", "scene_numbers"),
    ("geometry", "polytope", "solvers"),
    ("modes", "response", "mode_batch", "ambiguity_polygon"),
    ("engine", "query", "lcp", "contact_lcp", "siconos"),
    ("simulation", "statics", "stability"),
    ("atlas", "planning"),
    ("viz",),
    ("answers",),
    ("cli", "service", "__main__"),
]
"""frcontrol's layers, lowest first, as docs/ARCHITECTURE.md draws them: a module imports from its own
layer or below, never above (imports inside functions count too)."""


def layer_of(module: str) -> int | None:
    """The layer of ``frcontrol.``-relative ``module`` (its first part), None for the package itself."""
    top = module.split(".")[0]
    return next((i for i, names in enumerate(LAYERS) if top in names), None)


def imports_upwards(source: str, module: str, is_package: bool) -> list[str]:
    """The imports of ``module`` (``frcontrol``-relative, dotted) that reach a higher layer."""
    own = layer_of(module)
    parts = module.split(".") if module else []
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = parts if is_package else parts[:-1]
            base = base[:len(base) - node.level + 1]
            targets = [".".join([*base, node.module])] if node.module else [".".join([*base, a.name])
                                                                          for a in node.names]
        elif node.module and node.module.startswith("frcontrol."):
            targets = [node.module.removeprefix("frcontrol.")]
        else:
            continue
        for target in targets:
            layer = layer_of(target.lstrip("."))
            if own is not None and layer is not None and layer > own:
                found.append(target)
    return found


def test_the_layers_run_one_way():
    upwards = {}
    count = 0
    for path in sorted((ROOT / "frcontrol").rglob("*.py")):
        relative = path.relative_to(ROOT / "frcontrol").with_suffix("").as_posix().replace("/", ".")
        is_package = path.name == "__init__.py"
        module = relative.removesuffix(".__init__").removesuffix("__init__")
        if layer_of(module) is None and module:
            upwards[module] = ["(not in LAYERS: add it, and to docs/ARCHITECTURE.md's figure)"]
            continue
        count += 1
        if found := imports_upwards(path.read_text(encoding="utf-8"), module, is_package):
            upwards[module] = found
    assert count > 40
    assert not upwards, f"imports to a higher layer: {upwards}"


def test_an_upward_import_is_caught():
    assert imports_upwards("from .engine import analyze\n", "modes", False) == ["engine"]
    assert imports_upwards("def f():\n    from ..planning import flip\n", "simulation.rigid", False) \
        == ["planning"]
    assert imports_upwards("from .modes import ContactProblem\n", "engine", False) == []
    assert imports_upwards("from frcontrol.answers import x\n", "viz.figures", False) == ["answers"]


def test_every_package_is_installed():
    """pyproject.toml lists its packages by hand: a new sub-package left out installs nothing of it
    (an editable install hides that; CI's non-editable one does not)."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
                 ["tool"]["setuptools"]["packages"])
    found = {".".join(("frcontrol", *init.parent.relative_to(ROOT / "frcontrol").parts))
             for init in (ROOT / "frcontrol").rglob("__init__.py")} | {"frcontrol.cli", "frcontrol.robots"}
    assert found <= listed, f"packages missing from pyproject.toml: {sorted(found - listed)}"


def test_no_test_puts_the_checkout_first_on_the_path():
    """A test that puts the checkout first on ``sys.path`` makes every process the later tests spawn
    (service and Dask workers) import the source tree's ``frcontrol``, which has no
    ``frcontrol.robots``: they fail in CI, on the installed package, and nowhere else."""
    offenders = [path.name for path in sorted((ROOT / "tests").glob("*.py"))
                 if re.search(r"sys\.path\.insert\(\s*0", path.read_text(encoding="utf-8"))
                 and path.name != "test_architecture.py"]
    assert not offenders, f"use sys.path.append for the checkout in: {offenders}"


# ---------------------------------------------------------------------------------------------
# the import graph: no circle, and no import inside a function without a listed reason

PACKAGES = ("frcontrol", "cli")

LAZY_IMPORTS: dict[tuple[str, str], str] = {
    # start-up: the front doors load a command's library when the command runs
    ("cli.*", "frcontrol"): "`frc --help`, completion and option errors load no Pinocchio, SciPy or "
                            "engine (cli.app imports in 0.2 s, frcontrol.engine alone in 0.8 s)",
    ("cli", "cli.app"): "the entry point imports the command line inside its try: a Ctrl-C while it "
                        "loads exits 130 with one line",
    ("cli.*", "numpy"): "as above: `frc --help` loads no NumPy",
    ("cli.*", "matplotlib"): "plotting is loaded by the commands that draw (0.8 s)",
    ("cli.*", "rich"): "the progress bar is loaded when a long run starts",
    ("cli.*", "uvicorn"): "`frc serve` alone needs the server (the `serve` extra)",
    ("frcontrol.answers", "frcontrol"): "one function per command: the service's process and a "
                                        "command import answers.py without every command's library",
    ("frcontrol.service.*", "frcontrol"): "the server's process loads no engine, planner or simulator: "
                                          "its workers do, in warm_up, before their memory limit",
    ("frcontrol.service.work", "scipy"): "warm_up loads SciPy's LAPACK (and Qhull) before the memory limit",
    ("frcontrol.service.api", "fastapi"): "the offline API docs' parts load when the docs routes are added",
    ("frcontrol.service.api", "fastapi_offline"): "as above; an optional package",
    ("frcontrol.simulation", "frcontrol.simulation"): "the package and its INTEGRATORS import without "
                                                      "SciPy; simulate() loads its simulator",
    ("frcontrol.kernel", "frcontrol._kernel"): "the compiled kernel is optional (FRC_KERNEL)",
    ("frcontrol.atlas.*", "frcontrol"): "frcontrol.atlas plans a sweep without the engine, statics or "
                                        "planners; a sweep's worker imports what its `what` needs",
    ("frcontrol.atlas.*", "pyarrow"): "Parquet output is loaded when a table is written or read",
    ("frcontrol.atlas.executors", "distributed"): "Dask is optional (the `cluster` extra)",
    ("frcontrol.viz.*", "matplotlib"): "plotting is optional and slow to import (0.8 s)",
    ("frcontrol.viz.*", "meshcat"): "the 3D viewer is optional (the `viz` extra)",
    ("frcontrol.viz.*", "umsgpack"): "as above: meshcat's message packing",
    ("frcontrol.viz.*", "trimesh"): "mesh files are read only for links drawn from meshes",
    ("frcontrol.viz.meshcat_view", "frcontrol.simulation.samples"):
        "the viewer draws scenes without loading the simulators",
    ("frcontrol.scene_schema", "pydantic_core"): "the scene validator is compiled at the first scene "
                                                 "load: `frc --help` loads no pydantic-core",
    ("frcontrol.geometry", "scipy.spatial"): "Qhull serves the statics' wrench hulls alone: the engine "
                                             "imports without it (60 ms of CPU for the commands and "
                                             "atlas workers that need no hull nor scipy.integrate)",
}
"""Every import inside a function, as ``(importer, imported) -> the reason it is not at the top``.

``importer`` is a module (``frcontrol.simulation``) or, ending in ``.*``, every module of a package
(``cli.*``); ``imported`` names a module and everything below it (``matplotlib`` covers
``matplotlib.patches``). Imports of the standard library are exempt (they cost nothing measurable
and hide no circle of ours), and so are imports under ``if TYPE_CHECKING:`` (never executed)."""


def _module_name(path: Path, root: Path) -> str:
    """``frcontrol.simulation.rigid`` for ``frcontrol/simulation/rigid.py``; a package by its folder."""
    return path.relative_to(root).with_suffix("").as_posix().replace("/", ".").removesuffix(".__init__")


def _type_checking_only(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports_of(source: str, module: str, is_package: bool) -> list[tuple[str, bool]]:
    """``(absolute target, inside a function)`` for every executed import of one module.

    ``from X import y`` targets ``X.y`` when that is a module of ours (the caller decides: both are
    returned as ``X.y`` and resolved against the known modules), else ``X``.
    """
    parts = module.split(".")
    found: list[tuple[str, bool]] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking_only(child):
                for other in child.orelse:
                    visit(other, in_function)
                continue
            if isinstance(child, ast.Import):
                found.extend((alias.name, in_function) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = parts if is_package else parts[:-1]
                    base = base[:len(base) - child.level + 1]
                    origin = ".".join([*base, child.module] if child.module else base)
                else:
                    origin = child.module or ""
                found.extend((f"{origin}.{alias.name}", in_function) for alias in child.names)
            visit(child, in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                           ast.Lambda)))

    visit(ast.parse(source), False)
    return found


def _resolve(target: str, modules: set[str]) -> str:
    """``target`` as one of ``modules`` when it or its parent is one (``from X import y``), else itself."""
    if target in modules:
        return target
    parent = target.rsplit(".", 1)[0]
    return parent if parent in modules else target


def import_graph(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES
                 ) -> tuple[dict[str, set[str]], list[tuple[str, str]]]:
    """The packages' import graph (module -> modules of ours it imports, anywhere in its code) and
    every import inside a function as ``(importer, target)``."""
    paths = {_module_name(path, root): path for package in packages
             for path in sorted((root / package).rglob("*.py"))}
    modules = set(paths) | {_module_name(path, root) for package in packages   # compiled: _kernel.c
                            for path in (root / package).rglob("*.c")}
    graph: dict[str, set[str]] = {}
    inner: list[tuple[str, str]] = []
    for module, path in paths.items():
        graph.setdefault(module, set())
        for target, in_function in imports_of(path.read_text(encoding="utf-8"), module,
                                              path.name == "__init__.py"):
            resolved = _resolve(target, modules)
            if resolved in modules and resolved != module:
                graph[module].add(resolved)
            if in_function:
                inner.append((module, resolved))
    return graph, inner


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                connect(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return found


def test_the_import_graph_has_no_circle():
    graph, _ = import_graph()
    assert len(graph) > 60 and sum(map(len, graph.values())) > 200, "too few modules or imports found"
    assert not circles(graph), f"import circles (move the shared piece down): {circles(graph)}"


def test_a_circle_is_caught(tmp_path):
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from .b import x\n")
    (package / "b.py").write_text("def f():\n    from .c import y\n")
    (package / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                  "    from .d import z\nfrom pkg import a\n")
    (package / "d.py").write_text("from . import c\n")
    graph, inner = import_graph(tmp_path, ("pkg",))
    assert graph["pkg.b"] == {"pkg.c"} and graph["pkg.c"] == {"pkg.a"} and graph["pkg.d"] == {"pkg.c"}
    assert circles(graph) == [["pkg.a", "pkg.b", "pkg.c"]]
    assert inner == [("pkg.b", "pkg.c.y")] or inner == [("pkg.b", "pkg.c")]


def _listed(importer: str, target: str) -> tuple[str, str] | None:
    """The ``LAZY_IMPORTS`` key that allows ``importer`` to import ``target`` inside a function."""
    for key in LAZY_IMPORTS:
        who, what = key
        if (importer == who or (who.endswith(".*") and importer.startswith(who[:-1]))) and (
                target == what or target.startswith(what + ".")):
            return key
    return None


def _standard_library(target: str) -> bool:
    return target.split(".")[0] in sys.stdlib_module_names


def test_every_import_inside_a_function_is_listed():
    _, inner = import_graph()
    assert len(inner) > 50
    unlisted = sorted({f"{who} -> {what}" for who, what in inner
                       if not _standard_library(what) and _listed(who, what) is None})
    assert not unlisted, ("imports inside functions not in LAZY_IMPORTS (move them to the top, or "
                          f"list them with the start-up reason): {unlisted}")
    used = {_listed(who, what) for who, what in inner}
    assert not set(LAZY_IMPORTS) - used, f"LAZY_IMPORTS rows no import uses: {set(LAZY_IMPORTS) - used}"


def test_an_unlisted_import_inside_a_function_is_caught():
    assert _listed("frcontrol.engine", "frcontrol.planning.flip") is None
    assert _standard_library("importlib.metadata") and not _standard_library("matplotlib.pyplot")


def test_no_two_modules_share_a_file_name():
    """Within the installed package: the library and the command line (``cli/``, installed as
    ``frcontrol.cli``)."""
    names: dict[str, list[str]] = {}
    for package in ("frcontrol", "cli"):
        for path in (ROOT / package).rglob("*.py"):
            if path.name not in ("__init__.py", "__main__.py"):
                names.setdefault(path.name, []).append(path.relative_to(ROOT).as_posix())
    shared = {name: paths for name, paths in names.items() if len(paths) > 1}
    assert not shared, f"modules with one file name: {shared}"
