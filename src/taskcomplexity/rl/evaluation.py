"""Deterministic evaluation of the seeds' policies: every seed's episodes run side by side."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from taskcomplexity.seeding import derive_seed
from taskcomplexity.tasks.base import Task
from taskcomplexity.tasks.goal_env import goal_distance
from taskcomplexity.tasks.spec import TaskSpec

# Columns (ex − gx, ey − gy) of the task observation: 1-link, 2-link.
_DELTA_COLUMNS = {1: slice(6, 8), 2: slice(8, 10)}


def evaluation_seeds(seeds: Sequence[int], episodes: int) -> list[int]:
    """Reset seeds of the evaluation instances, seed-major: instance ``s·episodes + e``.

    The same start states are used at every evaluation of a run (common random numbers across the
    curve), and seed s's set does not depend on the other seeds trained with it.
    """
    return [derive_seed(seed, "eval", episode) for seed in seeds for episode in range(episodes)]


def observed_distance(task: TaskSpec, next_td: TensorDictBase, *, goal_conditioned: bool) -> torch.Tensor:
    """End-effector–target distance d after a step, from the observation; metres, shape (N,)."""
    if goal_conditioned:
        return goal_distance(next_td.get("achieved_goal"), next_td.get("desired_goal"))
    delta = next_td.get("observation")[..., _DELTA_COLUMNS[task.arm.dof]]
    return torch.linalg.vector_norm(delta, dim=-1)


def evaluate(
    env: EnvBase,
    policy: TensorDictModuleBase,
    task: Task,
    *,
    seeds: Sequence[int],
    episodes: int,
    goal_conditioned: bool,
    success_key: str | None = None,
    solved_return: float | None = None,
    device: torch.device | str = "cpu",
) -> tuple[np.ndarray, np.ndarray]:
    """Run ``episodes`` episodes per seed with the mean action, all at once.

    Parameters
    ----------
    env : EnvBase
        ``len(seeds) × episodes`` instances of ``task`` (``make_env``), batch ``(S·E,)``.
    policy : actor with one parameter set per seed (input ``(S, E, ...)``).
    seeds : sequence of int
        The run's seeds, S of them.
    episodes : int
        E.
    success_key : str, optional
        The info key the env reports success in (read into the tensordicts by ``make_env``).
    solved_return : float, optional
        For a task whose env reports no success: an episode whose return reaches it is solved.
    device : torch.device or str, default 'cpu'
        Where ``policy`` lives; the environments step on the CPU.

    Returns
    -------
    returns : ndarray (S, E)
        Undiscounted episode returns.
    success : ndarray (S, E) of float (1.0 solved, 0.0 not, NaN unknown)
        Reaching arms: whether the end effector came within the task's threshold (d < 0.05 m) during
        the episode. Other tasks: whether ``info[success_key]`` was true at some step of the episode;
        else whether the return reached ``solved_return``; else NaN (nothing says what solved means).

    Notes
    -----
    All instances step together until every one has finished its episode (at most
    ``task.max_steps`` steps); one that finishes early is reset and keeps stepping, its later rewards
    ignored (the vector environment cannot step a subset). The global torch RNG is left untouched (the mean action draws
    nothing, and the call runs inside ``torch.random.fork_rng``).
    """
    num_seeds = len(seeds)
    size = num_seeds * episodes
    returns = torch.zeros(size)
    success = torch.zeros(size, dtype=torch.bool)
    alive = torch.ones(size, dtype=torch.bool)
    on_device = torch.device(device).type != "cpu"
    with torch.random.fork_rng(devices=[]), torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        td = env.reset(seed=evaluation_seeds(seeds, episodes))
        for _ in range(task.max_steps):
            observed = td.reshape(num_seeds, episodes).copy()
            if on_device:
                observed = observed.to(device)
            action = policy(observed).get("action")
            td.set("action", action.reshape(size, -1).cpu())
            stepped, td = env.step_and_maybe_reset(td)
            nxt = stepped.get("next")
            returns += torch.where(alive, nxt.get("reward").squeeze(-1), 0.0)
            if isinstance(task, TaskSpec):
                reached = observed_distance(task, nxt, goal_conditioned=goal_conditioned) < task.reward.threshold
                success |= alive & reached
            elif success_key is not None:
                success |= alive & nxt.get(success_key).reshape(size).bool()
            alive &= ~nxt.get("done").squeeze(-1)
            if not alive.any():
                break
    if isinstance(task, TaskSpec) or success_key is not None:
        solved = success.double()
    elif solved_return is not None:
        solved = (returns >= solved_return).double()
    else:
        solved = torch.full((size,), float("nan"), dtype=torch.float64)
    return returns.reshape(num_seeds, episodes).numpy(), solved.reshape(num_seeds, episodes).numpy()
