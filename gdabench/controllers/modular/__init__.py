"""One policy for many bodies: the parts of the ``modular-ppo`` controller of issue 56 (not registered yet).

Modules: ``observation`` (ModularEvoGym's per-voxel observations from the voxel engine's flat ones), ``policy``
(a shared MLP over voxel tokens), ``train`` (PPO on a generation's pooled experience).  What is missing before
it is a controller: docs/controllers/modular.md.
"""
