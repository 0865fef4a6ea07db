"""What the datasets layer needs of an embodiment: a plain record and the compiled model to retarget onto.

The datasets layer sits below the environments, so it never sees an environment class. Each embodiment
describes itself as a :class:`DatasetSubject` (``LocoEnv.dataset_subject()``): its name, tasks, body sizes,
retargeting spec and a ``target(task, mode)`` callable that compiles its model without building an
environment. The records live here, with their only consumer; the layers above fill them in.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import mujoco
import numpy as np

if TYPE_CHECKING:
    from loco_mujoco.datasets.retarget import HumanoidRetarget, QuadrupedRetarget


@dataclass(frozen=True, eq=False)
class RetargetTarget:
    """A compiled model to retarget motion onto (arms free, a carry task's load included), its home pose in its
    qpos layout, and how motion maps onto it. ``label`` names it, e.g. ``HumanoidTorque4Ages.walk.2``."""

    label: str
    model: mujoco.MjModel
    home_qpos: np.ndarray
    spec: HumanoidRetarget | QuadrupedRetarget


@dataclass(frozen=True, eq=False)
class DatasetSubject:
    """An embodiment as the datasets see it.

    ``name`` is the environment class name (it names cache files, so it must not change), ``tasks`` its task
    names, ``sizes`` its body sizes (mode ``all`` joins one dataset per size), ``retarget`` how motion maps onto
    it (None: no real datasets), ``old_format_joints`` the original LocoMuJoCo joint names mapped to its own,
    and ``target(task, mode)`` its compiled model for that task and mode (mode None: the default one).
    """

    name: str
    tasks: tuple[str, ...]
    retarget: HumanoidRetarget | QuadrupedRetarget | None
    target: Callable[[str, str | None], RetargetTarget]
    sizes: tuple[str, ...] = ()
    old_format_joints: Mapping[str, str] = field(default_factory=dict)


class HasDatasetSubject(Protocol):
    """Anything that can describe itself as a dataset subject, e.g. an environment class."""

    def dataset_subject(self) -> DatasetSubject: ...


def as_subject(subject: DatasetSubject | HasDatasetSubject) -> DatasetSubject:
    """``subject`` itself, or the record that an environment class (or anything with ``dataset_subject()``) gives."""
    if isinstance(subject, DatasetSubject):
        return subject
    describe = getattr(subject, "dataset_subject", None)
    if describe is None:
        raise TypeError(f"expected a DatasetSubject, or an object with dataset_subject() such as an environment "
                        f"class; got {subject!r}")
    return describe()
