"""The ``pybullet`` RWG backend, and the hand-over of the ``batched`` backend's contact episodes to it.

The reaching arms' PyBullet reference env (:class:`taskcomplexity.tasks.pybullet_env.ReachingEnv`) runs one
episode at a time: :func:`simulate_pybullet` every episode of a chunk from its start;
:func:`finish_on_pybullet` the obstacle task's episodes that reached the block on the batched backend, from
the state where they stopped, with the policy's own state there. Both step a policy of one through
:meth:`~taskcomplexity.policies.families.SteppedBatch.begin` and ``respond``.
"""

from __future__ import annotations

import numpy as np
import torch

from taskcomplexity.policies.families import EpisodeState, SteppedBatch
from taskcomplexity.rwg.arm_resets import initial_states
from taskcomplexity.rwg.backends import Plan, Runner
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.tasks.spec import TaskSpec


def simulate_pybullet(task: TaskSpec, policies: SteppedBatch, joint_angles: np.ndarray,
                      target: np.ndarray) -> ReturnChunk:
    """Every episode of the chunk on the PyBullet reference, one after another.

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

    Returns
    -------
    ReturnChunk
        Returns (P, M) in the task's reward units, steps, success.
    """
    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    n_pol, n_ep = joint_angles.shape[:2]
    returns = np.zeros((n_pol, n_ep))
    steps = np.zeros((n_pol, n_ep), dtype=np.int64)
    success = np.zeros((n_pol, n_ep), dtype=bool)
    env = ReachingEnv(task=task)
    try:
        for p in range(n_pol):
            policy = policies.select(p)
            for e in range(n_ep):
                obs, _ = env.reset(options={"joint_angles": joint_angles[p, e], "target": target[p, e]})
                returns[p, e], steps[p, e], success[p, e] = run_episode(env, policy, obs, task.max_steps)
    finally:
        env.close()
    return ReturnChunk(policies.indices.copy(), returns, steps, success)


def finish_on_pybullet(task: TaskSpec, policies: SteppedBatch, env, handoff: np.ndarray, returns: np.ndarray,
                       steps: np.ndarray, success: np.ndarray, progress: bool = False,
                       planned: dict[int, EpisodeState] | None = None) -> None:
    """Continue handed-over episodes on the PyBullet reference, from the state where they stopped.

    Parameters
    ----------
    task : TaskSpec
    policies : SteppedBatch
        The P policies of the chunk.
    env : BatchedReaching
        The batched env of the chunk's P·M episodes (policy-major), holding their last state.
    handoff : ndarray (P, M) bool
        The episodes to finish.
    returns, steps, success : ndarray (P, M)
        The chunk's results so far, completed in place.
    progress : bool
        A bar over the handed-over episodes.
    planned : dict, optional
        Flat environment (p·M + e) → the policy's own state there, for families that keep one.
    """
    n_ep = handoff.shape[1]
    planned = planned or {}
    jobs = []
    for p, e in zip(*np.nonzero(handoff), strict=True):
        flat = p * n_ep + e
        one = policies.select(int(p))
        jobs.append(
            (
                int(p),
                int(e),
                one,
                env.joint_angles[flat].numpy().copy(),
                env.joint_velocities[flat].numpy().copy(),
                env.target[flat].numpy().copy(),
                task.max_steps - int(steps[p, e]),
                planned.get(int(flat)),
            )
        )
    from tqdm.auto import tqdm

    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    reference = ReachingEnv(task=task)
    try:
        bar = tqdm(jobs, desc="obstacle contacts on pybullet", unit="ep", disable=not progress, leave=False)
        outcomes = [_continue_episode(reference, job) for job in bar]
    finally:
        reference.close()
    for (p, e, *_), (ret, n, ok) in zip(jobs, outcomes, strict=True):
        returns[p, e] += ret
        steps[p, e] += n
        success[p, e] |= ok


def _continue_episode(env, job) -> tuple[float, int, bool]:
    """Finish one handed-over episode on the reference ``env`` from the state where it stopped."""
    _, _, policy, joint_angles, joint_velocities, target, max_steps, state = job  # the whole policy
    obs, _ = env.reset(options={"joint_angles": joint_angles, "joint_velocities": joint_velocities, "target": target})
    return run_episode(env, policy, obs, max_steps, state)


def run_episode(env, policy: SteppedBatch, obs: np.ndarray, max_steps: int,
                state: EpisodeState | None = None) -> tuple[float, int, bool]:
    """One episode of a policy of one on the reference ``env``, from its observation ``obs``.

    Parameters
    ----------
    env : ReachingEnv
    policy : SteppedBatch
        A batch of one policy.
    obs : ndarray (obs,) float64
        The observation the episode continues from.
    max_steps : int
        Steps left in the episode.
    state : EpisodeState, optional
        The policy's own state mid-episode; None: a new one
        (:meth:`~taskcomplexity.policies.families.SteppedBatch.begin`).

    Returns
    -------
    (return, steps, success) : float, int, bool
        The sum of the rewards of these steps, their number, whether the episode ended at the target.
    """
    total, n, ok = 0.0, 0, False
    with torch.no_grad():
        if state is None:
            state = policy.begin(torch.from_numpy(obs).view(1, 1, -1))
        for _ in range(max_steps):
            action, state = policy.respond(torch.from_numpy(obs).view(1, 1, -1), state)
            action = action[0, 0].numpy()
            obs, reward, terminated, _, info = env.step(action)
            total += reward
            n += 1
            if terminated:
                ok = info["success"]
                break
    return total, n, ok


class PyBulletRunner(Runner):
    """The ``pybullet`` backend's runner: each batch from its reset states (:mod:`taskcomplexity.rwg.arm_resets`)
    through :func:`simulate_pybullet`."""

    def run(self, policies: SteppedBatch, plan: Plan) -> ReturnChunk:
        joint_angles, target = initial_states(self.task, plan.seed, policies.indices, plan.episodes,
                                              plan.common_initial_states)
        return simulate_pybullet(self.task, policies, joint_angles, target)
