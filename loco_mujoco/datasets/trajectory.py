"""A task dataset on disk and in memory: concatenated trajectories of full-model qpos/qvel plus metadata."""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from loco_mujoco.atomic_write import atomic_write
from loco_mujoco.datasets.motion import MotionFormatError

FORMAT = "loco_mujoco.trajectories/1"


@dataclass
class TrajectoryDataset:
    """Trajectories stacked in time: ``qpos`` (T, nq) and ``qvel`` (T, nv) in the layout of ``joint_names``.

    Trajectory ``i`` spans rows ``split_points[i]:split_points[i + 1]``. ``metadata`` is JSON: sources,
    licences, frame rate, mean speed, quality figures. Datasets rolled out by agents also hold ``actions``
    (the action taken at each frame; NaN at a trajectory's last frame), ``observations`` (the env's
    observation at each frame) and ``absorbing`` (True at a frame the env reported as absorbing).
    """

    qpos: np.ndarray
    qvel: np.ndarray
    split_points: np.ndarray
    frequency: float
    joint_names: tuple[str, ...]
    metadata: dict = field(default_factory=dict)
    actions: np.ndarray | None = None
    observations: np.ndarray | None = None
    absorbing: np.ndarray | None = None
    source_file: Path | None = field(default=None, compare=False)  # the file it was loaded from, if any

    def __post_init__(self) -> None:
        self.split_points = np.asarray(self.split_points, dtype=np.int64)
        self.joint_names = tuple(self.joint_names)
        sp = self.split_points
        if len(sp) < 2 or sp[0] != 0 or sp[-1] != len(self.qpos) or np.any(np.diff(sp) < 2):
            raise ValueError(f"split_points {sp.tolist()} must rise from 0 to {len(self.qpos)} in steps of 2 or more")
        if len(self.qvel) != len(self.qpos):
            raise ValueError(f"qpos has {len(self.qpos)} rows but qvel has {len(self.qvel)}")
        for name in ("actions", "observations", "absorbing"):
            value = getattr(self, name)
            if value is not None and len(value) != len(self.qpos):
                raise ValueError(f"{name} has {len(value)} rows but qpos has {len(self.qpos)}")

    @property
    def n_trajectories(self) -> int:
        return len(self.split_points) - 1

    @property
    def n_frames(self) -> int:
        return len(self.qpos)

    @property
    def duration(self) -> float:
        """Seconds of motion over all trajectories."""
        return float(np.sum(np.diff(self.split_points) - 1) / self.frequency)

    def trajectory_slice(self, i: int) -> slice:
        return slice(int(self.split_points[i]), int(self.split_points[i + 1]))

    def trajectory_of_frame(self, frame: np.ndarray | int) -> np.ndarray:
        """Index of the trajectory each frame belongs to."""
        return np.searchsorted(self.split_points, frame, side="right") - 1

    def save(self, path: str | Path) -> Path:
        """Write an ``.npz`` that is byte-identical for identical content (fixed zip timestamps)."""
        path = Path(path)
        arrays = {"qpos": self.qpos, "qvel": self.qvel, "split_points": self.split_points,
                  "frequency": np.array(self.frequency), "joint_names": np.array(self.joint_names),
                  "metadata": np.array(json.dumps(self.metadata, sort_keys=True)), "format": np.array(FORMAT)}
        for name in ("actions", "observations", "absorbing"):
            if getattr(self, name) is not None:
                arrays[name] = getattr(self, name)
        write_npz_deterministic(path, arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> TrajectoryDataset:
        """Read a file written by :meth:`save`; a corrupt or foreign file raises naming the problem."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                if "format" not in data.files or str(data["format"]) != FORMAT:
                    raise MotionFormatError(path, f"not a {FORMAT} file (keys {sorted(data.files)[:8]}); "
                                            "original LocoMuJoCo files load with load_loco_npz")
                return cls(qpos=data["qpos"], qvel=data["qvel"], split_points=data["split_points"],
                           frequency=float(data["frequency"]), joint_names=tuple(str(j) for j in data["joint_names"]),
                           metadata=json.loads(str(data["metadata"])),
                           **{name: data[name] if name in data.files else None
                              for name in ("actions", "observations", "absorbing")}, source_file=path)
        except (zipfile.BadZipFile, OSError, KeyError, ValueError, EOFError) as err:
            if isinstance(err, MotionFormatError):
                raise
            raise MotionFormatError(path, f"corrupt dataset file ({type(err).__name__}: {err})") from None


def write_npz_deterministic(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``np.savez`` without timestamps: the same arrays always give the same bytes."""
    with atomic_write(path) as handle, zipfile.ZipFile(handle, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(arrays):
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.asarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, buf.getvalue())


def joint_layout(joint_names: tuple[str, ...]) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """qpos and qvel column indices of each joint, assuming the first joint is the free root (7 and 6 wide)."""
    q_at, v_at = {}, {}
    q = v = 0
    for i, name in enumerate(joint_names):
        qw, vw = (7, 6) if i == 0 else (1, 1)
        q_at[name] = np.arange(q, q + qw)
        v_at[name] = np.arange(v, v + vw)
        q, v = q + qw, v + vw
    return q_at, v_at
