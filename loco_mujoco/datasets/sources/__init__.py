"""Parsers from motion-capture file formats to the canonical :class:`~loco_mujoco.datasets.motion.Motion`."""
