"""GAIfO baseline; see the module docstring of baselines.gaifo.gaifo."""

from baselines.gaifo.gaifo import GAIfO, GAIfOConfig

__all__ = ["GAIfO", "GAIfOConfig"]
