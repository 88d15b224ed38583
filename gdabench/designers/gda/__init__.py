"""The generational diffusion algorithm (thesis chapter 4): one module per job.

``encoding`` bodies <-> model values; ``schedule`` noise schedules; ``model`` the U-Net;
``training`` fitting it to survivors; ``sampling`` drawing bodies from it; ``runtime`` device
and threads; ``designer`` the ask/tell loop that ties them together.
"""

from .designer import GenerationalDiffusion

__all__ = ["GenerationalDiffusion"]
