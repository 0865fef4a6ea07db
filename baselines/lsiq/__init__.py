"""LS-IQ: least-squares inverse Q-learning."""

from baselines.lsiq.lsiq import LSIQ, LSIQConfig

__all__ = ["LSIQ", "LSIQConfig"]
