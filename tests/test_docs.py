"""The manual: it builds (``mkdocs build --strict``), its generated scene reference is current, and
every relative link of the README leads to a file and a heading that exist."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def generator():
    path = ROOT / "docs" / "gen_scene_reference.py"
    spec = importlib.util.spec_from_file_location("gen_scene_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_scene_reference_is_generated_from_the_schema():
    gen = generator()
    assert gen.is_current(), "docs/scene-reference.md is stale: run `python docs/gen_scene_reference.py`"


def test_the_scene_reference_names_every_key_of_the_schema():
    """The generator is not vacuous: every key of every table of the schema has a row."""
    import json

    schema = json.loads((ROOT / "robots" / "scene.schema.json").read_text())
    page = generator().render(schema)
    keys = set()

    def walk(spec):
        if isinstance(spec, dict):
            keys.update(spec.get("properties", {}))
            for value in spec.values():
                walk(value)
        elif isinstance(spec, list):
            for value in spec:
                walk(value)

    walk(schema)
    assert len(keys) > 50
    missing = [key for key in keys if f"| `{key}` |" not in page]
    assert not missing, missing


def test_a_schema_change_makes_the_page_stale(monkeypatch, tmp_path):
    import json

    gen = generator()
    schema = json.loads((ROOT / "robots" / "scene.schema.json").read_text())
    schema["properties"]["gravity"]["description"] = "changed"
    changed = tmp_path / "scene.schema.json"
    changed.write_text(json.dumps(schema))
    monkeypatch.setattr(gen, "SCHEMA", changed)
    assert not gen.is_current()


def heading_anchors(text: str) -> set[str]:
    """The anchors MkDocs (and code hosts) give a page's headings: lower case, punctuation dropped,
    spaces as hyphens."""
    anchors = set()
    for heading in re.findall(r"^#+ (.+)$", text, flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        anchors.add(slug)
    return anchors


def test_the_readmes_links_lead_somewhere():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)#:\s]+)(?:#([^)\s]+))?\)", text)
    assert len(links) > 10
    for target, anchor in links:
        path = ROOT / target
        assert path.exists(), f"README.md links to {target}, which does not exist"
        if anchor:
            anchors = heading_anchors(path.read_text(encoding="utf-8"))
            assert anchor in anchors, f"README.md links to {target}#{anchor}: no such heading"



MANUAL_CITATION = re.compile(r"(docs/[\w-]+\.md),\s+\*([^*]+)\*")
"""A docstring's pointer into the manual: ``docs/PAGE.md, *Section title*``."""

OUTSIDE_DOCUMENTS = re.compile(r"METHOD §|the seed's|\bthe seed\b")
"""Names of documents the repository does not ship."""


def test_the_codes_pointers_into_the_manual_name_its_sections():
    cited = 0
    for path in sorted([*(ROOT / "frcontrol").rglob("*.py"), *(ROOT / "cli").rglob("*.py")]):
        text = path.read_text(encoding="utf-8")
        for page, section in MANUAL_CITATION.findall(text):
            page_text = (ROOT / page).read_text(encoding="utf-8")
            headings = {h.strip() for h in re.findall(r"^#+ (.+)$", page_text, flags=re.M)}
            assert " ".join(section.split()) in headings, \
                f"{path.relative_to(ROOT)} cites {page}, *{section}*: no such section"
            cited += 1
    assert cited >= 9


def test_the_code_and_manual_cite_no_document_outside_the_repository():
    paths = [*(ROOT / "frcontrol").rglob("*.py"), *(ROOT / "cli").rglob("*.py"),
             *(ROOT / "docs").glob("*.md")]
    offenders = [str(path.relative_to(ROOT)) for path in sorted(paths)
                 if "planning" not in path.relative_to(ROOT).parts
                 and OUTSIDE_DOCUMENTS.search(path.read_text(encoding="utf-8"))]
    assert offenders == []

@pytest.mark.slow
def test_the_manual_builds_strictly(tmp_path):
    if importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None:
        if os.environ.get("CI") == "true":
            pytest.fail("the docs extra is not installed in CI: the README's test command must install it")
        pytest.skip("the docs extra (mkdocs, mkdocs-material, mkdocstrings) is not installed: "
                    "pip install '.[docs]' to build the manual")
    command = [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")]
    done = subprocess.run(command,
                          cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    assert (tmp_path / "site" / "index.html").exists()
    assert "solutions_at" in (tmp_path / "site" / "api" / "index.html").read_text(encoding="utf-8")
