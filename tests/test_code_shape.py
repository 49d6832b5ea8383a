"""The code's shape: no function in frcontrol/ or cli/ longer than MAX_FUNCTION_LINES.

A function's length counts from its ``def`` line to its last line, docstring and decorators'
lines below the ``def`` included (``ast``'s ``lineno`` to ``end_lineno``). Methods and nested
functions count on their own, and their lines count in the function around them too. The C
kernel's functions (frcontrol/_kernel.c) count from the line of their name to their closing brace,
found by matching braces once comments, literals and preprocessor lines are set aside.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("frcontrol", "cli")

MAX_FUNCTION_LINES = 80
"""The longest a function may be, in lines."""

def function_lengths(path: Path) -> dict[str, int]:
    """``qualified name -> lines`` of every function and method in one file."""
    lengths: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                end = child.end_lineno if child.end_lineno is not None else child.lineno
                lengths[name] = max(lengths.get(name, 0), end - child.lineno + 1)
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)), "")
    return lengths


def package_lengths() -> dict[str, int]:
    """``"path::qualified name" -> lines`` over every Python file of the packages."""
    found: dict[str, int] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = path.relative_to(ROOT).as_posix()
            for name, lines in function_lengths(path).items():
                found[f"{relative}::{name}"] = lines
    return found


def test_no_function_is_longer_than_the_limit():
    lengths = package_lengths()
    assert len(lengths) > 100, f"only {len(lengths)} functions found under {ROOT}: wrong root?"
    too_long = {key: n for key, n in lengths.items() if n > MAX_FUNCTION_LINES}
    assert not too_long, (f"functions over {MAX_FUNCTION_LINES} lines (split them by their sub-jobs): "
                          + ", ".join(f"{key} ({n})" for key, n in sorted(too_long.items())))


@pytest.mark.parametrize(("source", "expected"), [
    ("def f():\n    return 1\n", {"f": 2}),
    ('def f():\n    """Doc.\n\n    More.\n    """\n    x = 1\n    return x\n', {"f": 7}),
    ("class C:\n    def m(self):\n        pass\n\n    def n(self):\n        def inner():\n"
     "            pass\n        return inner\n", {"C.m": 2, "C.n": 4, "C.n.inner": 2}),
    ("async def g():\n    await h()\n    return 2\n", {"g": 3}),
])
def test_lengths_count_from_def_to_last_line(tmp_path, source, expected):
    path = tmp_path / "example.py"
    path.write_text(source)
    assert function_lengths(path) == expected


def test_an_over_long_function_is_caught(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    path = tmp_path / "long.py"
    path.write_text("def long():\n" + body)
    assert function_lengths(path) == {"long": MAX_FUNCTION_LINES + 1}


C_SOURCES = ("frcontrol/_kernel.c",)
"""The C sources whose functions the limit holds for too."""

_C_SET_ASIDE = re.compile(r'/\*.*?\*/|//[^\n]*|"(?:\\.|[^"\\\n])*"|'  # comments, strings
                          r"'(?:\\.|[^'\\\n])*'|^[ \t]*#(?:[^\n]*\\\n)*[^\n]*",  # characters, preprocessor
                          re.S | re.M)
"""Comments, string and character literals, preprocessor lines (with their continuations)."""


def c_function_lengths(source: str) -> dict[str, int]:
    """``name -> lines`` of every function defined in C ``source``, by matching its braces."""
    text = _C_SET_ASIDE.sub(lambda m: "\n" * m.group().count("\n"), source)
    lengths: dict[str, int] = {}
    depth, line, header, header_line, current = 0, 1, "", 1, None
    for char in text:
        if char == "\n":
            line += 1
        if depth == 0 and char == "{":
            found = re.search(r"(\w+)\s*\([^;{}=]*\)\s*$", header)
            current = (found.group(1), header_line + header[:found.start(1)].count("\n")) if found else None
        if char == "{":
            depth += 1
        elif char == "}":
            depth -= 1
            if depth == 0 and current is not None:
                lengths[current[0]] = line - current[1] + 1
                current = None
        if depth == 0:
            if char in ";}":
                header, header_line = "", line
            elif char != "{":
                header += char
    return lengths


def test_no_c_function_is_longer_than_the_limit():
    lengths = {f"{name}::{function}": n for name in C_SOURCES
               for function, n in c_function_lengths((ROOT / name).read_text(encoding="utf-8")).items()}
    assert len(lengths) > 50, f"only {len(lengths)} C functions found: is the scan broken?"
    too_long = {key: n for key, n in lengths.items() if n > MAX_FUNCTION_LINES}
    assert not too_long, (f"C functions over {MAX_FUNCTION_LINES} lines (split them by their sub-jobs): "
                          + ", ".join(f"{key} ({n})" for key, n in sorted(too_long.items())))


def test_the_c_scan_counts_from_the_name_to_the_closing_brace():
    source = ('#define TABLE \\\n    {"a", {1}}, \\\n    {"b", {2}}\n'
              "static const Arg table[] = {TABLE, {\"}\", 0}};\n"
              "typedef struct {\n    int x;\n} Pair;\n\n"
              "static int\nsum(const Pair *p, /* { */ int n) {\n    if (n) {\n        return '}';\n    }\n"
              "    return p->x;\n}\n\n"
              "static PyObject *long_one(void) {\n" + "    x++;\n" * MAX_FUNCTION_LINES + "}\n")
    assert c_function_lengths(source) == {"sum": 6, "long_one": MAX_FUNCTION_LINES + 2}


def _raises_without_match(path: Path) -> list[int]:
    """Lines of ``pytest.raises(...)`` calls in a file that give no ``match=``."""
    lines = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "raises"
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "pytest"
                and not any(keyword.arg == "match" for keyword in node.keywords)):
            lines.append(node.lineno)
    return lines


def test_every_expected_error_names_its_message():
    """A ``pytest.raises`` without ``match=`` passes on any error of that type, the wrong one too."""
    bare = {path.name: lines for path in sorted((ROOT / "tests").glob("*.py"))
            if (lines := _raises_without_match(path))}
    assert not bare, f"pytest.raises without match= (file: lines): {bare}"


def test_a_bare_raises_is_caught(tmp_path):
    path = tmp_path / "test_x.py"
    path.write_text("import pytest\n\ndef test():\n    with pytest.raises(\n        ValueError):\n"
                    "        int('x')\n    with pytest.raises(ValueError, match='invalid'):\n"
                    "        int('x')\n")
    assert _raises_without_match(path) == [4]


VERDICT_FIELDS = frozenset({"verdict", "status", "pruned", "ambiguous_outputs"})
"""Fields of a result record that hold a verdict: one of a few named values, never any string."""

def bare_string_verdicts(path: Path, root: Path = ROOT) -> list[str]:
    """``"path::Class.field"`` of every dataclass field in ``VERDICT_FIELDS`` annotated ``str``."""
    found = []
    relative = path.relative_to(root).as_posix()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if not isinstance(node, ast.ClassDef):
            continue
        decorators = [d.func if isinstance(d, ast.Call) else d for d in node.decorator_list]
        if not any(isinstance(d, ast.Name) and d.id == "dataclass" for d in decorators):
            continue
        for statement in node.body:
            if (isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name)
                    and statement.target.id in VERDICT_FIELDS
                    and ast.unparse(statement.annotation).replace(" ", "") in ("str", "str|None")):
                found.append(f"{relative}::{node.name}.{statement.target.id}")
    return found


def test_verdicts_are_named_values():
    """A verdict is a ``Literal`` (or an enum): mypy then checks every value set or compared."""
    found = {key for path in sorted((ROOT / "frcontrol").rglob("*.py")) for key in bare_string_verdicts(path)}
    assert not found, f"verdict fields typed str (give them a Literal type): {sorted(found)}"


def test_a_bare_string_verdict_is_caught(tmp_path):
    path = tmp_path / "x.py"
    path.write_text("from dataclasses import dataclass\nfrom typing import Literal\n\n"
                    "@dataclass(frozen=True)\nclass R:\n    status: str\n    verdict: Literal['a']\n"
                    "    name: str\n\n@dataclass\nclass S:\n    pruned: str | None = None\n")
    assert bare_string_verdicts(path, tmp_path) == ["x.py::R.status", "x.py::S.pruned"]


def mutable_private_fields(path: Path, root: Path = ROOT) -> list[str]:
    """``"path::Class.field"`` of every private field of a frozen dataclass with a dict, list or set
    default: a cache that a frozen record fills after construction."""
    found = []
    relative = path.relative_to(root).as_posix()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if not isinstance(node, ast.ClassDef) or not any(
                isinstance(d, ast.Call) and any(k.arg == "frozen" and isinstance(k.value, ast.Constant)
                                                and k.value.value is True for k in d.keywords)
                for d in node.decorator_list):
            continue
        for statement in node.body:
            if (isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name)
                    and statement.target.id.startswith("_") and isinstance(statement.value, ast.Call)
                    and any(k.arg == "default_factory" and isinstance(k.value, ast.Name)
                            and k.value.id in ("dict", "list", "set") for k in statement.value.keywords)):
                found.append(f"{relative}::{node.name}.{statement.target.id}")
    return found


def test_frozen_records_hold_no_caches():
    """A frozen result is immutable: what it derives is built with it (or is a method's answer)."""
    found = [key for path in sorted((ROOT / "frcontrol").rglob("*.py"))
             for key in mutable_private_fields(path)]
    assert not found, f"frozen dataclasses with a private mutable field (a cache): {found}"


def test_a_cache_in_a_frozen_record_is_caught(tmp_path):
    path = tmp_path / "x.py"
    path.write_text("from dataclasses import dataclass, field\n\n@dataclass(frozen=True)\nclass R:\n"
                    "    data: dict = field(default_factory=dict)\n"
                    "    _cache: dict = field(default_factory=dict, compare=False)\n\n"
                    "@dataclass\nclass S:\n    _memo: list = field(default_factory=list)\n")
    assert mutable_private_fields(path, tmp_path) == ["x.py::R._cache"]


MAX_PARAMETERS = 8
"""The most parameters a public function of frcontrol/ or cli/ takes (positional and keyword-only,
``self``/``cls`` aside; ``*args``/``**kwargs`` aside): group options in a frozen settings dataclass."""

def parameter_counts(path: Path, root: Path = ROOT) -> dict[str, int]:
    """``"path::qualified name" -> parameters`` of every public function and method of one file.

    Public: no part of its qualified name starts with ``_`` (dunder methods such as ``__init__``
    of a public class count as public).
    """
    counts: dict[str, int] = {}
    relative = path.relative_to(root).as_posix()

    def private(name: str) -> bool:
        return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))

    def visit(node: ast.AST, prefix: str, in_class: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = child.args
                names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
                if in_class and names and names[0] in ("self", "cls"):
                    names = names[1:]
                if not private(child.name) and not any(private(p) for p in prefix.split(".") if p):
                    counts[f"{relative}::{prefix}{child.name}"] = len(names)
                visit(child, f"{prefix}{child.name}.", False)
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.", True)

    visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)), "", False)
    return counts


def typer_commands() -> set[str]:
    """``"cli/x.py::name"`` of every function registered with the ``frc`` Typer app (its commands
    and its callback): Typer reads one parameter per command-line option, so they are exempt."""
    import inspect

    from frcontrol.cli.app import app  # the installed name of cli/

    callbacks = [c.callback for c in app.registered_commands]
    if app.registered_callback is not None:
        callbacks.append(app.registered_callback.callback)
    functions = [inspect.unwrap(f) for f in callbacks if f is not None]
    return {f"{f.__module__.removeprefix('frcontrol.').replace('.', '/')}.py::{f.__qualname__}"
            for f in functions}


def test_no_public_function_takes_too_many_parameters():
    """Typer command functions (registered with the app, :func:`typer_commands`) are exempt: Typer
    declares one parameter per command-line option. No other exception."""
    counts = {key: n for package in PACKAGES for path in sorted((ROOT / package).rglob("*.py"))
              for key, n in parameter_counts(path).items()}
    commands = typer_commands()
    assert len(commands & set(counts)) >= 14, sorted(commands)  # the app's callback is private
    too_many = {key: n for key, n in counts.items()
                if n > MAX_PARAMETERS and key not in commands}
    assert not too_many, (f"public functions over {MAX_PARAMETERS} parameters (group options in a frozen "
                          f"settings dataclass): {dict(sorted(too_many.items()))}")


def test_parameters_are_counted_as_the_rule_says(tmp_path):
    path = tmp_path / "x.py"
    path.write_text("def f(a, /, b, *args, c, **kw): pass\n"
                    "def _g(a, b, c, d, e, f, g, h, i): pass\n"
                    "class C:\n    def m(self, a, *, b): pass\n    @classmethod\n    def k(cls, a): pass\n"
                    "    def __init__(self, a): pass\n    def _p(self, a): pass\n"
                    "class _D:\n    def m(self, a): pass\n")
    assert parameter_counts(path, tmp_path) == {"x.py::f": 3, "x.py::C.m": 2, "x.py::C.k": 1,
                                                "x.py::C.__init__": 1}
