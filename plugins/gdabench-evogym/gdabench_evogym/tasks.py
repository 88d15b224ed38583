"""The task ids of Evolution Gym 2.0 (``evogym.BASELINE_ENV_NAMES``), from gdabench's catalog.

Kept as data so that ``gdabench list`` does not import the simulator; a test checks the list against
the installed Evolution Gym.
"""

from gdabench.envs.tasks.catalog import CATALOG

TASKS = tuple(CATALOG)
