"""A trajectory's export to NPZ or CSV.

:func:`save_trajectory` writes ``times``, ``q``, ``v``, ``inputs``, ``forces`` (every contact's
``(lambda_n, lambda_t)``) and ``modes`` (one letter per contact and sample,
:func:`.samples.sample_modes`): in an ``.npz`` file as arrays of those names (with ``coordinates``,
``contacts`` and ``input_names``), in a ``.csv`` file as one row per sample with a header naming
every column. A run's per-sample series with dotted names follow, under those names, as arrays and
as columns (a series with several columns, such as a drive's stages, as ``NAME[i]``): the drives'
``drives.JOINT.voltage``, ``.current``, ``.motor_speed`` and ``.torque`` (:mod:`.samples`), the
rigid model's impact impulses ``impacts.NAME.impulse_normal`` and ``impacts.NAME.impulse_tangent``
[N s] and the compliant model's contact zones ``zones.NAME.deformation`` [m] and
``zones.NAME.force`` [N] (:func:`sample_series`), and the joint springs'
``springs.JOINT.deflection`` [m or rad] and ``springs.JOINT.force`` [N or N m]
(:mod:`frcontrol.springs`).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import InputError, reason_from_exception
from ..scene import Scene
from .choices import TRAJECTORY_FORMATS
from .samples import drive_arrays, sample_modes
from .trajectory import Trajectory

__all__ = ["TRAJECTORY_FORMATS", "sample_modes", "sample_series", "save_trajectory", "trajectory_arrays"]



def sample_series(trajectory: Trajectory) -> dict[str, np.ndarray]:
    """The run's per-sample series by dotted name, one value per sample (module docstring)."""
    info, out, count = trajectory.info, {}, len(trajectory.times)
    if "impact_impulses" in info:
        impulses = np.asarray(info["impact_impulses"], dtype=float)[:count]
        for i, name in enumerate(trajectory.contacts):
            out[f"impacts.{name}.impulse_normal"] = impulses[:, i, 0]
            out[f"impacts.{name}.impulse_tangent"] = impulses[:, i, 1]
    for name, zone in info.get("zones", {}).items():
        for part in ("deformation", "force"):
            out[f"zones.{name}.{part}"] = np.asarray(zone[part], dtype=float)[:count]
    return out


def trajectory_arrays(scene: Scene, trajectory: Trajectory) -> dict[str, np.ndarray]:
    """The arrays :func:`save_trajectory` writes, by name."""
    modes = sample_modes(scene, trajectory)
    k = len(trajectory.contacts)
    return {**sample_series(trajectory), **{
        "times": np.asarray(trajectory.times, dtype=float),
        "q": np.asarray(trajectory.q, dtype=float),
        "v": np.asarray(trajectory.v, dtype=float),
        "inputs": np.asarray(trajectory.inputs, dtype=float).reshape(len(trajectory.times), -1),
        "forces": np.asarray(trajectory.contact_forces, dtype=float).reshape(len(trajectory.times), k, 2),
        "modes": np.array([list(m) for m in modes], dtype="<U1").reshape(len(trajectory.times), k),
        "coordinates": np.array(trajectory.coordinates, dtype=str),
        "contacts": np.array(trajectory.contacts, dtype=str),
        "input_names": np.array(trajectory.input_names, dtype=str),
        **drive_arrays(scene, trajectory),
        **{f"springs.{joint}.{name}": series for joint, table in
           scene.robot.springs.samples(trajectory.q, trajectory.v).items() for name, series in table.items()},
    }}


def save_trajectory(scene: Scene, trajectory: Trajectory, path: str | Path) -> Path:
    """Write a trajectory as ``.npz`` (arrays by name) or ``.csv`` (a row per sample).

    Raises:
        InputError: another suffix, or the file cannot be written.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TRAJECTORY_FORMATS:
        raise InputError(f"cannot write a trajectory to {str(path)!r}: the suffix must be one of "
                         f"{', '.join(TRAJECTORY_FORMATS)}")
    arrays = trajectory_arrays(scene, trajectory)
    try:
        if suffix == ".npz":
            np.savez(path, **arrays)  # type: ignore[arg-type]  # numpy's stub types **kwds poorly
        else:
            _write_csv(path, arrays)
    except OSError as err:
        raise InputError(f"cannot write {str(path)!r}: {reason_from_exception(err)}") from err
    return path


def _write_csv(path: Path, arrays: dict[str, np.ndarray]) -> None:
    coords, contacts, inputs = arrays["coordinates"], arrays["contacts"], arrays["input_names"]
    header = (["time"] + [f"q_{c}" for c in coords] + [f"v_{c}" for c in coords]
              + [f"u_{u}" for u in inputs]
              + [f"{c}_{part}" for c in contacts for part in ("lambda_n", "lambda_t", "mode")])
    series = [name for name in arrays if "." in name]
    header += [name if arrays[name].ndim == 1 else f"{name}[{i}]"
               for name in series for i in range(1 if arrays[name].ndim == 1 else arrays[name].shape[1])]
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for j, t in enumerate(arrays["times"]):
            row: list[object] = [repr(float(t))]
            row += [repr(float(x)) for x in arrays["q"][j]] + [repr(float(x)) for x in arrays["v"][j]]
            row += [repr(float(x)) for x in arrays["inputs"][j]]
            for i in range(len(contacts)):
                row += [repr(float(arrays["forces"][j, i, 0])), repr(float(arrays["forces"][j, i, 1])),
                        str(arrays["modes"][j, i])]
            row += [repr(float(x)) for name in series for x in np.atleast_1d(arrays[name][j])]
            writer.writerow(row)
