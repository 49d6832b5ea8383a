"""docs/ARCHITECTURE.md names every module of the package and of the command line.

A module is named by its path below the package, as the document writes it (``engine.py``,
``planning/core/task.py``, ``cli/app.py``); a package's ``__init__.py`` is named by the package's
folder (``planning/``). A new module without a line in the document fails here.
"""

from __future__ import annotations

import ast
import re
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
    ("polytope", "solvers"),
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
