"""The fast backend: B reaching environments stepped at once, with the PyBullet env's semantics.

State lives in float64 torch tensors; the physics of one environment step is the fused kernel of
:mod:`taskcomplexity.tasks.dynamics` (parameters read from the same URDF files PyBullet loads) and
observations and rewards are the shared :mod:`taskcomplexity.tasks.mechanics`. Environments that
are done stop moving and stop accumulating reward while the others continue.

For the obstacle task the model has no contact forces: an environment whose forearm enters the
block's contact zone during a step is not advanced by the model; PyBullet's contact
solver may have acted on it there, so it is rolled back to the start of that step and marked in
:attr:`BatchedReaching.handoff`; the RWG runner finishes such episodes on the PyBullet reference.
"""

from __future__ import annotations

import numpy as np
import torch

from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.dynamics import ArmDynamics, advance, contact_zone
from taskcomplexity.tasks.spec import TaskSpec
from taskcomplexity.tasks.urdf import read_arm_urdf, urdf_path


class BatchedReaching:
    """B copies of one reaching task.

    Parameters
    ----------
    task : TaskSpec
    size : int
        Number of environments B.
    """

    def __init__(self, task: TaskSpec, size: int):
        self.task = task.validate()
        self.size = size
        dof = task.arm.dof
        self._dynamics = ArmDynamics(read_arm_urdf(urdf_path(task.arm))).vector()
        self._zone = contact_zone(task)
        self._scale = torch.tensor(task.arm.torque_scale, dtype=torch.float64)
        self.joint_angles = torch.zeros(size, dof, dtype=torch.float64)
        self.joint_velocities = torch.zeros(size, dof, dtype=torch.float64)
        self.target = torch.zeros(size, 2, dtype=torch.float64)
        self.active = torch.zeros(size, dtype=torch.bool)
        self.returns = torch.zeros(size, dtype=torch.float64)
        self.steps = torch.zeros(size, dtype=torch.int64)
        self.success = torch.zeros(size, dtype=torch.bool)
        self.handoff = torch.zeros(size, dtype=torch.bool)

    def reset(self, joint_angles: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """Start every environment from the given state (velocities 0).

        Parameters
        ----------
        joint_angles : Tensor (B, dof), rad
        target : Tensor (B, 2)
            Polar target (ρ in m, angle in rad).

        Returns
        -------
        Tensor (B, obs_size): the first observation.
        """
        self.joint_angles.copy_(joint_angles)
        self.joint_velocities.zero_()
        self.target.copy_(target)
        self.active.fill_(True)
        self.returns.zero_()
        self.steps.zero_()
        self.success.fill_(False)
        self.handoff.fill_(False)
        observation, *_ = mechanics.observe(self.task, self.joint_angles, self.joint_velocities, self.target)
        return observation

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

        An environment whose forearm entered the block's contact zone during this step is rolled back
        to the state it had before the step, marked in :attr:`handoff` and made inactive: its episode
        continues, from that state, on the PyBullet reference.
        """
        task = self.task
        action = action.clamp(-1.0, 1.0)
        was_active = self.active.clone()
        upper = mechanics.upper_arm_clearance(task, self.joint_angles) if task.arm.obstacle is not None else None
        torque = (action * self._scale).contiguous()
        before = (self.joint_angles.clone(), self.joint_velocities.clone()) if upper is not None else None
        contact = np.zeros(self.size, dtype=np.bool_)
        advance(
            self._dynamics,
            self.joint_angles.numpy(),
            self.joint_velocities.numpy(),
            torque.numpy(),
            was_active.numpy(),
            task.arm.time_step,
            task.arm.substeps,
            self._zone,
            contact,
        )
        contact = torch.from_numpy(contact)
        if before is not None and contact.any():
            self.joint_angles[contact] = before[0][contact]
            self.joint_velocities[contact] = before[1][contact]
            self.handoff |= contact
            was_active &= ~contact
            self.active &= ~contact
        observation, distance, elbow, effector = mechanics.observe(
            task, self.joint_angles, self.joint_velocities, self.target
        )
        forearm = mechanics.forearm_clearance(task, elbow, effector) if task.arm.obstacle is not None else None
        reward, terms, collision = mechanics.reward_terms(task, action, distance, upper, forearm)
        reward = torch.where(was_active, reward, torch.zeros_like(reward))
        done = was_active & (terms["success"] | collision)
        self.returns += reward
        self.steps += was_active.long()
        self.success |= was_active & terms["success"]
        self.active &= ~done
        return observation, reward, done
