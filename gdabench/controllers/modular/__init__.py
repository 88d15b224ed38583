"""A modular (per-voxel) view of a body's observation, for one policy shared by many bodies.

Work in progress towards the ``modular-ppo`` controller of issue 56 (not registered yet): ``observation``
builds ModularEvoGym's per-voxel observations from the voxel engine's flat ones.
"""
