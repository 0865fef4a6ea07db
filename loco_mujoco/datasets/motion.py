"""The canonical in-memory motion every source parser returns, whatever the file format."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


class MotionFormatError(ValueError):
    """A motion file is malformed or truncated; the message names the file and the problem."""

    def __init__(self, path: str | Path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{path}: {problem}")


# Y-up source worlds (BVH, DeepMimic, OpenSim, dog keypoints) map to our Z-up world by a +90 deg rotation
# about x: (x, y, z)_yup -> (x, -z, y). For OpenSim (X forward, Y up, Z right) this gives x forward, y left.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def is_float(token: str) -> bool:
    """Whether a text token parses as a number (for naming the bad token in parse errors)."""
    try:
        float(token)
        return True
    except ValueError:
        return False


@dataclass
class Motion:
    """A motion clip in metres, radians and the Z-up world used by MuJoCo.

    ``joint_angles[:, i]`` is the angle of ``joint_names[i]`` (the source's own names: OpenSim coordinates,
    BVH ``<joint>_<axis>rotation`` channels, robot joint names ...). ``keypoints`` maps a point name to
    its world positions, shape (N, 3). ``root_quat`` is (w, x, y, z) of the source's root segment.
    """

    name: str
    time: np.ndarray
    root_pos: np.ndarray
    root_quat: np.ndarray
    joint_names: tuple[str, ...] = ()
    joint_angles: np.ndarray | None = None
    keypoints: dict[str, np.ndarray] = field(default_factory=dict)
    joint_velocities: np.ndarray | None = None
    skeleton: str = ""
    source: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.time)
        if self.joint_angles is None:
            self.joint_angles = np.zeros((n, len(self.joint_names)))
        self.joint_names = tuple(self.joint_names)
        shapes = {"root_pos": (n, 3), "root_quat": (n, 4), "joint_angles": (n, len(self.joint_names))}
        if self.joint_velocities is not None:
            shapes["joint_velocities"] = (n, len(self.joint_names))
        for attr, shape in shapes.items():
            if getattr(self, attr).shape != shape:
                raise MotionFormatError(self.source or self.name, f"{attr} has shape {getattr(self, attr).shape}, "
                                        f"expected {shape}")
        for key, points in self.keypoints.items():
            if points.shape != (n, 3):
                raise MotionFormatError(self.source or self.name, f"keypoint {key!r} has shape {points.shape}, "
                                        f"expected {(n, 3)}")
        if n < 2:
            raise MotionFormatError(self.source or self.name, f"needs at least 2 frames, has {n}")
        if np.any(np.diff(self.time) <= 0):
            raise MotionFormatError(self.source or self.name, "time stamps are not strictly increasing")
        arrays = [self.time, self.root_pos, self.root_quat, self.joint_angles, *self.keypoints.values()]
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise MotionFormatError(self.source or self.name, "contains NaN or infinite values")

    @property
    def n_frames(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    @property
    def frequency(self) -> float:
        """Mean frame rate in Hz."""
        return (self.n_frames - 1) / self.duration

    def angle(self, name: str) -> np.ndarray:
        """The angle trajectory of one named joint; KeyError lists the names there are."""
        try:
            return self.joint_angles[:, self.joint_names.index(name)]
        except ValueError:
            raise KeyError(f"{self.name} has no joint {name!r}; it has {list(self.joint_names)}") from None
