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
"""
