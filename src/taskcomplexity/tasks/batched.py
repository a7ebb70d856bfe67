"""The fast backend: B reaching environments stepped at once, with the PyBullet env's semantics.

State lives in float64 torch tensors; one environment step (physics with parameters read from the
same URDF files PyBullet loads, then observation, reward and bookkeeping) is the fused numba kernel
of :mod:`taskcomplexity.tasks.step_kernel`, held to :mod:`taskcomplexity.tasks.mechanics` by tests.
Environments that are done stop moving and stop accumulating reward while the others continue.

The obstacle task's forearm–block contacts are handled in one of two ways (``contacts``):

- ``"pybullet"`` (exact): an environment whose forearm enters the block's contact zone during a step
  is rolled back to the start of that step and marked in :attr:`BatchedReaching.handoff`; the RWG
  runner finishes such episodes on the PyBullet reference.
- ``"model"`` (fast): contacts act as :mod:`taskcomplexity.tasks.contact` models Bullet's solver;
  :attr:`BatchedReaching.contact` marks the episodes the block acted on. PyBullet's contact dynamics
  are chaotic, so these episodes agree with PyBullet in distribution, not one by one.
"""

from __future__ import annotations

import numpy as np
import torch

from taskcomplexity.tasks import mechanics, rollout_kernel, step_kernel
from taskcomplexity.tasks.dynamics import ArmDynamics, contact_zone
from taskcomplexity.tasks.spec import TaskSpec
from taskcomplexity.tasks.urdf import read_arm_urdf, urdf_path


class BatchedReaching:
    """B copies of one reaching task.

    Parameters
    ----------
    task : TaskSpec
    size : int
        Number of environments B.
    contacts : {"pybullet", "model"}
        How the obstacle task's contacts are handled (see the module docstring).
    """

    def __init__(self, task: TaskSpec, size: int, contacts: str = "pybullet"):
        self.task = task.validate()
        self.size = size
        step_kernel.prepare_kernels()
        dof = task.arm.dof
        self._kernel = step_kernel.KernelTask(
            arm=ArmDynamics(read_arm_urdf(urdf_path(task.arm))).params(), task=mechanics.task_params(task),
            zone=contact_zone(task, contacts), time_step=task.arm.time_step, substeps=task.arm.substeps,
        )
        self.joint_angles = torch.zeros(size, dof, dtype=torch.float64)
        self.joint_velocities = torch.zeros(size, dof, dtype=torch.float64)
        self.target = torch.zeros(size, 2, dtype=torch.float64)
        self.active = torch.zeros(size, dtype=torch.bool)
        self.returns = torch.zeros(size, dtype=torch.float64)
        self.steps = torch.zeros(size, dtype=torch.int64)
        self.success = torch.zeros(size, dtype=torch.bool)
        self.handoff = torch.zeros(size, dtype=torch.bool)
        self.contact = torch.zeros(size, dtype=torch.bool)
        self.observation = torch.zeros(size, task.observation_size, dtype=torch.float64)
        self.reward = torch.zeros(size, dtype=torch.float64)
        self.done = torch.zeros(size, dtype=torch.bool)
        self._state = {
            name: getattr(self, name).numpy()
            for name in (
                "joint_angles", "joint_velocities", "target", "active", "returns", "steps", "success", "handoff",
                "contact", "observation", "reward", "done",
            )
        }

    def reset(
        self, joint_angles: torch.Tensor, target: torch.Tensor, index: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Start the environments ``index`` (every one when None) from the given state (velocities 0).

        Parameters
        ----------
        joint_angles : Tensor (n, dof), rad
        target : Tensor (n, 2)
            Polar target (ρ in m, angle in rad).
        index : Tensor (n,) of int, optional
            The environments to start; the others keep their state. n = B without it.

        Returns
        -------
        Tensor (B, obs_size): the observation buffer, the started environments' first observation in their rows.
        """
        at = slice(None) if index is None else index
        self.joint_angles[at] = joint_angles
        self.joint_velocities[at] = 0.0
        self.target[at] = target
        self.active[at] = True
        self.returns[at] = 0.0
        self.steps[at] = 0
        for flags in (self.success, self.handoff, self.contact, self.done):
            flags[at] = False
        self.reward[at] = 0.0
        observation, *_ = mechanics.observe(self.task, self.joint_angles[at], self.joint_velocities[at],
                                            self.target[at])
        self.observation[at] = observation
        return self.observation

    def step(self, action: torch.Tensor):
        """Advance every active environment by one step.

        Parameters
        ----------
        action : Tensor (B, dof)
            Clipped to [−1, 1].

        Returns
        -------
        observation : Tensor (B, obs_size)
        reward : Tensor (B,)
            This step's reward (0 for environments that were already done).
        done : Tensor (B,), bool
            Terminated this step.

        The three are buffers owned by the environment, overwritten by the next step; the
        observation of an environment that is no longer active keeps its last value.

        An environment whose forearm entered the block's contact zone during this step is rolled back
        to the state it had before the step, marked in :attr:`handoff` and made inactive: its episode
        continues, from that state, on the PyBullet reference.
        """
        action = torch.as_tensor(action, dtype=torch.float64).contiguous()
        step_kernel.step(self._kernel, self._state, action.numpy())
        return self.observation, self.reward, self.done

    def rollout(
        self,
        weights: np.ndarray,
        layer_sizes: np.ndarray,
        *,
        activation: str = "relu",
        output: str = "tanh",
        bias: bool = False,
        input_bias: bool = False,
        precision: str = "float64",
    ) -> None:
        """Run every active environment's episode to its end, each under its own random MLP policy.

        What repeated :meth:`step` calls with the policies' actions do, in one fused kernel
        (:mod:`taskcomplexity.tasks.rollout_kernel`): environments that are done cost nothing, and
        hand-overs leave the state :meth:`step` leaves.

        Parameters
        ----------
        weights : ndarray (P, S)
            P policies' packed parameters (:meth:`taskcomplexity.policies.mlp.PolicyBatch.packed`);
            environment i follows policy i // (B / P).
        layer_sizes : ndarray (L + 1,) int
        activation, output, bias, input_bias
            As in :class:`taskcomplexity.policies.mlp.NetworkSpec`.
        precision : {'float64', 'float32'}
            The forward pass's arithmetic (:func:`taskcomplexity.tasks.rollout_kernel.rollout`).
        """
        if self.size % len(weights):
            raise ValueError(f"{self.size} environments do not split evenly over {len(weights)} policies")
        rollout_kernel.rollout(
            self._kernel, self._state, weights, layer_sizes, episodes=self.size // len(weights),
            max_steps=self.task.max_steps, activation=activation, output=output, bias=bias, input_bias=input_bias,
            precision=precision,
        )
