"""IQ-Learn: inverse soft-Q learning."""

from baselines.iq_learn.iq_learn import IQLearn, IQLearnConfig

__all__ = ["IQLearn", "IQLearnConfig"]
