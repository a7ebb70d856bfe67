"""The ``vector`` backend: a researcher's NumPy-vectorised env (``tests/vector_pendulum.py``) against its single env.

The vector env does gymnasium's Pendulum arithmetic on arrays and seeds environment i from ``seed[i]``, so the returns
equal the ``gym`` backend's. They agree to ``RTOL``, not to the bit: NumPy may evaluate ``np.sin`` of an array on a
SIMD path that rounds otherwise than its one-element call in the single env (on this project's CPUs they are equal).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.rwg.backends import task_backends
from taskcomplexity.tasks.gym_task import GymTask

VECTOR = "vector_pendulum:VectorPendulum-v0"
ONE_SEED = "vector_pendulum:VectorPendulumOneSeed-v0"
RTOL = 1e-12


def test_a_vector_env_that_seeds_each_environment_runs_on_it_by_default():
    assert task_backends(GymTask(VECTOR)) == ("vector", "gym")
    assert task_backends(GymTask(ONE_SEED)) == ("gym",)  # one generator for every environment: its returns would depend on
    # which slot an episode ran in
    with pytest.raises(ConfigError, match=r"^backend=vector is not available for task VectorPendulumOneSeed-v0 "
                                          r"\(allowed: auto, gym\)$"):
        run_rwg(GymTask(ONE_SEED), NetworkSpec(), PriorSpec(), RWGSettings(policies=2, episodes=2), "vector")


@pytest.mark.parametrize("common", [False, True])
def test_the_vector_backend_gives_the_gym_backends_returns_in_any_chunking(common):
    task = GymTask(VECTOR)
    settings = RWGSettings(policies=6, episodes=5, seed=2, common_initial_states=common)
    ours = run_rwg(task, NetworkSpec(), PriorSpec(), settings, "vector")
    theirs = run_rwg(task, NetworkSpec(), PriorSpec(), settings, "gym")
    np.testing.assert_allclose(ours.returns, theirs.returns, rtol=RTOL)
    assert np.array_equal(ours.steps, theirs.steps) and (ours.steps == 200).all()
    chunked = RWGSettings(policies=6, episodes=5, seed=2, common_initial_states=common, chunk_policies=4, shards=2,
                          shard=1)
    assert np.array_equal(run_rwg(task, NetworkSpec(), PriorSpec(), chunked, "vector").returns, ours.returns[3:])


def test_episodes_that_end_early_are_read_until_their_end_only():
    """Under a shorter limit every episode ends at it (the env would step on and autoreset: never read)."""
    task = GymTask(VECTOR, max_steps=7)
    ours = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=3, episodes=4, seed=1), "vector")
    theirs = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=3, episodes=4, seed=1), "gym")
    assert (ours.steps == 7).all()
    np.testing.assert_allclose(ours.returns, theirs.returns, rtol=RTOL)


def test_a_vector_env_with_unseeded_noise_late_in_its_episodes_is_refused_before_any_return(tmp_path):
    from taskcomplexity.rwg.env_checks import EnvContractError, check_vector_env
    from taskcomplexity.seeding import episode_reset_seeds
    from taskcomplexity.stages.cache import Cache
    from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage

    check_vector_env(GymTask(VECTOR), 0)  # a vector env its seeds fix passes
    seed = int(episode_reset_seeds(0, np.array([0]), np.array([0]))[0])
    noisy = GymTask("vector_pendulum:VectorPendulumNoisy-v0")
    assert task_backends(noisy)[0] == "vector"
    request = RWGRequest(noisy, NetworkSpec(), PriorSpec(), RWGSettings(policies=4, episodes=2), backend="vector")
    with pytest.raises(EnvContractError, match=rf"is not reproducible on backend=vector: two replays of the episode "
                       rf"reset with seed {seed}, with the same actions, gave a different observation at step 31 "):
        run_rwg_stage(Cache(tmp_path / "cache"), request)
    assert not list((tmp_path / "cache").rglob("*.parquet"))
