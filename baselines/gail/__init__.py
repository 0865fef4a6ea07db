"""GAIL baseline; see the module docstring of baselines.gail.gail."""

from baselines.gail.gail import GAIL, GAILConfig

__all__ = ["GAIL", "GAILConfig"]
