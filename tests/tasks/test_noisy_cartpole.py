"""The noisy CartPole (``taskcomplexity/NoisyCartPole-v0``) and its kernel twin.

The kernel repeats the env's arithmetic and draws the env's random numbers (each episode's PCG64
stream, continued after the reset's four draws), so the comparisons below are exact: the float64
state, every reward, every flag and every return are equal bit for bit.
"""

from __future__ import annotations

import inspect

import gymnasium
import numpy as np
import pytest
import torch
import yaml
from test_classic_kernels import KernelEnv

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policy
from taskcomplexity.rwg import RWGSettings, resolve_backend, run_rwg
from taskcomplexity.rwg.backends import task_backends
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.classic import KERNELS
from taskcomplexity.tasks.classic.noisy_cartpole import NoisyCartPoleEnv
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.registration import NOISY_CARTPOLE_ID

CELLS = [(0.05, 0.0), (0.05, 0.1), (0.1, 0.03), (0.15, 0.05), (0.15, 0.1), (0.0, 0.05)]
PIC_NETWORK = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")  # the original family's


def noisy(reset_noise: float, dynamics_noise: float, **kwargs) -> GymTask:
    return GymTask(NOISY_CARTPOLE_ID, kwargs={"reset_noise": reset_noise, "dynamics_noise": dynamics_noise}, **kwargs)


def compare_exactly(task: GymTask, seed: int, choose) -> int:
    """One episode on the env and on the kernel, same reset seed and policy outputs: the float64 states,
    returns and flags are equal at every step. Returns the episode's length."""
    env = task.make_env()
    mine = KernelEnv(task)
    try:
        env.reset(seed=seed)
        obs = mine.reset(seed)
        np.testing.assert_array_equal(mine.state[0], env.unwrapped.state)
        total = 0.0
        for t in range(task.max_steps):
            outputs = choose(obs)
            _, reward, terminated, truncated, _ = env.step(decode_actions(task.action_space, outputs[None])[0])
            obs, my_total, my_terminated, my_truncated = mine.step(outputs)
            total += float(reward)
            np.testing.assert_array_equal(mine.state[0], env.unwrapped.state, err_msg=f"step {t}")
            assert (my_total, my_terminated, my_truncated) == (total, terminated, truncated), f"step {t}"
            if terminated or truncated:
                return t + 1
        raise AssertionError("the episode outlived the time limit")
    finally:
        env.close()


@pytest.mark.parametrize(("reset_noise", "dynamics_noise"), CELLS)
def test_the_kernel_steps_like_the_env_on_random_actions(reset_noise, dynamics_noise):
    task = noisy(reset_noise, dynamics_noise)
    rng = np.random.default_rng(5)
    lengths = [compare_exactly(task, int(s), lambda _: rng.uniform(-1.0, 1.0, 2))
               for s in episode_reset_seeds(4, 0, np.arange(8))]
    assert sum(lengths) > 8 * 5  # the episodes ran for several steps each


@pytest.mark.parametrize(("reset_noise", "dynamics_noise"), [(0.05, 0.1), (0.15, 0.03)])
def test_the_kernel_steps_like_the_env_under_random_policies(reset_noise, dynamics_noise):
    task = noisy(reset_noise, dynamics_noise)
    batch = sample_policies(PIC_NETWORK, PriorSpec(), 4, 2, 3, np.arange(10))
    lengths = []
    for n in range(10):
        policy = select_policy(batch, n)

        def choose(obs, policy=policy):
            return policy.act(torch.from_numpy(obs[None, None]))[0, 0].numpy()

        lengths += [compare_exactly(task, int(episode_reset_seeds(3, n, e)), choose) for e in range(3)]
    assert sum(lengths) > 30 * 5  # episodes of several steps


@pytest.mark.parametrize(("reset_noise", "dynamics_noise"), [(0.05, 0.0), (0.1, 0.05), (0.15, 0.1)])
def test_the_kernel_backend_gives_the_gym_backends_returns(reset_noise, dynamics_noise):
    task = noisy(reset_noise, dynamics_noise)
    assert resolve_backend(task, "auto") == "kernel"
    settings = RWGSettings(policies=6, episodes=5, seed=9)
    kernel = run_rwg(task, PIC_NETWORK, PriorSpec(), settings, backend="kernel")
    gym = run_rwg(task, PIC_NETWORK, PriorSpec(), settings, backend="gym")
    np.testing.assert_array_equal(kernel.returns, gym.returns)
    np.testing.assert_array_equal(kernel.steps, gym.steps)
    assert len(np.unique(kernel.returns)) > 3  # policies that differ, not 30 copies of one return


def test_the_kernels_generators_continue_where_the_envs_reset_left_its_generator():
    seeds = episode_reset_seeds(1, 0, np.arange(50))
    _, generators = KERNELS[NOISY_CARTPOLE_ID].start(seeds, {"reset_noise": 0.1, "dynamics_noise": 0.05})
    env = NoisyCartPoleEnv(reset_noise=0.1, dynamics_noise=0.05)
    for seed, words in zip(seeds, generators, strict=True):
        env.reset(seed=int(seed))
        pcg = env.np_random.bit_generator.state["state"]
        assert (int(words[0]) << 64 | int(words[1]), int(words[2]) << 64 | int(words[3])) == (pcg["state"], pcg["inc"])
    assert generators.dtype == np.uint64 and generators.shape == (50, 4)
    assert KERNELS["CartPole-v0"].start(seeds)[1].shape == (50, 0)  # the others carry no generator


def test_without_noise_it_is_cartpole_v0():
    plain, mine = gymnasium.make("CartPole-v0"), gymnasium.make(NOISY_CARTPOLE_ID)
    try:
        for seed in (0, 17, 2**31 - 1):
            np.testing.assert_array_equal(plain.reset(seed=seed)[0], mine.reset(seed=seed)[0])
            for t in range(200):
                action = (t * 7 + seed) % 3 % 2
                a, b = plain.step(action), mine.step(action)
                np.testing.assert_array_equal(a[0], b[0])
                assert a[1:4] == b[1:4]
                if a[2] or a[3]:
                    break
            # no draws in the steps: both generators are where the reset left them
            assert plain.unwrapped.np_random.bit_generator.state == mine.unwrapped.np_random.bit_generator.state
    finally:
        plain.close()
        mine.close()
    settings = RWGSettings(policies=8, episodes=6, seed=2)
    ours = run_rwg(noisy(0.05, 0.0), PIC_NETWORK, PriorSpec(), settings, backend="kernel")
    v0 = run_rwg(GymTask("CartPole-v0"), PIC_NETWORK, PriorSpec(), settings, backend="kernel")
    np.testing.assert_array_equal(ours.returns, v0.returns)
    np.testing.assert_array_equal(ours.steps, v0.steps)


def test_dynamics_noise_kicks_the_pole_uniformly_and_changes_the_returns():
    u = 0.1
    plain, mine = NoisyCartPoleEnv(), NoisyCartPoleEnv(dynamics_noise=u)
    plain.reset(seed=0)
    mine.reset(seed=0)
    rng = np.random.default_rng(1)
    kicks = []
    for _ in range(4000):  # from the same state and action, the envs differ by the kick to θ̇ alone
        state = rng.uniform(-0.1, 0.1, 4)
        plain.state, mine.state = state.copy(), state.copy()
        action = int(rng.integers(2))
        plain.step(action)
        mine.step(action)
        np.testing.assert_array_equal(mine.state[:3], plain.state[:3])
        kicks.append(mine.state[3] - plain.state[3])
    kicks = np.array(kicks)
    # U(−u, u): mean 0 with sd u/√(3·4000) ≈ 0.0009 (4 sd below), extremes within 0.5 % of ±u
    # (P(no kick in the top 0.5 %) = 0.9975⁴⁰⁰⁰ ≈ 5e-5), sd u/√3 within 3 %
    assert abs(kicks.mean()) < 4 * u / np.sqrt(3 * 4000)
    assert -u <= kicks.min() < -0.99 * u and 0.99 * u < kicks.max() <= u
    assert abs(kicks.std() / (u / np.sqrt(3)) - 1) < 0.03
    settings = RWGSettings(policies=10, episodes=10, seed=4)
    calm = run_rwg(noisy(0.05, 0.0), PIC_NETWORK, PriorSpec(), settings, backend="kernel")
    kicked = run_rwg(noisy(0.05, u), PIC_NETWORK, PriorSpec(), settings, backend="kernel")
    assert (calm.returns != kicked.returns).mean() > 0.5  # same policies and resets: the noise alone


def test_reset_noise_scales_the_initial_states():
    seeds = episode_reset_seeds(6, np.arange(40)[:, None], np.arange(50)[None, :]).ravel()
    states = {u: KERNELS[NOISY_CARTPOLE_ID].initial_states(seeds, {"reset_noise": u}) for u in (0.05, 0.1, 0.15)}
    for u, x in states.items():  # uniform in [−u, u): extremes within 1 % of ±u over 8000 draws, sd u/√3 within 3 %
        assert -u <= x.min() < -0.99 * u and 0.99 * u < x.max() < u
        assert abs(x.std() / (u / np.sqrt(3)) - 1) < 0.03
    # the same uniforms d, scaled: −u + 2u·d (to rounding, 1e-15 relative to u)
    np.testing.assert_allclose(states[0.15], 3 * states[0.05], rtol=0, atol=1e-15)
    env = NoisyCartPoleEnv(reset_noise=0.15)
    for seed, state in zip(seeds[:20], states[0.15][:20], strict=True):
        env.reset(seed=int(seed))
        np.testing.assert_array_equal(env.state, state)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"dynamics_noise": -0.1}, r"dynamics_noise must be >= 0, got -0\.1"),
    ({"reset_noise": -0.05}, r"reset_noise must be >= 0, got -0\.05"),
    ({"dynamics_noise": float("nan")}, r"dynamics_noise must be a finite number >= 0, got nan"),
    ({"reset_noise": "0.1"}, r"reset_noise must be a finite number >= 0, got '0\.1'"),
])
def test_bad_noise_is_refused_naming_the_argument(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        gymnasium.make(NOISY_CARTPOLE_ID, **kwargs)
    with pytest.raises(ConfigError, match=rf"^task\.kwargs of {NOISY_CARTPOLE_ID}: {message}$"):
        GymTask(NOISY_CARTPOLE_ID, kwargs=kwargs).validate()


def test_the_preset_the_kernel_and_the_env_share_their_defaults():
    signature = {k: p.default for k, p in inspect.signature(NoisyCartPoleEnv).parameters.items()}
    preset = yaml.safe_load((CONF_DIR / "task" / "noisy_cartpole.yaml").read_text())
    assert preset["env_id"] == NOISY_CARTPOLE_ID
    assert preset["kwargs"] == {"reset_noise": signature["reset_noise"], "dynamics_noise": signature["dynamics_noise"]}
    assert dict(KERNELS[NOISY_CARTPOLE_ID].arguments) == {k: signature[k] for k in KERNELS[NOISY_CARTPOLE_ID].arguments}
    spec = gymnasium.spec(NOISY_CARTPOLE_ID)
    assert (spec.max_episode_steps, spec.reward_threshold) == (200, gymnasium.spec("CartPole-v0").reward_threshold)
    assert task_backends(GymTask(NOISY_CARTPOLE_ID, kwargs={"render_mode": "rgb_array"})) == ("gym",)


def test_the_study_relates_adjacent_noise_levels_along_each_axis():
    study = load_study_file(CONF_DIR / "study" / "cartpole_noise.yaml")
    cells = {entry.id: (entry.selection["kwargs"]["reset_noise"], entry.selection["kwargs"]["dynamics_noise"])
             for entry in study.tasks}
    assert sorted(cells.values()) == sorted((u, d) for u in (0.05, 0.1, 0.15) for d in (0.0, 0.03, 0.05, 0.1))
    assert all(entry.selection["task"] == "noisy_cartpole" for entry in study.tasks)
    pairs = {(cells[r.easier], cells[r.harder], r.kind) for r in study.relations}
    expected = {((u, a), (u, b), "dynamics_noise") for u in (0.05, 0.1, 0.15)
                for a, b in ((0.0, 0.03), (0.03, 0.05), (0.05, 0.1))}
    expected |= {((a, d), (b, d), "reset_noise") for d in (0.0, 0.03, 0.05, 0.1) for a, b in ((0.05, 0.1), (0.1, 0.15))}
    assert pairs == expected and len(study.relations) == 17
