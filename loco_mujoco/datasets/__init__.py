"""Datasets: motion sources, retargeting onto embodiments, task datasets and trajectories."""
