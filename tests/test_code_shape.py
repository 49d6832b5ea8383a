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
