"""The goal-conditioned view splits the task observation losslessly and re-scores goals like the task."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
import torch

from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks.goal_env import (
    GoalReachingEnv,
    compute_reward,
    goal_gym_ids,
    goal_reached,
    join_observation,
    register_goal_tasks,
    split_observation,
)
from taskcomplexity.tasks.pybullet_env import ReachingEnv
from taskcomplexity.tasks.spec import make_task, preset_tasks

GOAL_TASKS = [t for t in preset_tasks() if make_task(*t).arm.obstacle is None]
STEPS = 120  # a few episodes of random actions per task (episodes last at most 50 steps)


def _random_transitions(arm: str, reward: str, seed: int = 0):
    """(task observation after the step, action, reward, terminated) along random-action episodes."""
    env = ReachingEnv(arm=arm, reward=reward)
    rng = np.random.default_rng(seed)
    try:
        env.reset(seed=seed)
        rows = []
        for t in range(STEPS):
            action = rng.uniform(-1, 1, env.action_space.shape)
            obs, r, terminated, _, _ = env.step(action)
            rows.append((obs, action, r, terminated))
            if terminated or t % 50 == 49:
                env.reset()
        return env.task, rows
    finally:
        env.close()


@pytest.mark.parametrize(("arm", "reward"), GOAL_TASKS)
def test_join_inverts_split_to_within_a_few_ulp(arm, reward):
    task, rows = _random_transitions(arm, reward)
    observations = np.stack([obs for obs, *_ in rows])
    parts = split_observation(task, observations)
    rebuilt = join_observation(task, parts["observation"], parts["desired_goal"])
    # Every column is copied or recomputed with the same float64 operation, except the 1-link target
    # angle, recovered by atan2: equal to within a few ulp of 2π (1e-12 rad is ~1000 ulp).
    np.testing.assert_allclose(rebuilt, observations, rtol=0, atol=1e-12)
    # the same on torch tensors (the networks' path), in float64
    rebuilt_t = join_observation(task, torch.as_tensor(parts["observation"]), torch.as_tensor(parts["desired_goal"]))
    np.testing.assert_allclose(rebuilt_t.numpy(), observations, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("arm", "reward"), GOAL_TASKS)
def test_compute_reward_reproduces_the_task_reward_and_termination(arm, reward):
    task, rows = _random_transitions(arm, reward, seed=1)
    observations = np.stack([obs for obs, *_ in rows])
    actions = np.stack([a for _, a, *_ in rows])
    rewards = np.array([r for *_, r, _ in rows])
    terminated = np.array([t for *_, t in rows])
    parts = split_observation(task, observations)
    goal_reward = compute_reward(task, parts["achieved_goal"], parts["desired_goal"])
    if reward == "sparse":
        np.testing.assert_array_equal(goal_reward, rewards)  # the whole reward, exactly
    else:
        # dense: the goal term plus the action term −Σa² (not a function of the goals)
        np.testing.assert_allclose(goal_reward - (actions**2).sum(-1), rewards, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(goal_reached(task, parts["achieved_goal"], parts["desired_goal"]), terminated)


def test_sparse_compute_reward_is_vectorised_and_uses_the_threshold():
    task = make_task("two_link", "sparse")
    achieved = np.zeros((3, 4, 2))
    desired = np.zeros((3, 4, 2))
    desired[..., 0] = [0.0, 0.049, 0.05, 1.0]  # inside, inside, on the threshold (outside), far
    expected = np.broadcast_to([0.0, 0.0, -1.0, -1.0], (3, 4))
    np.testing.assert_array_equal(compute_reward(task, achieved, desired), expected)


@pytest.mark.parametrize(("arm", "reward"), GOAL_TASKS)
def test_registered_goal_env_observes_a_dict_inside_its_space(arm, reward):
    register_goal_tasks()
    env = gymnasium.make(goal_gym_ids()[(arm, reward)])
    try:
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        assert set(obs) == {"observation", "achieved_goal", "desired_goal"}
        action = np.full(env.action_space.shape, 0.5)
        obs, r, *_ = env.step(action)
        assert env.observation_space.contains(obs)
        assert env.unwrapped.task == make_task(arm, reward)
        goal_reward = env.get_wrapper_attr("compute_reward")(obs["achieved_goal"], obs["desired_goal"])
        action_term = 0.0 if reward == "sparse" else float((action**2).sum())
        assert goal_reward - action_term == pytest.approx(r, abs=1e-12)
        assert env.spec.max_episode_steps == 50
    finally:
        env.close()


def test_goal_view_of_the_obstacle_task_is_refused_naming_the_task():
    env = ReachingEnv(arm="two_link_obstacle", reward="dense")
    try:
        with pytest.raises(ConfigError, match=r"task two_link_obstacle-dense has no goal-conditioned view"):
            GoalReachingEnv(env)
    finally:
        env.close()
