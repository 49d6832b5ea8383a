"""An atlas's ``--out``: finished chunks kept as they come, resumed, then one columnar table.

While a sweep runs, every finished chunk is written at once to ``FILE.parts/`` (beside ``FILE``)
as ``chunk-NNNNNN.json``, written to a temporary name and renamed, so that a chunk file is whole or
absent whatever stops the run (Ctrl-C, SIGTERM, SIGKILL, a lost scheduler). The folder's
``manifest.json`` holds the plan and its fingerprint. When every chunk is there, ``FILE`` is
written, one row per grid point in index order, and the folder is removed.

``--resume`` reads the folder back, refuses it if its fingerprint is not the plan's (other
arguments, or an edited scene or URDF), and leaves only the missing chunks to compute. JSON keeps
every float exactly (shortest round-trip repr), so a resumed result is identical to an
uninterrupted one.

The table (Parquet via pyarrow, or NPZ), one row per point, the same column names in both:

- ``index`` (int64), then one float64 column per axis, named by its path;
- ``count``, ``modes``, ``stable``, ``ambiguous``, ``error``, then the kind's columns.

Parquet holds real nulls (an error point's columns, a plan's absent mode, an unanalysable
stability): ``count`` int64, ``modes`` a list of strings (sorted), ``stable`` a list of booleans
(one per mode, in their order; an element is null where the stability is not analysable),
``ambiguous``, ``error`` and names strings, flags booleans, numbers float64. NumPy has no null, so
NPZ encodes them: ``count`` -1, ``modes`` and ``stable`` one string of space-separated items
(``"L R"``, ``"true null"``; empty at a point whose ``count`` is -1), strings empty, flags int8
(1 true, 0 false, -1 null), numbers NaN.

Both carry a JSON metadata entry (:func:`table_metadata`): the plan, the fixed ``--set`` values and
inputs, each column's unit, type and null encoding. It is the Parquet file's metadata under
``frcontrol.atlas.metadata`` (and the plan alone under ``frcontrol.atlas``, as before), with each
field's unit in its own field metadata (``unit``); in NPZ it is the array ``atlas_metadata`` (and
the plan alone ``atlas_plan``). :func:`read_table` reads either back as the run's rows.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .grid import INPUT_PREFIX, AtlasPlan
from .points import columns

TABLE_FORMATS = (".parquet", ".npz")
"""The suffixes ``--out`` accepts."""

FLAG_COLUMNS = frozenset({"form_closure", "force_closure", "static_equilibrium", "weakly_stable",
                          "strongly_stable", "found"})
NUMBER_COLUMNS = frozenset({"form_closure_margin", "force_closure_margin", "pitch_acceleration", "margin",
                            "max_disturbance_scale", "robustness_radius"})
LIST_COLUMNS = frozenset({"modes", "stable"})
"""The columns whose value at a point is a list (Parquet list columns)."""

COLUMN_UNITS: dict[str, str] = {
    "count": "-", "form_closure_margin": "N or N m", "force_closure_margin": "N or N m",
    "pitch_acceleration": "rad/s^2", "margin": "N m", "max_disturbance_scale": "-",
    "robustness_radius": "N m or N",
}
"""The units of the computed number columns (:data:`~.points.KIND_COLUMNS`); an axis's unit is its
scene field's (:func:`axis_unit`)."""

METADATA_KEY = "frcontrol.atlas.metadata"
"""The Parquet file-metadata key of the table's JSON metadata (NPZ: the array ``atlas_metadata``)."""


def parts_folder(out: Path) -> Path:
    """Where the chunks of ``out`` are kept while the sweep runs: ``FILE.parts``."""
    return out.with_name(out.name + ".parts")


def check_out(out: Path) -> None:
    """Refuse, before any work, an ``--out`` that is not ``.parquet`` or ``.npz`` (or lacks pyarrow).

    Raises:
        InputError: another suffix, or pyarrow missing.
    """
    suffix = out.suffix.lower()
    if suffix not in TABLE_FORMATS:
        raise InputError(f"--out {str(out)!r}: the suffix must be one of {', '.join(TABLE_FORMATS)}")
    if suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError as err:
            raise InputError(f'--out {str(out)!r}: Parquet needs pyarrow: pip install "frcontrol[cluster]" '
                             "(or pip install pyarrow), or write FILE.npz") from err


class ChunkStore:
    """The finished chunks of one plan in ``FILE.parts/`` (module docstring)."""

    def __init__(self, out: Path, plan: AtlasPlan) -> None:
        self.out = Path(out)
        self.plan = plan
        self.folder = parts_folder(self.out)

    def chunk_path(self, chunk: int) -> Path:
        """The file of one chunk."""
        return self.folder / f"chunk-{chunk:06d}.json"

    def open(self, resume: bool) -> dict[int, dict[str, Any]]:
        """Start the store: a new folder, or (``resume``) the chunks already in it.

        Returns:
            The chunks found, by number (empty unless resuming).

        Raises:
            InputError: the folder holds another sweep's chunks (resume), or chunks while not
                resuming (they would be lost: pass --resume, or delete the folder).
        """
        manifest = self.folder / "manifest.json"
        if self.folder.exists():
            if not resume:
                found = len(list(self.folder.glob("chunk-*.json")))
                raise InputError(f"{self.folder} holds {found} finished chunks of an unfinished sweep: "
                                 "add --resume to finish it, or delete the folder to start again")
            stored = _read_json(manifest)
            if stored is None or stored.get("fingerprint") != self.plan.fingerprint:
                raise InputError(f"--resume: {self.folder} was written by a sweep with other arguments "
                                 f"({_difference(stored, self.plan)}); run with the same arguments, or "
                                 "delete the folder to start again")
            return self.finished()
        self.folder.mkdir(parents=True)
        _write_atomic(manifest, json.dumps(self.plan.to_dict()))
        return {}

    def finished(self) -> dict[int, dict[str, Any]]:
        """The whole chunks of this plan in the folder, by number.

        A file that does not parse, lacks a column or holds other points is left out (computed again).
        """
        chunks: dict[int, dict[str, Any]] = {}
        expected = {"chunk", "index", *columns(self.plan.what)}
        for path in sorted(self.folder.glob("chunk-*.json")):
            data = _read_json(path)
            if data is None or not expected <= set(data):
                continue  # not a whole chunk: computed again
            chunk = int(data["chunk"])
            if 0 <= chunk < self.plan.chunk_count and data["index"] == list(self.plan.chunk_points(chunk)):
                chunks[chunk] = data
        return chunks

    def add(self, result: Mapping[str, Any]) -> None:
        """Keep one finished chunk."""
        _write_atomic(self.chunk_path(int(result["chunk"])), json.dumps(result))

    def finish(self, rows: Mapping[str, Sequence[Any]]) -> None:
        """Write the table and remove the chunks' folder."""
        write_table(self.out, self.plan, rows)
        shutil.rmtree(self.folder, ignore_errors=True)


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _difference(stored: Mapping[str, Any] | None, plan: AtlasPlan) -> str:
    if stored is None:
        return "no readable manifest.json"
    mine = plan.to_dict()
    keys = ("scene", "what", "axes", "inputs", "set", "chunk_size")
    changed = [key for key in keys if stored.get(key) != mine[key]]
    return f"different {', '.join(changed)}" if changed else "the scene file or its URDF changed"


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def axis_unit(path: str) -> str:
    """The unit of an axis's path, from the scene schema's description (``"-"`` if it gives none)."""
    from ..scene_schema import SCENE_SCHEMA

    if path.startswith(INPUT_PREFIX):
        path = "inputs.lower"
    node: Any = SCENE_SCHEMA
    for part in path.replace("[", ".").replace("]", "").split("."):
        if node.get("type") == "array":
            if "properties" not in node["items"]:
                break  # a coordinate of state.q or state.v: the list's unit
            node = node["items"]  # ``part`` names an entry (contacts.tip)
            continue
        node = node.get("properties", {}).get(part, node.get("additionalProperties") or {})
    found = re.search(r"\[([^\]]+)\]", str(node.get("description", "")))
    return found.group(1) if found else "-"


def _column_kind(name: str) -> tuple[str, Any]:
    """A result column's type and its NPZ null: ``("int64", -1)``, ``("bool", -1)``..."""
    if name == "count":
        return "int64", -1
    if name in LIST_COLUMNS:
        return ("list<string>" if name == "modes" else "list<bool>"), ""
    if name in FLAG_COLUMNS:
        return "bool", -1
    if name in NUMBER_COLUMNS:
        return "float64", "NaN"
    return "string", ""


def table_metadata(plan: AtlasPlan) -> dict[str, Any]:
    """The table's JSON metadata: ``{"plan", "set", "inputs", "columns": {name: {unit?, type, null}}}``.

    ``null`` is how NPZ writes a null (Parquet writes real nulls); a unit is given where one applies.
    """
    described: dict[str, dict[str, Any]] = {"index": {"type": "int64", "null": None}}
    for axis in plan.axes:
        described[axis.path] = {"type": "float64", "null": None, "unit": axis_unit(axis.path),
                                "start": axis.start, "stop": axis.stop, "count": axis.count}
    for name in columns(plan.what):
        kind, null = _column_kind(name)
        described[name] = {"type": kind, "null": null}
        if name in COLUMN_UNITS:
            described[name]["unit"] = COLUMN_UNITS[name]
    return {"plan": plan.to_dict(), "set": dict(plan.overrides), "inputs": dict(plan.inputs),
            "columns": described}


def table_columns(plan: AtlasPlan, rows: Mapping[str, Sequence[Any]]) -> dict[str, np.ndarray]:
    """The NPZ table's flat columns (module docstring), one entry per grid point in index order."""
    out = _grid_columns(plan, rows)
    out["count"] = np.array([-1 if c is None else c for c in rows["count"]], dtype=np.int64)
    out["modes"] = np.array([" ".join(m or []) for m in rows["modes"]], dtype=str)
    out["stable"] = np.array([" ".join(json.dumps(x) for x in (s or [])) for s in rows["stable"]], dtype=str)
    for name in ("ambiguous", "error"):
        out[name] = np.array([x or "" for x in rows[name]], dtype=str)
    for name in columns(plan.what)[5:]:
        values = rows[name]
        if name in FLAG_COLUMNS:
            out[name] = np.array([-1 if x is None else int(bool(x)) for x in values], dtype=np.int8)
        elif name in NUMBER_COLUMNS:
            out[name] = np.array([np.nan if x is None else x for x in values], dtype=np.float64)
        else:
            out[name] = np.array([x or "" for x in values], dtype=str)
    return out


def _grid_columns(plan: AtlasPlan, rows: Mapping[str, Sequence[Any]]) -> dict[str, np.ndarray]:
    """``index`` and one column per axis (the axis's values at each row's point)."""
    index = np.asarray(rows["index"], dtype=np.int64)
    out: dict[str, np.ndarray] = {"index": index}
    for axis, i in zip(plan.axes, np.unravel_index(index, plan.shape), strict=True):
        out[axis.path] = axis.values[i]
    return out


def _arrow_table(plan: AtlasPlan, rows: Mapping[str, Sequence[Any]], meta: Mapping[str, Any]) -> Any:
    """The Parquet table: real nulls, booleans, list columns, units in the fields' metadata."""
    import pyarrow as pa

    types = {"int64": pa.int64(), "float64": pa.float64(), "bool": pa.bool_(), "string": pa.string(),
             "list<string>": pa.list_(pa.string()), "list<bool>": pa.list_(pa.bool_())}
    grid = _grid_columns(plan, rows)
    arrays, fields = [], []
    for name, described in meta["columns"].items():
        kind = types[described["type"]]
        arrays.append(pa.array(grid[name] if name in grid else list(rows[name]), type=kind))
        unit = {b"unit": described["unit"].encode()} if "unit" in described else None
        fields.append(pa.field(name, kind, nullable=name not in grid, metadata=unit))
    file_meta = {"frcontrol.atlas": json.dumps(meta["plan"]), METADATA_KEY: json.dumps(meta)}
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=file_meta))


def write_table(out: Path, plan: AtlasPlan, rows: Mapping[str, Sequence[Any]]) -> None:
    """Write the table to ``out`` (``.parquet`` or ``.npz``), through a temporary file."""
    meta = table_metadata(plan)
    tmp = out.with_name(out.name + f".tmp{os.getpid()}{out.suffix}")
    if out.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        pq.write_table(_arrow_table(plan, rows, meta), tmp)
    else:
        arrays: dict[str, Any] = {**table_columns(plan, rows), "atlas_metadata": np.array(json.dumps(meta)),
                                  "atlas_plan": np.array(json.dumps(meta["plan"]))}
        np.savez(tmp, **arrays)
    os.replace(tmp, out)


def read_metadata(path: Path) -> dict[str, Any]:
    """The JSON metadata of a table written by :func:`write_table` (:func:`table_metadata`)."""
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        return dict(json.loads(pq.read_schema(path).metadata[METADATA_KEY.encode()]))
    with np.load(path) as data:
        return dict(json.loads(str(data["atlas_metadata"])))


def read_table(path: Path) -> dict[str, list[Any]]:
    """A table written by :func:`write_table`, as ``{column: [value per row]}``: the run's rows.

    Nulls are None and lists are lists, from either format (NPZ's encodings decoded), so that a
    table reads back as :attr:`~frcontrol.atlas.AtlasResult.rows` (with the axis columns).
    """
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        return {name: table.column(name).to_pylist() for name in table.column_names}
    described = read_metadata(path)["columns"]
    with np.load(path) as data:
        out = {name: _from_npz(data[name].tolist(), kind["type"]) for name, kind in described.items()}
    for name in LIST_COLUMNS:  # an error point's lists are empty in NPZ: null where count is
        out[name] = [None if count is None else items for items, count in zip(out[name], out["count"],
                                                                               strict=True)]
    return out


def _from_npz(values: list[Any], kind: str) -> list[Any]:
    """A column of an NPZ table, its nulls and lists decoded (module docstring)."""
    if kind == "int64" or kind == "bool":
        decoded = [None if v == -1 else v for v in values]
        return [None if v is None else bool(v) for v in decoded] if kind == "bool" else decoded
    if kind == "float64":
        return [None if math.isnan(v) else v for v in values]
    if kind == "list<string>":
        return [v.split() for v in values]
    if kind == "list<bool>":
        return [[json.loads(x) for x in v.split()] for v in values]
    return [v or None for v in values]


__all__ = [
    "COLUMN_UNITS",
    "FLAG_COLUMNS",
    "LIST_COLUMNS",
    "METADATA_KEY",
    "NUMBER_COLUMNS",
    "TABLE_FORMATS",
    "ChunkStore",
    "axis_unit",
    "check_out",
    "parts_folder",
    "read_metadata",
    "read_table",
    "table_columns",
    "table_metadata",
    "write_table",
]
