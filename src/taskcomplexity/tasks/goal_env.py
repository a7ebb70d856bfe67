"""A goal-conditioned view of a reaching task, for Hindsight Experience Replay (HER).

HER needs the task's observation split into a goal-free part and two goals, and the reward as a
function of (achieved goal, desired goal) so that a transition can be re-scored for a goal it was not
collected for. For the reaching tasks:

- ``achieved_goal`` = (ex, ey), the end-effector position *as observed* (from the rounded angles
  where the task rounds them), metres;
- ``desired_goal`` = (gx, gy), the target position as observed, metres;
- ``observation`` = the entries of the task observation that do not depend on the goal:

  | arm | ``observation`` | task observation entries |
  |---|---|---|
  | 1-link | w(q), ex, ey, q̇ | 0, 1, 2, 8 |
  | 2-link | cos q̂₁, cos(q̂₁+q̂₂), sin q̂₁, sin(q̂₁+q̂₂), ex, ey | 0, 1, 2, 3, 6, 7 |

The split loses nothing: :func:`join_observation` rebuilds the task observation from
(``observation``, ``desired_goal``) — the target angle w(θ) = atan2(gy, gx) mod 2π of a 1-link task to
within floating-point rounding, everything else exactly — so a goal-conditioned agent can see exactly
the inputs of the plain agent, for any (relabelled) goal.

:func:`compute_reward` is the task's own reward (:func:`taskcomplexity.tasks.rewards.reward`) with
d = ‖a − g‖:

- sparse: r = 0 if ‖a − g‖ < threshold else −1 (the whole reward: the kind's
  :attr:`~taskcomplexity.tasks.rewards.RewardKind.goal_reward`);
- dense: r = −‖a − g‖² without the action; the action term −Σ aᵢ² is not a function of the goals,
  so whoever relabels a dense transition passes the stored action (the HER buffer of
  ``taskcomplexity.rl.her`` does). The obstacle task's collision and proximity terms are not
  goal-dependent either, and its goal view is not provided (HER is a sparse-reward method).

Registered ids (by :func:`register_goal_tasks`, which callers invoke; importing this module does not
register anything): ``taskcomplexity/OneLink1m0-Sparse-Goal-v0``, ``…-Dense-Goal-v0``, likewise
``OneLink1m65`` and ``TwoLink``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks import rewards
from taskcomplexity.tasks.mechanics import xp_of
from taskcomplexity.tasks.registration import MAX_EPISODE_STEPS
from taskcomplexity.tasks.spec import TaskSpec, gym_id, make_task, preset_tasks

GOAL_SIZE = 2
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class GoalLayout:
    """Where the goal-free part and the two goals sit in a task observation (column indices)."""

    observation: tuple[int, ...]
    achieved_goal: tuple[int, int]
    desired_goal: tuple[int, int]


_ONE_LINK = GoalLayout(observation=(0, 1, 2, 8), achieved_goal=(1, 2), desired_goal=(4, 5))
_TWO_LINK = GoalLayout(observation=(0, 1, 2, 3, 6, 7), achieved_goal=(6, 7), desired_goal=(4, 5))


def goal_layout(task: TaskSpec) -> GoalLayout:
    """The :class:`GoalLayout` of ``task``.

    Raises
    ------
    ConfigError
        For a task with an obstacle (its reward is not a function of the goals).
    """
    if task.arm.obstacle is not None:
        raise ConfigError(
            f"task {task.task_id} has no goal-conditioned view: its collision and proximity terms "
            "are not functions of the goals (allowed: tasks without an obstacle)"
        )
    return _ONE_LINK if task.arm.dof == 1 else _TWO_LINK


def observation_size(task: TaskSpec) -> int:
    """Length of the goal-free ``observation`` (4 for a 1-link arm, 6 for a 2-link arm)."""
    return len(goal_layout(task).observation)


def split_observation(task: TaskSpec, task_observation) -> dict[str, Any]:
    """Task observation (..., 9 or 10) → ``observation``, ``achieved_goal`` (..., 2), ``desired_goal`` (..., 2).

    Works on NumPy arrays and torch tensors alike (leading dimensions are batch dimensions).
    """
    layout = goal_layout(task)
    return {
        "observation": task_observation[..., list(layout.observation)],
        "achieved_goal": task_observation[..., list(layout.achieved_goal)],
        "desired_goal": task_observation[..., list(layout.desired_goal)],
    }


def join_observation(task: TaskSpec, observation, desired_goal):
    """Rebuild the task observation (..., 9 or 10) from the goal-free part and a (relabelled) goal.

    Parameters
    ----------
    observation : array (..., 4) for a 1-link arm, (..., 6) for a 2-link arm
    desired_goal : array (..., 2)
        Target position (gx, gy), metres.

    Returns
    -------
    array (..., 9) or (..., 10)
        The layout of ``mechanics.observe``. For a 1-link arm the target angle is recovered as
        atan2(gy, gx) mod 2π, equal to the observed w(θ) to within a few ulp.
    """
    xp = xp_of(observation)
    gx, gy = desired_goal[..., 0], desired_goal[..., 1]
    if task.arm.dof == 1:
        q, ex, ey, qdot = (observation[..., i] for i in range(4))
        angle = xp.remainder(xp.arctan2(gy, gx), TWO_PI)
        columns = [q, ex, ey, angle, gx, gy, ex - gx, ey - gy, qdot]
    else:
        c1, c12, s1, s12, ex, ey = (observation[..., i] for i in range(6))
        columns = [c1, c12, s1, s12, gx, gy, ex, ey, ex - gx, ey - gy]
    return xp.stack(columns, -1)


def goal_distance(achieved_goal, desired_goal):
    """‖achieved − desired‖ over the last axis, metres; shape (...,)."""
    xp = xp_of(achieved_goal)
    delta = achieved_goal - desired_goal
    return xp.sqrt(delta[..., 0] ** 2 + delta[..., 1] ** 2)


def _numpy(x) -> np.ndarray:
    """``x`` as a float64 NumPy array (a torch tensor is copied off its device)."""
    if xp_of(x) is not np:
        x = x.detach().cpu().numpy()
    return np.asarray(x, dtype=np.float64)


def _like(values: np.ndarray, x):
    """``values`` in the array type of ``x``: a tensor on its device (in its dtype, for floats)."""
    if xp_of(x) is np:
        return values
    import torch

    out = torch.as_tensor(values, device=x.device)
    return out.to(x.dtype) if out.is_floating_point() else out


def compute_reward(task: TaskSpec, achieved_goal, desired_goal, action=None):
    """The reward of ``task`` for goals (and actions), vectorised over leading dimensions.

    Parameters
    ----------
    achieved_goal, desired_goal : array (..., 2)
        Metres (NumPy arrays or torch tensors).
    action : array (..., dof), optional
        The actions (clipped to [−1, 1] here); without them a dense reward has no action term.

    Returns
    -------
    array (...,)
        :func:`taskcomplexity.tasks.rewards.reward` of d = ‖a − g‖, in the type of ``achieved_goal``:
        sparse, 0 where ‖a − g‖ < threshold, −1 elsewhere (the task's whole reward); dense,
        −‖a − g‖² − Σ aᵢ² (without ``action``: −‖a − g‖², see the module notes).
    """
    distance = _numpy(goal_distance(achieved_goal, desired_goal))
    effort = 0.0 if action is None else (np.clip(_numpy(action), -1.0, 1.0) ** 2).sum(-1)
    return _like(rewards.rewards(task.reward.kind, distance, task.reward.threshold, effort), achieved_goal)


def goal_reached(task: TaskSpec, achieved_goal, desired_goal):
    """The task's success (and termination) condition ‖a − g‖ < threshold; bool array (...,).

    :func:`taskcomplexity.tasks.rewards.success` on the float64 distance, as :func:`compute_reward`
    sees it (so the two agree on every goal), in the type of ``achieved_goal``.
    """
    distance = _numpy(goal_distance(achieved_goal, desired_goal))
    return _like(np.asarray(rewards.success(distance, task.reward.threshold)), achieved_goal)


class GoalReachingEnv(gymnasium.ObservationWrapper):
    """A reaching task seen as a goal-conditioned environment.

    ## Observation space
    ``Dict(observation=Box(4 or 6), achieved_goal=Box(2), desired_goal=Box(2))``, float64; see the
    module docstring for the entries and units.

    ## Rewards, starting state, episode end
    Those of the wrapped task, unchanged. :meth:`compute_reward` recomputes the goal-dependent
    reward for any goals (gymnasium-robotics ``GoalEnv`` signature).

    ## Arguments
    ``env``: a :class:`~taskcomplexity.tasks.pybullet_env.ReachingEnv` (or a wrapper of one) whose
    ``task`` has no obstacle.

    ## Version history
    v0: initial release.
    """

    def __init__(self, env: gymnasium.Env):
        super().__init__(env)
        self.task: TaskSpec = env.unwrapped.task
        size = observation_size(self.task)
        box = spaces.Box(-np.inf, np.inf, (GOAL_SIZE,), dtype=np.float64)
        self.observation_space = spaces.Dict(
            {
                "observation": spaces.Box(-np.inf, np.inf, (size,), dtype=np.float64),
                "achieved_goal": box,
                "desired_goal": box,
            }
        )

    def observation(self, observation):
        return split_observation(self.task, np.asarray(observation, dtype=np.float64))

    def compute_reward(self, achieved_goal, desired_goal, info: Any = None):
        """Goal-dependent reward, shape ``achieved_goal.shape[:-1]`` (see :func:`compute_reward`)."""
        return compute_reward(self.task, np.asarray(achieved_goal), np.asarray(desired_goal))


def make_goal_env(arm: str = "one_link_1m0", reward: str = "sparse", task: TaskSpec | None = None) -> GoalReachingEnv:
    """Gymnasium entry point: the goal view of ``ReachingEnv(arm, reward, task)`` (no time limit)."""
    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    return GoalReachingEnv(ReachingEnv(arm=arm, reward=reward, task=task))


def goal_gym_id(arm: str, reward: str) -> str:
    """``('two_link', 'sparse')`` → ``'taskcomplexity/TwoLink-Sparse-Goal-v0'``."""
    return gym_id(arm, reward).removesuffix("-v0") + "-Goal-v0"


def goal_gym_ids() -> dict[tuple[str, str], str]:
    """The goal view's gymnasium id of every preset task without an obstacle, by ``(arm, reward)``."""
    return {(arm, reward): goal_gym_id(arm, reward) for arm, reward in preset_tasks()
            if make_task(arm, reward).arm.obstacle is None}


def register_goal_tasks() -> None:
    """Register the goal view of every preset task without an obstacle with gymnasium (idempotent)."""
    for (arm, reward), env_id in goal_gym_ids().items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point="taskcomplexity.tasks.goal_env:make_goal_env",
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs={"arm": arm, "reward": reward},
            )


__all__ = [
    "GOAL_SIZE",
    "GoalLayout",
    "GoalReachingEnv",
    "compute_reward",
    "goal_distance",
    "goal_gym_id",
    "goal_gym_ids",
    "goal_layout",
    "goal_reached",
    "join_observation",
    "make_goal_env",
    "observation_size",
    "register_goal_tasks",
    "split_observation",
]
