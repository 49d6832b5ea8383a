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

The table (Parquet via pyarrow, or NPZ), one row per point:

- ``index`` (int64), then one float64 column per axis, named by its path;
- ``count`` (int64; -1 at an error point), ``modes`` (the sorted modes separated by spaces),
  ``stable`` (one ``true``/``false``/``null`` per mode, separated by spaces), ``ambiguous`` and
  ``error`` (strings; empty when there is none);
- the kind's columns: flags as int8 (1 true, 0 false, -1 null), numbers as float64 (NaN for null),
  names as strings (empty for null).

The plan (as JSON) is in the Parquet schema's metadata under ``frcontrol.atlas``, and in the NPZ
array ``atlas_plan`` (a string).
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .grid import AtlasPlan
from .points import columns

TABLE_FORMATS = (".parquet", ".npz")
"""The suffixes ``--out`` accepts."""

FLAG_COLUMNS = frozenset({"form_closure", "force_closure", "static_equilibrium", "weakly_stable",
                          "strongly_stable", "found"})
NUMBER_COLUMNS = frozenset({"form_closure_margin", "force_closure_margin", "pitch_acceleration", "margin",
                            "max_disturbance_scale", "robustness_radius"})


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


def table_columns(plan: AtlasPlan, rows: Mapping[str, Sequence[Any]]) -> dict[str, np.ndarray]:
    """The flat columns of the table (module docstring), one entry per grid point in index order."""
    index = np.asarray(rows["index"], dtype=np.int64)
    out: dict[str, np.ndarray] = {"index": index}
    multi = np.unravel_index(index, plan.shape)
    for axis, i in zip(plan.axes, multi, strict=True):
        out[axis.path] = axis.values[i]
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


def write_table(out: Path, plan: AtlasPlan, rows: Mapping[str, Sequence[Any]]) -> None:
    """Write the table to ``out`` (``.parquet`` or ``.npz``), through a temporary file."""
    table = table_columns(plan, rows)
    meta = json.dumps(plan.to_dict())
    tmp = out.with_name(out.name + f".tmp{os.getpid()}{out.suffix}")
    if out.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        arrow = pa.table({k: pa.array(v) for k, v in table.items()}).replace_schema_metadata(
            {"frcontrol.atlas": meta})
        pq.write_table(arrow, tmp)
    else:
        arrays: dict[str, Any] = {**table, "atlas_plan": np.array(meta)}
        np.savez(tmp, **arrays)
    os.replace(tmp, out)


def read_table(path: Path) -> dict[str, np.ndarray]:
    """An atlas table written by :func:`write_table`, as ``{column: array}`` (plus ``atlas_plan``)."""
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        out = {name: table.column(name).to_numpy() for name in table.column_names}
        out["atlas_plan"] = np.array(table.schema.metadata[b"frcontrol.atlas"].decode())
        return out
    with np.load(path) as data:
        return {name: data[name] for name in data.files}


__all__ = [
    "FLAG_COLUMNS",
    "NUMBER_COLUMNS",
    "TABLE_FORMATS",
    "ChunkStore",
    "check_out",
    "parts_folder",
    "read_table",
    "table_columns",
    "write_table",
]
