"""The classic-control kernels against ``gymnasium.make(id)``, step for step (RWG's kernel backend against its gym
backend: ``tests/rwg/test_kernel_backend.py``).

Tolerance. The kernels repeat gymnasium's arithmetic operation for operation in the same IEEE types
(float64 dynamics; float32 where gymnasium computes in float32: every observation, Pendulum's and
MountainCarContinuous' action terms, MountainCarContinuous' state after its first step) and call the
same libm sin/cos, so on this platform every observation, reward and flag is bit-identical. The
tolerance allows one float32 ulp in observations (rtol 2⁻²³) and 1e-12 relative in rewards and
returns, for a NumPy build whose SIMD sin/cos differ from libm by an ulp; flags must be equal.

Acrobot is chaotic: a one-ulp change of θ₁ grows past 1e-6 in the observation after ~340 steps at the
earliest (1st percentile over 2000 episodes of random torques; median ~450). Its trajectories are
compared step for step over the first ACROBOT_HORIZON steps only (its return distribution over whole episodes,
with a two-sample Kolmogorov–Smirnov test, in ``tests/rwg/test_kernel_backend.py``).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policy
from taskcomplexity.rwg.backends import task_backends
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
    assert task_backends(task) == ("kernel", "gym")
    rng = np.random.default_rng(3)
    for s in range(4):
        compare_episode(task, s, lambda _: rng.uniform(-1.0, 1.0, task.action_size))
