"""Hindsight Experience Replay with TorchRL's :class:`~torchrl.data.HERReplayBuffer`.

torchrl 0.14 ships ``HERReplayBuffer``: a ``TensorDictReplayBuffer`` that, for a fraction
``her_ratio`` of every sampled batch, replaces the desired goal with an achieved goal drawn from the
same episode and re-scores the transition with a user ``reward_fn``. We use it as is, with:

- ``achieved_goal_key = ("next", "achieved_goal")``: a relabelled goal is where the end effector was
  *after* a step, so under the ``future`` strategy (goal from step t' ∈ [t, end of episode], uniform)
  the transition's own outcome is a possible goal, as in Andrychowicz et al. (2017);
- ``reward_fn`` = :func:`relabel`, the task's own rules for the new goal: the reward of
  :func:`taskcomplexity.tasks.goal_env.compute_reward` for the new goal and the stored action (the
  action term −Σ aᵢ² of a dense task) and the termination ``‖a − g‖ < threshold``, which it also writes into
  ``("next", "terminated")`` and ``("next", "done")`` of the relabelled rows (a transition that reaches
  its relabelled goal ends the episode, so its target does not bootstrap).

Which rows are relabelled: ``HERReplayBuffer`` relabels the first ``floor(n·her_ratio)`` rows of a
sampled batch of n (rows are i.i.d. uniform draws from the storage, so this is a uniformly random
subset). The trainer samples several minibatches at once and shuffles before splitting them, so each
minibatch holds a hypergeometric number of relabelled rows with mean ``her_ratio × batch_size``.
"""

from __future__ import annotations

from collections.abc import Callable

import torch
from tensordict import TensorDictBase
from torchrl.data import HERReplayBuffer, LazyTensorStorage

from taskcomplexity.tasks.goal_env import compute_reward, goal_reached
from taskcomplexity.tasks.spec import TaskSpec

GOAL_KEY = "desired_goal"
ACHIEVED_GOAL_KEY = ("next", "achieved_goal")


def relabel_fn(task: TaskSpec) -> Callable[[TensorDictBase], torch.Tensor]:
    """The ``reward_fn`` of :class:`HERReplayBuffer` for ``task`` (see :func:`relabel`)."""

    def _relabel(td: TensorDictBase) -> torch.Tensor:
        return relabel(task, td)

    return _relabel


def relabel(task: TaskSpec, td: TensorDictBase) -> torch.Tensor:
    """Re-score transitions whose ``desired_goal`` was replaced; returns the reward, shape (n, 1).

    Also overwrites ``("next", "terminated")`` with ‖a − g‖ < threshold and ``("next", "done")`` with
    terminated | truncated, in place.

    Parameters
    ----------
    td : TensorDict (n,)
        Needs ``desired_goal`` (the new goal), ``("next", "achieved_goal")``, ``action`` and
        ``("next", "truncated")``.
    """
    achieved = td.get(ACHIEVED_GOAL_KEY)
    goal = td.get(GOAL_KEY)
    reward = compute_reward(task, achieved, goal, td.get("action"))
    terminated = goal_reached(task, achieved, goal).unsqueeze(-1)
    td.set_(("next", "terminated"), terminated)
    td.set_(("next", "done"), terminated | td.get(("next", "truncated")))
    return reward.unsqueeze(-1).to(td.get(("next", "reward")).dtype)


def make_her_replay_buffer(task: TaskSpec, capacity: int, *, her_ratio: float, strategy: str,
                           storage: LazyTensorStorage | None = None) -> HERReplayBuffer:
    """One seed's HER replay buffer on a :class:`~torchrl.data.LazyTensorStorage` of ``capacity`` transitions.

    Parameters
    ----------
    task : TaskSpec
        Supplies the reward rules of :func:`relabel`.
    capacity : int
        Transitions.
    her_ratio : float
        Fraction of every sampled batch that is relabelled, in [0, 1].
    strategy : {'future', 'final', 'episode', 'random'}
    storage : LazyTensorStorage, optional
        Where the transitions are stored (default: a ``LazyTensorStorage`` of ``capacity`` on the CPU).
    """
    return HERReplayBuffer(
        relabel_fn(task),
        her_ratio=her_ratio,
        strategy=strategy,
        goal_key=GOAL_KEY,
        achieved_goal_key=ACHIEVED_GOAL_KEY,
        end_key=("next", "done"),
        storage=LazyTensorStorage(capacity) if storage is None else storage,
    )
