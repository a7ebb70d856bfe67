"""The ``batched`` RWG backend: every episode of a chunk of policies on the reaching arms' numba kernel.

An MLP family runs fused: each policy's episodes run to their end in one kernel, forward pass and physics
together (:meth:`taskcomplexity.tasks.batched.BatchedReaching.rollout`). Any other family steps: one batched
:meth:`~taskcomplexity.policies.families.SteppedBatch.respond` of the policies and one
:meth:`~taskcomplexity.tasks.batched.BatchedReaching.step` per environment step. On the obstacle task with
``rwg.contacts=pybullet``, the episodes that reach the block are handed over to the PyBullet reference where they
stopped (:func:`taskcomplexity.rwg.pybullet_backend.finish_on_pybullet`).
"""

from __future__ import annotations

import numpy as np
import torch

from taskcomplexity.policies.families import EpisodeState, SteppedBatch
from taskcomplexity.policies.mlp import PolicyBatch
from taskcomplexity.rwg.arm_resets import initial_states
from taskcomplexity.rwg.backends import Plan, Runner
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.pybullet_backend import finish_on_pybullet
from taskcomplexity.tasks.spec import TaskSpec


def simulate_batched(
    task: TaskSpec, policies: SteppedBatch, joint_angles: np.ndarray, target: np.ndarray, contacts: str = "pybullet",
    progress: bool = False, *, fused: bool = True, precision: str = "float64",
) -> ReturnChunk:
    """Every episode of the chunk on the batched backend.

    Parameters
    ----------
    task : TaskSpec
        A reaching arm.
    policies : SteppedBatch
        P policies.
    joint_angles : ndarray (P, M, dof) float64
        Initial joint angles, rad (:func:`taskcomplexity.rwg.arm_resets.initial_states`).
    target : ndarray (P, M, 2) float64
        Targets in polar form (m, rad).
    contacts : {'pybullet', 'model'}
        ``rwg.contacts``: the obstacle task's contacts finished on PyBullet or integrated by the contact model.
    progress : bool
        A bar over the episodes handed over to PyBullet.
    fused : bool
        (MLPs only) each policy's episodes run to their end in one kernel (forward pass and step per
        environment, :meth:`~taskcomplexity.tasks.batched.BatchedReaching.rollout`); otherwise step by step, one batched
        :meth:`~taskcomplexity.policies.families.SteppedBatch.respond` of the policies and one
        :meth:`~taskcomplexity.tasks.batched.BatchedReaching.step` per environment step — the reference the fused
        rollout is tested and benchmarked against, and every other family's path.
    precision : {'float64', 'float32'}
        The fused forward pass's arithmetic (``float32`` needs the fused MLP path).

    Returns
    -------
    ReturnChunk
        Returns (P, M) in the task's reward units, steps, success, the number of episodes handed over and of
        those the contact model touched.
    """
    from taskcomplexity.tasks.batched import BatchedReaching

    n_pol, n_ep = joint_angles.shape[:2]
    env = BatchedReaching(task, n_pol * n_ep, contacts)
    obs = env.reset(torch.from_numpy(joint_angles.reshape(n_pol * n_ep, -1)), torch.from_numpy(target.reshape(-1, 2)))
    planned: dict[int, EpisodeState] = {}  # flat environment → the policy's state where it was handed over
    if precision != "float64" and not (fused and isinstance(policies, PolicyBatch)):
        raise ValueError(f"precision={precision} runs on the fused rollout of an MLP family only")
    if fused and isinstance(policies, PolicyBatch):  # the fused kernel runs the MLP family's packed weights
        env.rollout(*policies.packed(), activation=policies.activation, output=policies.output,
                    bias=policies.biases is not None, input_bias=policies.input_bias, precision=precision)
    else:
        with torch.no_grad(), policies:  # closing the batch ends its forward-pass threads
            state = policies.begin(obs.view(n_pol, n_ep, -1))
            for _ in range(task.max_steps):
                if not env.active.numpy().any():  # NumPy: no torch thread pool woken per step
                    break
                before, handed = state, env.handoff.numpy().copy()
                action, state = policies.respond(obs.view(n_pol, n_ep, -1), state)
                obs, _, _ = env.step(action.reshape(n_pol * n_ep, -1))
                if before is not None:
                    for flat in np.flatnonzero(env.handoff.numpy() & ~handed):
                        planned[int(flat)] = before.row(*divmod(int(flat), n_ep))
    returns = env.returns.numpy().reshape(n_pol, n_ep).copy()
    steps = env.steps.numpy().reshape(n_pol, n_ep).copy()
    success = env.success.numpy().reshape(n_pol, n_ep).copy()
    handoff = env.handoff.numpy().reshape(n_pol, n_ep)
    if handoff.any():
        finish_on_pybullet(task, policies, env, handoff, returns, steps, success, progress, planned)
    return ReturnChunk(
        policies.indices.copy(), returns, steps, success, int(handoff.sum()), int(env.contact.numpy().sum())
    )


class BatchedRunner(Runner):
    """The ``batched`` backend's runner: each batch from its reset states (:mod:`taskcomplexity.rwg.arm_resets`)
    through :func:`simulate_batched`."""

    def run(self, policies: SteppedBatch, plan: Plan) -> ReturnChunk:
        joint_angles, target = initial_states(self.task, plan.seed, policies.indices, plan.episodes,
                                              plan.common_initial_states)
        return simulate_batched(self.task, policies, joint_angles, target, plan.contacts, plan.progress,
                                precision=plan.precision)
