"""SQIL: soft Q imitation learning."""

from baselines.sqil.sqil import SQIL, SQILConfig

__all__ = ["SQIL", "SQILConfig"]
