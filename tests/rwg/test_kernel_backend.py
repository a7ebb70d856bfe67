"""RWG's kernel backend (``taskcomplexity.rwg.kernel_backend``) against its gym backend: the same returns for the same
policies and episodes, in any chunking, with one BLAS thread.

Tolerance: the classic-control kernels repeat gymnasium's arithmetic bit for bit on this platform
(``tests/tasks/test_classic_kernels.py`` states why); returns agree to 1e-12 relative, for a NumPy build whose SIMD
sin/cos differ from libm by an ulp, and episode lengths exactly. Acrobot is chaotic: its returns are compared as
distributions over whole episodes, with a two-sample Kolmogorov–Smirnov test.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from scipy import stats

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, resolve_backend, run_rwg
from taskcomplexity.rwg.backends import task_backends
from taskcomplexity.tasks.classic import KERNELS
from taskcomplexity.tasks.gym_task import GymTask

pytestmark = pytest.mark.filterwarnings("ignore:.*CartPole-v0 is out of date:DeprecationWarning")

IDS = sorted(KERNELS)
REWARD_RTOL = 1e-12


def test_ids_and_arguments_without_a_kernel_keep_the_gym_backend():
    assert task_backends(GymTask("CartPole-v1", kwargs={"render_mode": "rgb_array"})) == ("gym",)
    assert task_backends(GymTask("LunarLander-v3")) == ("gym",) if "LunarLander-v3" in gymnasium.registry else True
    assert resolve_backend(GymTask("Acrobot-v1"), "auto") == "kernel"


@pytest.mark.parametrize("env_id", IDS)
def test_the_kernel_backend_gives_the_gym_backends_returns(env_id):
    task = GymTask(env_id, max_steps=None if env_id != "MountainCarContinuous-v0" else 300)
    network, prior = NetworkSpec(), PriorSpec()
    settings = RWGSettings(policies=5, episodes=4, seed=7)
    kernel = run_rwg(task, network, prior, settings, backend="kernel")
    gym = run_rwg(task, network, prior, settings, backend="gym")
    np.testing.assert_array_equal(kernel.policy, gym.policy)
    if env_id == "Acrobot-v1":  # chaotic: equal distributions over whole episodes (see the module docstring)
        assert stats.ks_2samp(kernel.returns.ravel(), gym.returns.ravel()).pvalue > 0.01
    else:
        np.testing.assert_allclose(kernel.returns, gym.returns, rtol=REWARD_RTOL)
        np.testing.assert_array_equal(kernel.steps, gym.steps)


def test_kernel_returns_do_not_depend_on_chunking_and_truncate_at_the_tasks_limit():
    task = GymTask("CartPole-v0", max_steps=30)
    network, prior = NetworkSpec(hidden=(8,)), PriorSpec(kind="uniform")
    whole = run_rwg(task, network, prior, RWGSettings(policies=9, episodes=5, seed=1), backend="kernel")
    split = run_rwg(task, network, prior, RWGSettings(policies=9, episodes=5, seed=1, chunk_policies=2),
                    backend="kernel")
    np.testing.assert_array_equal(whole.returns, split.returns)
    assert whole.steps.max() <= 30 and not whole.success.any()


@pytest.mark.parametrize("env_id", ["CartPole-v0", "Pendulum-v1", "MountainCarContinuous-v0"])
def test_the_original_policy_family_gets_the_same_weights_and_returns_on_both_backends(env_id):
    task = GymTask(env_id, max_steps=60)
    network = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear", input_bias=True)
    prior = PriorSpec(kind="xavier_uniform", gain=5 / 3)
    settings = RWGSettings(policies=4, episodes=3, seed=2)
    kernel = run_rwg(task, network, prior, settings, backend="kernel")
    gym = run_rwg(task, network, prior, settings, backend="gym")
    np.testing.assert_allclose(kernel.returns, gym.returns, rtol=REWARD_RTOL)
    np.testing.assert_array_equal(kernel.steps, gym.steps)


def test_compaction_packs_running_episodes_first_and_drops_finished_policies():
    from taskcomplexity.rwg.kernel_backend import _compaction

    running = np.array([[False, True, False, True], [False, False, False, False], [True, False, False, False]])
    rows, slots = _compaction(running)
    np.testing.assert_array_equal(rows, [0, 2])
    np.testing.assert_array_equal(slots, [[1, 3], [8, 9]])  # row 2 padded with a finished slot


def test_rwg_runs_the_forward_pass_with_one_blas_thread_and_the_same_returns():
    # The forward pass runs its own worker per core; BLAS threads inside them only spin. RWG limits BLAS to one
    # thread while it runs (and restores the limit after), and the products, so the returns, are the same.
    from threadpoolctl import threadpool_info, threadpool_limits

    from taskcomplexity.rwg import simulate_chunk

    task = GymTask("Pendulum-v1")
    network = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")
    settings = RWGSettings(policies=8, episodes=256, seed=3)
    blas = [p for p in threadpool_info() if p["user_api"] == "blas"]
    if not blas:
        pytest.skip("NumPy reports no BLAS library to limit")
    seen = []
    limited = run_rwg(task, network, PriorSpec(), settings, backend="kernel",
                      on_chunk=lambda key, chunk: seen.append({p["num_threads"] for p in threadpool_info()
                                                               if p["user_api"] == "blas"}))
    assert seen and all(threads == {1} for threads in seen)
    assert [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] == [p["num_threads"] for p in blas]
    with threadpool_limits(limits=2, user_api="blas"):
        threaded = simulate_chunk(task, network, PriorSpec(), settings, 0, settings.policies, backend="kernel")
    np.testing.assert_array_equal(limited.returns, threaded.returns)

