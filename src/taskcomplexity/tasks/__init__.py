"""The tasks: the Task seam, the reaching arms (specs, URDFs, PyBullet reference, batched backend), any gymnasium id.

``docs/reference/tasks.md`` states the reaching tasks' exact mechanics.

Modules
-------
base
    The Task seam: what every measurable task provides, whatever simulates it.
batched
    The fast backend: B reaching environments stepped at once, with the PyBullet env's semantics.
batched_vector
    The fast backend as a gymnasium vector environment stepped by one kernel call.
classic
    Batched numba kernels of gymnasium's classic-control environments (a package).
contact
    The forearm–block contact of the obstacle task, modelled the way Bullet's multibody solver does it.
dynamics
    Batched planar-arm dynamics, integrated the way PyBullet's Featherstone multibody does it.
envpool_ids
    Which gymnasium ids EnvPool simulates (gymnasium's MuJoCo tasks, DM Control's): the envpool backend's.
from_config
    A composed config's task: the seam between the ``task``/``arm``/``reward`` groups and the Task types.
goal_env
    A goal-conditioned view of a reaching task, for Hindsight Experience Replay.
gym_task
    Any registered gymnasium id as a Task.
manipulation
    Meta-World's manipulation tasks as gymnasium envs whose episodes follow from their reset seeds.
mechanics
    Semantics shared by both backends: angle wrapping, kinematics, observations, clearances, rewards.
pybullet_env
    The reference: one reaching task in PyBullet, as a gymnasium environment.
quiet
    Silence a C library's writes to the standard streams for the span of a ``with`` block.
registration
    The package's gymnasium ids, registered lazily (PyBullet is imported only by ``make``).
reward_kinds
    The reward kinds, declared once: what each is and what its consumers branch on (read without the kernels).
rewards
    The reward kinds: declared once, computed by one scalar function.
rollout_kernel
    RWG's episodes as one fused numba kernel: each policy's forward pass, then the step kernel's step.
source
    The digest of an env's source in its task's identity: its file and the researcher's own modules it imports.
spec
    Task specifications: the arm, the reward and (optionally) the obstacle of a reaching task.
step_kernel
    The batched backend's environment step as one fused numba kernel.
vectorised
    Which gymnasium ids register a vector env that seeds each of its environments: the vector backend's.
urdf
    URDF files of the arms (the ``urdf/`` folder): written from an arm spec, read back for the batched backend.
"""

from taskcomplexity.tasks.spec import REWARDS, ArmSpec, RewardSpec, TaskSpec, arm_presets, make_task, preset_tasks

__all__ = ["REWARDS", "ArmSpec", "RewardSpec", "TaskSpec", "arm_presets", "make_task", "preset_tasks"]
