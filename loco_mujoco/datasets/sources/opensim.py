"""OpenSim motion files (``.mot``/``.sto`` coordinates, ``.trc`` markers) to :class:`Motion`.

Frames: OpenSim ground is X forward, Y up, Z right; positions are mapped with ``Y_UP_TO_Z_UP`` (x forward,
y left, z up) and rotations with ``C R C^T``. The pelvis orientation is ``R = Rz(tilt) Rx(list) Ry(rotation)``
(body-fixed, in that order), as in the gait2392/Rajagopal/Hamner models.

Marker columns in ``.mot`` files (Hamner running IK carries model-marker positions after its 37
coordinates): a column is a marker coordinate when its name is ``<stem>_tx``/``_ty``/``_tz``, the stem is not
``pelvis`` and all three ``<stem>_t{x,y,z}`` columns are present. OpenSim gait models have no such non-pelvis
translation triples (knee translations are named ``knee_angle_r_translation1`` ...). Markers become
``keypoints`` (metres, Z-up). A lone ``<name>_tx`` column stays a (translational) coordinate.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.motion import Y_UP_TO_Z_UP, Motion, MotionFormatError, is_float
from loco_mujoco.rotations import continuous, mat_to_quat

PELVIS = ("pelvis_tx", "pelvis_ty", "pelvis_tz", "pelvis_tilt", "pelvis_list", "pelvis_rotation")
_TRANSLATION = re.compile(r"(_t[xyz]$)|translation")
_UNITS_TO_M = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "meters": 1.0}
_PELVIS_MARKERS = ("R.ASIS", "L.ASIS", "V.Sacral")


def _read_lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8", errors="strict").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise MotionFormatError(path, f"cannot read file: {err}") from err


def _parse_rows(path: Path, lines: list[str], first_line: int, names: list[str]) -> np.ndarray:
    """Whitespace-separated numeric rows; every row must have one value per column name."""
    rows = []
    for k, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        tokens = line.split()
        if len(tokens) != len(names):
            raise MotionFormatError(path, f"data row {k} (line {first_line + k}) has {len(tokens)} values, "
                                    f"expected {len(names)}")
        try:
            rows.append([float(t) for t in tokens])
        except ValueError:
            bad = next(i for i, t in enumerate(tokens) if not is_float(t))
            raise MotionFormatError(path, f"non-numeric value {tokens[bad]!r} in data row {k}, "
                                    f"column {names[bad]!r}") from None
    data = np.array(rows, dtype=float).reshape(len(rows), len(names))
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        raise MotionFormatError(path, f"NaN or infinite value in data row {bad[0][0] + 1}, column {names[bad[0][1]]!r}")
    if len(data) < 2:
        raise MotionFormatError(path, f"too few frames: {len(data)} (need at least 2)")
    return data


def _in_degrees(path: Path, header: list[str]) -> bool:
    """``inDegrees=yes/no``; otherwise an "Angles are in degrees/radians" line or an old SIMM header (degrees)."""
    text = "\n".join(header).lower()
    match = re.search(r"indegrees\s*=\s*(\w+)", text)
    if match:
        if match.group(1) in ("yes", "true"):
            return True
        if match.group(1) in ("no", "false"):
            return False
        raise MotionFormatError(path, f"unknown units: inDegrees={match.group(1)!r}")
    if "angles are in degrees" in text:
        return True
    if "angles are in radians" in text:
        return False
    if "simm motion file header" in text:
        return True
    raise MotionFormatError(path, "unknown units: header has no inDegrees= line, no 'Angles are in ...' line "
                            "and is not a SIMM header")


def _check_declared(path: Path, header: list[str], n_rows: int, n_cols: int) -> None:
    """Compare the header's declared row/column counts (nRows/datarows, nColumns/datacolumns) with the data."""
    for line in header:
        match = re.match(r"\s*(nrows|datarows|ncolumns|datacolumns)\s*[= ]\s*(\d+)\s*$", line, re.IGNORECASE)
        if not match:
            continue
        key, value = match.group(1).lower(), int(match.group(2))
        actual = n_rows if key in ("nrows", "datarows") else n_cols
        if value != actual:
            kind = "rows" if key in ("nrows", "datarows") else "columns"
            raise MotionFormatError(path, f"header declares {key}={value} but the file has {actual} data {kind}"
                                    + (" (truncated?)" if kind == "rows" and actual < value else ""))


def _coordinate_name(column: str) -> str | None:
    """Plain names stay; ``/jointset/<joint>/<coord>/value`` paths give ``<coord>``; other paths are skipped."""
    if "/" not in column:
        return column
    parts = [p for p in column.split("/") if p]
    return parts[-2] if len(parts) >= 2 and parts[-1] == "value" else None


def _marker_stems(names: list[str]) -> set[str]:
    stems = {n[:-3] for n in names if re.search(r"_t[xyz]$", n)}
    return {s for s in stems if s != "pelvis" and all(f"{s}_t{a}" in names for a in "xyz")}


def load_opensim(path: str | Path) -> Motion:
    """Parse an OpenSim ``.mot``/``.sto`` coordinate file into a Z-up :class:`Motion` (angles in radians)."""
    path = Path(path)
    lines = _read_lines(path)
    end = next((i for i, line in enumerate(lines) if line.strip().lower() == "endheader"), None)
    if end is None:
        raise MotionFormatError(path, "missing 'endheader' line")
    header = lines[:end]
    col_line = next((i for i in range(end + 1, len(lines)) if lines[i].strip()), None)
    if col_line is None:
        raise MotionFormatError(path, "missing column header row after 'endheader'")
    raw = lines[col_line].rstrip()
    columns = [c.strip() for c in (raw.split("\t") if "\t" in raw else raw.split())]
    if not columns or columns[0].lower() != "time":
        raise MotionFormatError(path, f"first column must be 'time', got {columns[0]!r}")
    if len(set(columns)) != len(columns):
        raise MotionFormatError(path, "duplicate column names in header row")
    data = _parse_rows(path, lines[col_line + 1:], col_line + 1, columns)
    _check_declared(path, header, len(data), len(columns))
    degrees = _in_degrees(path, header)

    coords: dict[str, np.ndarray] = {}
    skipped = []
    for j, col in enumerate(columns[1:], start=1):
        name = _coordinate_name(col)
        if name is None:
            skipped.append(col)
        else:
            coords[name] = data[:, j]
    markers = _marker_stems(list(coords))
    keypoints = {s: np.stack([coords.pop(f"{s}_t{a}") for a in "xyz"], axis=1) @ Y_UP_TO_Z_UP.T
                 for s in sorted(markers)}
    for name in coords:
        if degrees and not _TRANSLATION.search(name):
            coords[name] = np.deg2rad(coords[name])
    missing = [p for p in PELVIS if p not in coords]
    if missing:
        raise MotionFormatError(path, f"missing pelvis coordinate column(s) {missing}")

    pelvis = {p: coords.pop(p) for p in PELVIS}
    root_pos = np.stack([pelvis["pelvis_tx"], pelvis["pelvis_ty"], pelvis["pelvis_tz"]], axis=1) @ Y_UP_TO_Z_UP.T
    r_osim = Rotation.from_euler("ZXY", np.stack([pelvis["pelvis_tilt"], pelvis["pelvis_list"],
                                                  pelvis["pelvis_rotation"]], axis=1)).as_matrix()
    root_quat = continuous(mat_to_quat(Y_UP_TO_Z_UP @ r_osim @ Y_UP_TO_Z_UP.T))
    names = tuple(coords)
    meta = {"format": f"opensim-{path.suffix.lstrip('.').lower()}", "in_degrees": degrees, "pelvis": pelvis,
            "skipped_columns": skipped, "markers": sorted(markers)}
    knees = [coords[k] for k in ("knee_angle_r", "knee_angle_l") if k in coords]
    if knees:
        meta["knee_flexion_sign"] = -1 if np.median(np.concatenate(knees)) < 0 else 1
    return Motion(name=path.stem, time=data[:, 0], root_pos=root_pos, root_quat=root_quat, joint_names=names,
                  joint_angles=np.stack([coords[n] for n in names], axis=1) if names else None,
                  keypoints=keypoints, skeleton="opensim", source=str(path), meta=meta)


def load_trc(path: str | Path) -> Motion:
    """Parse an OpenSim ``.trc`` marker file: keypoints in metres, Z-up; root at the pelvis markers' mean."""
    path = Path(path)
    lines = _read_lines(path)
    if len(lines) < 6 or not lines[0].startswith("PathFileType"):
        raise MotionFormatError(path, "missing 'PathFileType' first line (not a .trc file?)")
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    if len(keys) != len(values):
        raise MotionFormatError(path, f"header line 3 has {len(values)} values for {len(keys)} keys on line 2")
    info = {k.strip(): v.strip() for k, v in zip(keys, values, strict=True)}
    for key in ("DataRate", "NumFrames", "NumMarkers", "Units"):
        if key not in info:
            raise MotionFormatError(path, f"header line 2 lacks {key!r}")
    if info["Units"].lower() not in _UNITS_TO_M:
        raise MotionFormatError(path, f"unknown units {info['Units']!r} (expected mm, cm or m)")
    try:
        rate, n_frames, n_markers = float(info["DataRate"]), int(info["NumFrames"]), int(info["NumMarkers"])
    except ValueError as err:
        raise MotionFormatError(path, f"non-numeric DataRate/NumFrames/NumMarkers on header line 3: {err}") from err
    names = [m.strip() for m in lines[3].split("\t")[2:] if m.strip()]
    if lines[3].split("\t")[:2] != ["Frame#", "Time"] or len(names) != n_markers:
        raise MotionFormatError(path, f"marker name line 4 must be 'Frame#, Time' and {n_markers} names, "
                                f"found {len(names)} names")
    scale = _UNITS_TO_M[info["Units"].lower()]
    n_cols = 2 + 3 * n_markers
    rows = []
    for k, line in enumerate((ln for ln in lines[5:] if ln.strip()), start=1):
        cells = line.rstrip().split("\t")
        if len(cells) != n_cols:
            raise MotionFormatError(path, f"data row {k} has {len(cells)} values, expected {n_cols}")
        empty = [i for i, c in enumerate(cells) if not c.strip()]
        if empty:
            raise MotionFormatError(path, f"missing marker value (empty cell) in data row {k}, marker "
                                    f"{names[(empty[0] - 2) // 3] if empty[0] >= 2 else 'Frame#/Time'!r}")
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not is_float(c))
            raise MotionFormatError(path, f"non-numeric value {bad!r} in data row {k}") from None
    data = np.array(rows, dtype=float).reshape(len(rows), n_cols)
    if not np.all(np.isfinite(data)):
        raise MotionFormatError(path, f"NaN or infinite value in data row {np.argwhere(~np.isfinite(data))[0][0] + 1}")
    if len(data) < 2:
        raise MotionFormatError(path, f"too few frames: {len(data)} (need at least 2)")
    if len(data) > n_frames:
        raise MotionFormatError(path, f"{len(data)} data rows but the header declares NumFrames={n_frames}")
    xyz = data[:, 2:].reshape(len(data), n_markers, 3) * scale @ Y_UP_TO_Z_UP.T
    keypoints = {name: xyz[:, i] for i, name in enumerate(names)}
    have_pelvis = all(m in keypoints for m in _PELVIS_MARKERS)
    root_pos = (np.mean([keypoints[m] for m in _PELVIS_MARKERS], axis=0) if have_pelvis
                else np.zeros((len(data), 3)))
    root_quat = np.tile([1.0, 0.0, 0.0, 0.0], (len(data), 1))
    meta = {"format": "opensim-trc", "data_rate": rate, "units": info["Units"], "header_num_frames": n_frames,
            "first_frame": int(data[0, 0]), "root_from": list(_PELVIS_MARKERS) if have_pelvis else None}
    return Motion(name=path.stem, time=data[:, 1], root_pos=root_pos, root_quat=root_quat, keypoints=keypoints,
                  skeleton="opensim-markers", source=str(path), meta=meta)
