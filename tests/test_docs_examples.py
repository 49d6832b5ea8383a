"""Every example in README.md and docs/*.md runs, and prints what the page shows.

The conventions (docs/contributing.md, "Examples in the documentation"):

- every ```python block runs as a whole, in a fresh namespace;
- in a ```bash block every line starting with ``frc `` or ``python -m `` runs (a ``\\`` continues a
  line; ``# comments`` are dropped); other lines (installs, ``dask``, ``curl``) are not run;
- in a ```console block every line starting with ``$ frc `` or ``$ python -m `` runs, and the lines
  after it, up to the next ``$ `` line, are its output;
- a ```text block right after a python block, or after a bash block of one command (only blank lines
  between them), is its output;
- shown output is compared token by token: text exactly (runs of blank space are one space), numbers
  to the digits printed (``3.116`` matches 3.1158 and 3.1163, not 3.12), and ``...`` matches anything;
- a command exits 0, unless its shown output begins with ``frc: error:`` (then it must exit 1, or
  the code of an ``<!-- example: exit N -->`` marker, such as 2 for a usage error, and that output
  is its stderr, without progress lines);
- ``<!-- example: slow -->`` on the line before a block marks its examples slow;
  ``<!-- example: skip REASON -->`` leaves them out, saying why;
  ``<!-- example: file NAME -->`` before any fenced block writes it as NAME into the folder every
  example of that page runs in (a fresh temporary folder per example).
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from conftest import error_lines

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
MARKER = re.compile(r"<!--\s*example:\s*(slow|skip|file|exit)\s*(.*?)\s*-->")
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


@dataclass
class Block:
    """One fenced block: its language, its lines, where it starts, and the marker before it."""

    page: Path
    line: int
    lang: str
    lines: list[str]
    marker: tuple[str, str] | None = None
    adjacent: bool = False  # only blank lines between the previous block and this one


@dataclass
class Example:
    """One thing to run: a Python block or one command, with the output the page shows."""

    page: Path
    line: int
    kind: str  # "python" or "command"
    code: str
    expected: str | None
    files: dict[str, str] = field(default_factory=dict)
    marker: tuple[str, str] | None = None

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks_of(page: Path) -> list[Block]:
    """The page's fenced blocks, in order, each with the example marker just before it."""
    lines = page.read_text(encoding="utf-8").splitlines()
    blocks, i, previous_end = [], 0, -1
    while i < len(lines):
        fence = re.match(r"^```(\w*)\s*$", lines[i])
        if not fence:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        before = next((lines[j] for j in range(i - 1, -1, -1) if lines[j].strip()), "")
        found = MARKER.search(before)
        adjacent = previous_end >= 0 and not any(line.strip() for line in lines[previous_end + 1:i])
        blocks.append(Block(page, i + 1, fence.group(1), lines[i + 1:end],
                            (found.group(1), found.group(2)) if found else None, adjacent))
        i, previous_end = end + 1, end
    return blocks


def is_command(line: str) -> bool:
    return line.startswith(("frc ", "python -m "))


def commands_of(block: Block) -> list[tuple[int, str]]:
    """A bash block's runnable commands (continuations joined, comments dropped), with their lines."""
    out, pending, start = [], "", 0
    for offset, raw in enumerate(block.lines):
        if not pending:
            start = block.line + 1 + offset
        pending += raw.rstrip().removesuffix("\\") + " "
        if raw.rstrip().endswith("\\"):
            continue
        words = shlex.split(pending, comments=True)
        pending = ""
        if words and is_command(shlex.join(words)):
            out.append((start, shlex.join(words)))
    return out


def examples_of(page: Path) -> list[Example]:
    """Every example of one page."""
    blocks = blocks_of(page)
    files = {b.marker[1]: "\n".join(b.lines) + "\n" for b in blocks if b.marker and b.marker[0] == "file"}
    out: list[Example] = []
    for k, block in enumerate(blocks):
        following = blocks[k + 1] if k + 1 < len(blocks) else None
        shown = ("\n".join(following.lines) if following and following.lang == "text" and following.adjacent
                 else None)
        if block.lang == "python":
            code = "\n".join(block.lines)
            out.append(Example(page, block.line, "python", code, shown, files, block.marker))
        elif block.lang == "bash":
            commands = commands_of(block)
            for line, command in commands:
                out.append(Example(page, line, "command", command, shown if len(commands) == 1 else None,
                                   files, block.marker))
        elif block.lang == "console":
            out += console_examples(block, files)
    return out


def console_examples(block: Block, files: dict[str, str]) -> list[Example]:
    """A console block's ``$ `` commands, each with the lines after it as its output."""
    out: list[Example] = []
    for offset, line in enumerate(block.lines):
        if not line.startswith("$ "):
            continue
        rest = block.lines[offset + 1:]
        stop = next((j for j, other in enumerate(rest) if other.startswith("$ ")), len(rest))
        shown = "\n".join(rest[:stop]).strip("\n") or None
        if is_command(line[2:]):
            out.append(Example(block.page, block.line + 1 + offset, "command", line[2:], shown, files,
                               block.marker))
    return out


def all_examples() -> list:
    params = []
    for page in PAGES:
        for example in examples_of(page):
            marks = []
            if example.marker and example.marker[0] == "slow":
                marks.append(pytest.mark.slow)
            if example.marker and example.marker[0] == "skip":
                marks.append(pytest.mark.skip(reason=example.marker[1] or "marked skip"))
            params.append(pytest.param(example, id=example.id, marks=marks))
    return params


def matches(expected: str, actual: str) -> str | None:
    """None when ``actual`` shows what ``expected`` does (the rules above), else why not."""
    pattern, numbers = [], []
    for token in re.findall(rf"\.\.\.|\s+|{NUMBER}|[^\s.\d+-]+|.", expected.strip()):
        if token == "...":
            pattern.append(r".*?")
        elif token.isspace():
            pattern.append(r"\s+")
        elif re.fullmatch(NUMBER, token):
            pattern.append(f"({NUMBER})")
            numbers.append(token)
        else:
            pattern.append(re.escape(token))
    found = re.fullmatch("".join(pattern), actual.strip(), flags=re.DOTALL)
    if found is None:
        return "the text differs"
    for shown, got in zip(numbers, found.groups(), strict=True):
        if not close_to_printed(shown, got):
            return f"{got} does not round to the shown {shown}"
    return None


def close_to_printed(shown: str, got: str) -> bool:
    """Whether ``got`` equals ``shown`` to the digits ``shown`` prints (half a unit of its last digit)."""
    mantissa, _, exponent = shown.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    unit = 10.0 ** (int(exponent or 0) - decimals)
    return abs(float(got) - float(shown)) <= 0.5 * unit * (1 + 1e-9)


def run_python(code: str) -> str:
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        exec(compile(code, "<example>", "exec"), {"__name__": "__example__"})
    return stdout.getvalue()


def run_command(command: str) -> tuple[int, str, str]:
    """Run a ``frc`` command in this process, a ``python -m`` one as a process."""
    if command.startswith("frc "):
        from frcontrol.cli.app import app
        from typer.testing import CliRunner

        result = CliRunner().invoke(app, shlex.split(command)[1:])
        if result.exception is not None and not isinstance(result.exception, SystemExit):
            raise result.exception
        return result.exit_code, result.stdout, result.stderr
    done = subprocess.run([sys.executable, *shlex.split(command)[1:]], capture_output=True, text=True,
                          timeout=600)
    return done.returncode, done.stdout, done.stderr


@pytest.mark.parametrize("example", all_examples())
def test_example_runs_and_shows_its_output(example: Example, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name, text in example.files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    if example.kind == "python":
        output = run_python(example.code)
    else:
        code, stdout, stderr = run_command(example.code)
        wants_error = example.expected is not None and example.expected.startswith("frc: error:")
        error_code = int(example.marker[1]) if example.marker and example.marker[0] == "exit" else 1
        assert code == (error_code if wants_error else 0), (example.code, stderr[-800:])
        # a refusal is compared without the progress lines a loaded machine may show before it
        output = "\n".join(error_lines(stderr)) if wants_error else stdout
    if example.expected is not None:
        problem = matches(example.expected, output)
        assert problem is None, (f"{example.id}: {problem}\n--- shown:\n{example.expected}\n"
                                 f"--- printed:\n{output}")


def test_the_collector_finds_the_examples_the_pages_hold():
    """The collector is not vacuous: the README's ten-line example, with its output, is collected,
    and so is one example per command of the command reference."""
    readme = examples_of(ROOT / "README.md")
    assert any(e.kind == "python" and "solutions_at" in e.code and e.expected for e in readme)
    shown = examples_of(ROOT / "docs" / "commands.md")
    commands = {e.code.split()[1] for e in shown if e.code.startswith("frc ")}
    from frcontrol.cli.app import app
    from typer.main import get_command

    assert set(get_command(app).commands) <= commands  # type: ignore[attr-defined]


@pytest.mark.parametrize("expected, actual, ok", [
    ("[3.116 3.116]", "[3.1158 3.1163]", True),
    ("[3.116 3.116]", "[3.738 3.738]", False),
    ("3.12", "3.116", True),
    ("3.116", "3.12", False),
    ("1.5e-18 m/s", "1.46e-18  m/s", True),
    ("modes:  FF\n10 of 16", "modes: FF 10 of 16", True),
    ("{\"a\": 1, ...}", "{\"a\": 1, \"b\": [2, 3]}", True),
    ("-0.", "0.", True),
    ("wrote flip.png", "wrote flip.html", False),
])
def test_output_comparison(expected, actual, ok):
    assert (matches(expected, actual) is None) is ok
