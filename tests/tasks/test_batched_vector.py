"""The batched vector environment against the PyBullet vector it replaces, step for step."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.rl.factories import one_env
from taskcomplexity.tasks.batched_vector import BatchedReachingVector
from taskcomplexity.tasks.spec import make_task

ENVS = 5
STEPS = 130  # more than two episodes of 50 steps: resets of finished and truncated instances are compared
# The kernel and Bullet sum the chain dynamics in another order: ~1e-7 of joint-state drift per episode
# (tests/tasks/test_batched.py); observations are smooth functions of the state.
TOL = 1e-6


def _pybullet_vector(task, goal_conditioned):
    return gymnasium.vector.SyncVectorEnv(
        [lambda: one_env(task, goal_conditioned=goal_conditioned)] * ENVS,
        autoreset_mode=gymnasium.vector.AutoresetMode.DISABLED,
    )


def _flat(observation):
    if isinstance(observation, dict):
        return np.concatenate([observation[k] for k in sorted(observation)], axis=-1)
    return observation


@pytest.mark.parametrize(("arm", "reward", "goal_conditioned"), [
    ("one_link_1m0", "dense", False),
    ("one_link_1m65", "sparse", True),
    ("two_link", "sparse", False),
    ("two_link", "dense", True),
])
def test_the_batched_vector_steps_as_the_pybullet_vector(arm, reward, goal_conditioned):
    task = make_task(arm, reward)
    reference = _pybullet_vector(task, goal_conditioned)
    batched = BatchedReachingVector(task, ENVS, goal_conditioned=goal_conditioned)
    try:
        assert batched.observation_space == reference.observation_space
        assert batched.action_space == reference.action_space
        seeds = [101 + 7 * i for i in range(ENVS)]
        obs_r, _ = reference.reset(seed=seeds)
        obs_b, _ = batched.reset(seed=seeds)
        np.testing.assert_allclose(_flat(obs_b), _flat(obs_r), atol=1e-12, rtol=0)
        rng = np.random.default_rng(3)
        ends = resets = 0
        for t in range(STEPS):
            actions = rng.uniform(-1.2, 1.2, size=(ENVS, task.arm.dof))
            obs_r, rew_r, term_r, trunc_r, _ = reference.step(actions)
            obs_b, rew_b, term_b, trunc_b, info = batched.step(actions)
            assert info == {}
            np.testing.assert_allclose(_flat(obs_b), _flat(obs_r), atol=TOL, rtol=0, err_msg=f"step {t}")
            np.testing.assert_allclose(rew_b, rew_r, atol=TOL, rtol=0, err_msg=f"step {t}")
            np.testing.assert_array_equal(term_b, term_r, err_msg=f"step {t}")
            np.testing.assert_array_equal(trunc_b, trunc_r, err_msg=f"step {t}")
            finished = term_r | trunc_r
            ends += int(finished.sum())
            if finished.any():
                resets += 1
                obs_r, _ = reference.reset(options={"reset_mask": finished.copy()})
                obs_b, _ = batched.reset(options={"reset_mask": finished.copy()})
                np.testing.assert_allclose(_flat(obs_b)[finished], _flat(obs_r)[finished], atol=1e-12, rtol=0,
                                           err_msg=f"reset after step {t}")
                np.testing.assert_allclose(_flat(obs_b), _flat(obs_r), atol=TOL, rtol=0)
        assert ends >= 2 * ENVS and resets >= 2  # the resets of finished instances were compared
    finally:
        reference.close()
        batched.close()


def test_a_seeded_reset_restarts_only_the_seeded_generators():
    task = make_task("two_link", "dense")
    a, b = BatchedReachingVector(task, 3), BatchedReachingVector(task, 3)
    first, _ = a.reset(seed=[1, 2, 3])
    again, _ = b.reset(seed=[1, 2, 3])
    np.testing.assert_array_equal(first, again)
    later, _ = a.reset(seed=[1, None, None])
    np.testing.assert_array_equal(later[0], first[0])  # restarted
    assert not np.allclose(later[1:], first[1:])  # continued their streams


def test_the_obstacle_task_is_refused():
    with pytest.raises(ConfigError, match="obstacle"):
        BatchedReachingVector(make_task("two_link_obstacle", "dense"), 2)
