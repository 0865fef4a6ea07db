"""Shared environment machinery: the LocoEnv base class, task names, rewards."""
