"""docs/ARCHITECTURE.md names every module of the package and of the command line.

A module is named by its path below the package, as the document writes it (``engine.py``,
``planning/core/task.py``, ``cli/app.py``); a package's ``__init__.py`` is named by the package's
folder (``planning/``). A new module without a line in the document fails here.
"""

from __future__ import annotations

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
