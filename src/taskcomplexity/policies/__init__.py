"""The policy families whose random members RWG runs, each declared once in :mod:`.families`' registry.

Modules
-------
families
    What a family is (its spec and batch protocols), the registry by ``network.family``, the choice from config.
mlp
    Random MLPs: the paper's policy network, its priors and the batched forward pass.
movement_primitives
    Dynamic movement primitives: the basis functions and the integration of one primitive.
primitives
    The movement-primitive family: random DMP weights per joint, rolled out against the task's observations.
tanh
    The forward pass's tanh: NumPy's where NumPy runs its AVX-512 loop, the numba kernel elsewhere.
tanh_kernel
    tanh of float64 arrays as a numba loop of the CPU's vector width, its arithmetic pinned on every CPU path.
"""
