"""RWG's generic backend (``taskcomplexity.rwg.gym_backend``) against the env itself, stepped by hand, and its worker
processes (``taskcomplexity.rwg.workers``) against one process."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch

import preloaded
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policy
from taskcomplexity.rwg import ReturnChunk, RWGSettings, run_rwg
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import decode_actions, encode_observations
from taskcomplexity.tasks.gym_task import GymTask


def reference_return(task: GymTask, network, prior, seed: int, policy: int, episode: int) -> tuple[float, int]:
    """One episode stepped by hand on ``gymnasium.make``: the generic backend must give exactly this."""
    one = select_policy(sample_policies(network, prior, task.observation_size, task.action_size, seed,
                                        np.array([policy])), 0)
    env = gymnasium.make(task.env_id)
    obs, _ = env.reset(seed=int(episode_reset_seeds(seed, policy, episode)))
    total, steps = 0.0, 0
    while True:
        x = torch.from_numpy(encode_observations(task.observation_space, np.asarray(obs)[None]))
        action = decode_actions(task.action_space, one.act(x.view(1, 1, -1))[0].numpy())[0]
        obs, reward, terminated, truncated, _ = env.step(action)
        total += float(reward)
        steps += 1
        if terminated or truncated:
            env.close()
            return total, steps


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0"])
def test_the_generic_backend_matches_the_env_stepped_by_hand_in_any_chunking(env_id):
    task = GymTask(env_id)
    network, prior = NetworkSpec(), PriorSpec()
    settings = RWGSettings(policies=6, episodes=3, seed=4)
    whole = run_rwg(task, network, prior, settings, backend="gym")
    split = run_rwg(task, network, prior, RWGSettings(policies=6, episodes=3, seed=4, chunk_policies=4), backend="gym")
    np.testing.assert_array_equal(whole.returns, split.returns)
    np.testing.assert_array_equal(whole.steps, split.steps)
    for n, e in [(0, 0), (5, 2), (3, 1)]:
        expected, steps = reference_return(task, network, prior, 4, n, e)
        assert whole.returns[n, e] == expected and whole.steps[n, e] == steps
    if env_id == "CartPole-v1":  # +1 per step: the return counts the steps
        np.testing.assert_array_equal(whole.returns, whole.steps)


def middle(chunk: ReturnChunk) -> ReturnChunk:
    """Policies 3, 4, 5 of a chunk that starts at policy 0."""
    return ReturnChunk(chunk.policy[3:6], chunk.returns[3:6], chunk.steps[3:6], chunk.success[3:6])


@pytest.mark.parametrize("workers", [2, 3])
def test_worker_processes_give_the_returns_of_one_process(workers):
    task, network, prior = GymTask("Pendulum-v1"), NetworkSpec(), PriorSpec()
    one = run_rwg(task, network, prior, RWGSettings(policies=10, episodes=3, seed=2, workers=1), backend="gym")
    done = {}
    pool = run_rwg(task, network, prior, RWGSettings(policies=10, episodes=3, seed=2, chunk_policies=3,
                                                     workers=workers),
                   backend="gym", completed={(3, 6): middle(one)}, on_chunk=done.__setitem__)
    np.testing.assert_array_equal(one.returns, pool.returns)
    np.testing.assert_array_equal(one.steps, pool.steps)
    assert sorted(done) == [(0, 3), (6, 9), (9, 10)]  # each chunk computed once, the one given not again


def test_rwg_workers_is_refused_below_zero():
    with pytest.raises(ConfigError, match=r"rwg.workers must be an integer >= 0 \(0 = one per core\), got -1"):
        RWGSettings(workers=-1).validate()


def slow_first_failing_second(task, network, prior, settings, backend, start, stop):
    """A worker's chunk (in place of rwg.workers._chunk): chunk 0 takes a second, chunk 1 fails at once."""
    import time

    if start == 1:
        raise ValueError("boom")
    if start == 0:
        time.sleep(1.0)
    return ReturnChunk(np.arange(start, stop), np.zeros((stop - start, 2)), np.ones((stop - start, 2), dtype=np.int64),
                       np.zeros((stop - start, 2), dtype=bool))


def test_a_failing_chunk_lets_the_running_ones_finish_and_keeps_them(monkeypatch):
    from taskcomplexity.rwg import workers

    monkeypatch.setattr(workers, "_chunk", slow_first_failing_second)  # the forked workers inherit it
    done = {}
    with pytest.raises(ValueError, match="boom"):
        workers.run_on_workers(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(), "gym",
                               [(0, 1), (1, 2), (2, 3), (3, 4)], 2, done.__setitem__)
    assert (0, 1) in done and (1, 2) not in done  # chunk 0 was running when chunk 1 failed: it is kept



SCRIPT = '''
import multiprocessing

import gymnasium
import numpy as np
import torchrl  # noqa: F401  (importing it sets multiprocessing's global start method to spawn)

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.gym_task import GymTask

assert multiprocessing.get_start_method() == "spawn"


class Drift(gymnasium.Env):
    observation_space = gymnasium.spaces.Box(-10.0, 10.0, (1,), np.float64)
    action_space = gymnasium.spaces.Box(-1.0, 1.0, (1,), np.float64)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(-1.0, 1.0, 1)
        return self.x.copy(), {}

    def step(self, action):
        self.x = self.x + 0.1 * np.asarray(action, dtype=np.float64).reshape(1)
        return self.x.copy(), float(-abs(self.x[0])), False, False, {}


gymnasium.register("ScriptDrift-v0", entry_point=Drift, max_episode_steps=8)
returns = [run_rwg(GymTask("ScriptDrift-v0"), NetworkSpec(), PriorSpec(),
                   RWGSettings(policies=4, episodes=2, chunk_policies=1, workers=workers), backend="gym").returns
           for workers in (1, 2)]
np.testing.assert_array_equal(*returns)
print("the same returns on 2 workers")
'''


def test_workers_start_the_platforms_way_after_torchrl_set_spawn_so_the_scripts_env_is_there():
    """An env registered by the calling script (here a ``-c`` program, which a spawned worker cannot import again)
    reaches the workers after TorchRL's import set multiprocessing's global start method to ``spawn``: they start
    the platform's way (fork on Linux), as a run that has not imported TorchRL does."""
    root = Path(__file__).resolve().parents[2]
    environment = {**os.environ, "PYTHONPATH": str(root / "src")}
    done = preloaded.run([sys.executable, "-c", SCRIPT], cwd=root, env=environment, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "the same returns on 2 workers"
