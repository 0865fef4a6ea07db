"""VAIL baseline; see the module docstring of baselines.vail.vail."""

from baselines.vail.vail import VAIL, VAILConfig

__all__ = ["VAIL", "VAILConfig"]
