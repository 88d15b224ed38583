"""The generational diffusion algorithm (thesis chapter 4): one module per job.

``designer`` the thesis's ask/tell loop, which ties the rest together; ``config`` its
parameters; ``encoding`` bodies <-> model values; ``schedule`` noise schedules; ``model`` the
U-Net; ``training`` fitting it to survivors; ``backend`` where that happens (here, or ahead on
a spare core: ``speculation``); ``sampling`` drawing bodies from it; ``quotas`` what a
generation's draw loop collects; ``surrogate`` the pool's reward model; ``prior`` bodies of
another run for generation 0.
"""

from .designer import GenerationalDiffusion

__all__ = ["GenerationalDiffusion"]
