"""Behaviour cloning."""

from baselines.bc.bc import BC, BCConfig

__all__ = ["BC", "BCConfig"]
