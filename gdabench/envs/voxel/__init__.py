"""A batched soft-voxel engine with Evolution Gym 2.0's physics (Numba, CPU).

Modules: ``model`` (a body as Evolution Gym builds it: points, edges, boxels), ``kernels`` (the
physics of one env step for many environments), ``engine`` (tables, state, the pure ``step``).
"""
