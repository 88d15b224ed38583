"""``modular-ppo``: one policy for many bodies (issue 56).

Modules: ``observation`` (ModularEvoGym's per-voxel observations from the voxel engine's flat ones), ``policy``
(a shared MLP over voxel tokens), ``train`` (PPO on a generation's pooled experience), ``config`` (its settings,
checked without torch), ``controller`` (the controller: a generation learns together, the policy is carried on
to the next generation and kept in the trial's folder).
"""
