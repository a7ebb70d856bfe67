"""The classic-control kernels against ``gymnasium.make(id)``, step for step, and RWG's kernel backend
against its gym backend.

Tolerance. The kernels repeat gymnasium's arithmetic operation for operation in the same IEEE types
(float64 dynamics; float32 where gymnasium computes in float32: every observation, Pendulum's and
MountainCarContinuous' action terms, MountainCarContinuous' state after its first step) and call the
same libm sin/cos, so on this platform every observation, reward and flag is bit-identical. The
tolerance allows one float32 ulp in observations (rtol 2⁻²³) and 1e-12 relative in rewards and
returns, for a NumPy build whose SIMD sin/cos differ from libm by an ulp; flags must be equal.

Acrobot is chaotic: a one-ulp change of θ₁ grows past 1e-6 in the observation after ~340 steps at the
earliest (1st percentile over 2000 episodes of random torques; median ~450). Its trajectories are
compared step for step over the first ACROBOT_HORIZON steps only, and its return distribution over
whole episodes with a two-sample Kolmogorov–Smirnov test.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
import torch
from scipy import stats

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policy
from taskcomplexity.rwg import RWGSettings, resolve_backend, run_rwg
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import decode_actions, encode_observations
from taskcomplexity.tasks.classic import KERNELS, kernel_for
from taskcomplexity.tasks.classic.kernels import observe_all, step_all
from taskcomplexity.tasks.gym_task import GymTask

pytestmark = pytest.mark.filterwarnings("ignore:.*CartPole-v0 is out of date:DeprecationWarning")

IDS = sorted(KERNELS)
OBS_RTOL = 2.0**-23  # one float32 ulp
REWARD_RTOL = 1e-12
ACROBOT_HORIZON = 200


class KernelEnv:
    """One environment of a kernel, stepped like a gymnasium env (for step-for-step comparison)."""

    def __init__(self, task: GymTask):
        self.task = task
        self.kernel = kernel_for(task.env_id, task.kwargs)
        self.params = self.kernel.params(task.kwargs)

    def reset(self, seed: int) -> np.ndarray:
        self.state, self.generators = self.kernel.start(np.array([seed]), self.task.kwargs)
        self.obs = np.zeros((1, self.task.observation_size))
        observe_all(self.kernel.code, self.state, self.obs)
        self.running = np.ones(1, dtype=bool)
        self.returns = np.zeros(1)
        self.steps = np.zeros(1, dtype=np.int64)
        return self.obs[0].copy()

    def step(self, outputs: np.ndarray):
        """(observation, return so far, terminated, truncated) after one step."""
        step_all(self.kernel.code, self.params, self.state, self.generators, outputs[None].astype(np.float64),
                 self.obs, self.running, self.returns, self.steps, self.task.max_steps)
        done = not self.running[0]
        truncated = done and self.steps[0] >= self.task.max_steps
        terminated = done and not truncated
        if done:  # the kernel skips observing a finished episode: observe it here for the comparison
            observe_all(self.kernel.code, self.state, self.obs)
        return self.obs[0].copy(), self.returns[0], terminated, truncated


def compare_episode(task: GymTask, seed: int, choose, horizon: int | None = None) -> int:
    """Run one episode on gymnasium and on the kernel with the same reset seed and actions.

    ``choose(obs) -> outputs`` gives the policy outputs (decoded into actions as the backends do).
    Returns the episode's length.
    """
    env = task.make_env()
    mine = KernelEnv(task)
    try:
        ref, _ = env.reset(seed=seed)
        obs = mine.reset(seed)
        np.testing.assert_allclose(obs, encode_observations(task.observation_space, ref[None])[0], rtol=OBS_RTOL)
        total = 0.0  # gymnasium's rewards summed as the backends sum them
        for t in range(task.max_steps):
            outputs = choose(obs)
            action = decode_actions(task.action_space, outputs[None])[0]
            ref, reward, terminated, truncated, _ = env.step(action)
            obs, my_total, my_terminated, my_truncated = mine.step(outputs)
            total += float(reward)
            if horizon is None or t < horizon:
                np.testing.assert_allclose(obs, encode_observations(task.observation_space, ref[None])[0],
                                           rtol=OBS_RTOL, atol=1e-30, err_msg=f"step {t}")
                np.testing.assert_allclose(my_total, total, rtol=REWARD_RTOL, err_msg=f"step {t}")
                assert (my_terminated, my_truncated) == (terminated, truncated), f"step {t}"
            if terminated or truncated or my_terminated or my_truncated:
                if horizon is None or t < horizon:
                    return t + 1
                break
        return t + 1
    finally:
        env.close()


def horizon_of(env_id: str) -> int | None:
    return ACROBOT_HORIZON if env_id == "Acrobot-v1" else None


@pytest.mark.parametrize("env_id", IDS)
def test_kernels_step_like_gymnasium_on_random_actions(env_id):
    task = GymTask(env_id)
    rng = np.random.default_rng(11)
    size = task.action_size
    lengths = [compare_episode(task, int(s), lambda _: rng.uniform(-1.0, 1.0, size), horizon_of(env_id))
               for s in episode_reset_seeds(2, 0, np.arange(6))]
    assert sum(lengths) > 6  # the episodes ran


@pytest.mark.parametrize("env_id", IDS)
def test_kernels_step_like_gymnasium_under_random_policies(env_id):
    task = GymTask(env_id)
    network, prior = NetworkSpec(hidden=(16,)), PriorSpec()
    batch = sample_policies(network, prior, task.observation_size, task.action_size, 5, np.arange(4))
    for n in range(4):
        policy = select_policy(batch, n)

        def choose(obs, policy=policy):
            return policy.act(torch.from_numpy(obs[None, None]))[0, 0].numpy()

        for e in range(2):
            compare_episode(task, int(episode_reset_seeds(5, n, e)), choose, horizon_of(env_id))


@pytest.mark.parametrize(("env_id", "kwargs"), [("CartPole-v1", {"sutton_barto_reward": True}),
                                                ("Pendulum-v1", {"g": 9.81}),
                                                ("MountainCar-v0", {"goal_velocity": 0.01}),
                                                ("MountainCarContinuous-v0", {"goal_velocity": 0.01})])
def test_the_constructor_arguments_a_kernel_models_step_like_gymnasium(env_id, kwargs):
    task = GymTask(env_id, kwargs=kwargs, max_steps=120)
    assert task.backends == ("kernel", "gym")
    rng = np.random.default_rng(3)
    for s in range(4):
        compare_episode(task, s, lambda _: rng.uniform(-1.0, 1.0, task.action_size))


def test_ids_and_arguments_without_a_kernel_keep_the_gym_backend():
    assert GymTask("CartPole-v1", kwargs={"render_mode": "rgb_array"}).backends == ("gym",)
    assert GymTask("LunarLander-v3").backends == ("gym",) if "LunarLander-v3" in gymnasium.registry else True
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
