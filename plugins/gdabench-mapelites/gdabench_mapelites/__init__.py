"""MAP-Elites for voxel bodies, packaged as a gdabench plugin."""

from .designer import MapElites

__all__ = ["MapElites"]
