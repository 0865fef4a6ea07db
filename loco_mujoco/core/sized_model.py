"""The model of a body size from the class alone, so datasets can retarget onto each size without an environment.

``BodySizesMixin.load_spec`` scales an environment's model to its mode; :class:`SizedModelMixin` applies the same
rule to ``model_spec(mode)``. Put it first: ``class HumanoidTorque4Ages(SizedModelMixin, BodySizesMixin, ...)``.
"""

from __future__ import annotations

import mujoco

from loco_mujoco.core.body_sizes import SIZES, BodySizesMixin
from loco_mujoco.models.scaling import scale_spec


class SizedModelMixin:
    """``model_spec(mode)`` for body-size embodiments: the embodiment's model scaled to size ``mode`` (``all``:
    the adult, the last size, as an environment in mode ``all`` starts)."""

    @classmethod
    def model_spec(cls, mode: str | None) -> mujoco.MjSpec:
        spec = super(BodySizesMixin, cls).load_spec()  # the embodiment's own classmethod, past the instance hook
        size = mode if mode in SIZES else SIZES[-1]
        if size != SIZES[-1]:
            scale_spec(spec, cls.size_factor(size))
        return spec
