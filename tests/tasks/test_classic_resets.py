"""Initial states of the classic-control kernels: the draws of ``env.reset(seed=s)``, computed for many seeds at once."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.seeding import np_random

from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.classic import KERNELS
from taskcomplexity.tasks.classic.resets import seed_uniforms
from taskcomplexity.tasks.gym_task import GymTask

pytestmark = pytest.mark.filterwarnings("ignore:.*CartPole-v0 is out of date:DeprecationWarning")


def test_seed_uniforms_are_the_first_draws_of_gymnasiums_generator():
    rng = np.random.default_rng(0)
    seeds = np.concatenate([[0, 1, 2**31 - 1, 2**32 - 1], rng.integers(0, 2**32, 2000)]).astype(np.int64)
    mine = seed_uniforms(seeds, 5)
    reference = np.stack([np_random(int(s))[0].random(5) for s in seeds])
    np.testing.assert_array_equal(mine, reference)  # bit for bit: the same integer arithmetic


@pytest.mark.parametrize("env_id", sorted(KERNELS))
def test_initial_states_are_the_states_reset_draws(env_id):
    task = GymTask(env_id)
    seeds = episode_reset_seeds(3, np.arange(4)[:, None], np.arange(10)[None, :])
    states = KERNELS[env_id].initial_states(seeds)
    assert states.shape == (4, 10, KERNELS[env_id].state_size)
    env = task.make_env()
    try:
        for n in range(4):
            for e in range(10):
                env.reset(seed=int(seeds[n, e]))
                reference = np.asarray(env.unwrapped.state, dtype=np.float64)
                np.testing.assert_array_equal(states[n, e, : reference.size], reference)
    finally:
        env.close()


def test_reset_seeds_outside_one_word_are_refused():
    with pytest.raises(ValueError, match=r"reset seeds must be in \[0, 2\*\*32\)"):
        KERNELS["Pendulum-v1"].initial_states(np.array([2**32]))
