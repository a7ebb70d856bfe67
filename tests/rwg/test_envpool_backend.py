"""The ``envpool`` backend against gymnasium's own envs, for every task of ``study=furuta_benchmark`` EnvPool runs.

EnvPool draws its initial states from its own generators, so its returns are another sample of a task's return
distribution, not gymnasium's numbers. Two checks per id:

- **Distribution** (every id): the same ``POLICIES`` policies (the study's network and prior) run ``EPISODES``
  episodes on each backend; per policy, a two-sided Mann–Whitney test of its returns on the two, the policies'
  p-values combined by Fisher's method, refused below ``ALPHA``. Size and power at these sizes are a test of their
  own (:func:`test_the_equivalence_test_has_its_stated_size_and_power`): size ≤ 0.005, power ≥ 0.95 against a shift
  of 0.75 within-policy standard deviations in every policy (random signs); and a wiring error (observations in
  reversed order) is refused on Hopper (p ≈ 1e-57).
- **Step for step** where EnvPool aligns its MuJoCo tasks with gymnasium's (the planar walkers, whose observation
  and ``info["x_position"]`` give the whole state): gymnasium's env set to EnvPool's initial state follows it for
  ``ALIGNED_STEPS`` steps on the same actions. When gymnasium's MuJoCo is another version than EnvPool's build,
  the two may part at a step where gymnasium's env makes a new contact, and are not compared after it: two MuJoCo
  versions can resolve a new contact differently (Hopper-v5 on 3.3.0 and on EnvPool 1.2.5's 3.6.0 part at the
  foot's first touch, step 9, and follow each other step for step when gymnasium runs on 3.6.0 too; HalfCheetah
  and Walker2d make new contacts from step 3 and stay together).

The checks need the atlas extra (``pip install -e '.[atlas]'``) and are skipped without it.
"""

from __future__ import annotations

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import OmegaConf
from scipy import stats

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.errors import ConfigError
from taskcomplexity.rwg import RWGSettings, run_rwg

POLICIES = 16
EPISODES = 16
STEPS = 200
"""Episode limit of the checks (the tasks' own is 1000): the returns' distribution is compared on these steps."""
ALPHA = 1e-3
ALIGNED_STEPS = 20
OBS_TOLERANCE = 1e-8
"""Largest observation difference over ``ALIGNED_STEPS`` steps: the two builds of MuJoCo round differently in the
last bits, which the dynamics amplify (HalfCheetah: 1e-15 after one step, 1e-12 after ten, 1e-7 after fifty)."""
REWARD_TOLERANCE = 1e-6
"""Largest reward difference per step (measured: 7e-8; EnvPool sums the reward's terms in another order)."""
PLANAR = ("HalfCheetah-v5", "Hopper-v5", "Walker2d-v5")
"""EnvPool's MuJoCo ids whose state is (x_position, observation): gymnasium's env can be set to it."""


def _study() -> tuple[list[tuple[str, str]], str, str]:
    """(task id, preset) of the study's tasks that have a preset (MuJoCo, DM Control), its network and its prior."""
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        study = compose("config", overrides=["study=furuta_benchmark"]).study
    GlobalHydra.instance().clear()
    entries = OmegaConf.to_container(study.tasks)
    return [(e["id"], e["task"]) for e in entries if "task" in e], str(study.network), str(study.prior)


PRESETS, NETWORK, PRIOR = _study()


def fisher_p(a: np.ndarray, b: np.ndarray) -> float:
    """p of 'the rows of a and b come from the same distributions' (a, b: (policies, episodes))."""
    return float(stats.combine_pvalues(stats.mannwhitneyu(a, b, axis=1).pvalue).pvalue)


def test_the_equivalence_test_has_its_stated_size_and_power():
    rng = np.random.default_rng(0)
    same = [fisher_p(rng.standard_normal((POLICIES, EPISODES)), rng.standard_normal((POLICIES, EPISODES)))
            for _ in range(2000)]
    assert np.mean(np.array(same) < ALPHA) <= 0.005
    shifted = [fisher_p(rng.standard_normal((POLICIES, EPISODES)),
                        rng.standard_normal((POLICIES, EPISODES)) + 0.75 * rng.choice([-1, 1], (POLICIES, 1)))
               for _ in range(400)]
    assert np.mean(np.array(shifted) < ALPHA) >= 0.95


def _request(compose_config, preset: str):
    pytest.importorskip("envpool", reason="the envpool extra is not installed")
    from taskcomplexity.study.plan import rwg_request_from_config
    from taskcomplexity.tasks.envpool_ids import envpool_id

    cfg = compose_config(f"task={preset}", f"task.max_steps={STEPS}", f"network={NETWORK}", f"prior={PRIOR}")
    try:
        request = rwg_request_from_config(cfg)
    except ConfigError as err:  # the mujoco or dmc extra is missing
        pytest.skip(str(err))
    assert envpool_id(request.task) is not None and request.backend == "envpool"  # auto picks EnvPool
    return request


def _returns(request, backend: str, episodes: int = EPISODES):
    # the gym backend's pools hold 4 policies × 16 episodes (a DM Control env takes ~0.1 s to make)
    settings = RWGSettings(policies=POLICIES, episodes=episodes, seed=3, chunk_policies=4 if backend == "gym" else 0)
    return run_rwg(request.task, request.network, request.prior, settings, backend=backend)


@pytest.mark.parametrize(("task_id", "preset"), PRESETS, ids=[t for t, _ in PRESETS])
def test_envpools_returns_are_a_sample_of_gymnasiums(compose_config, task_id, preset):
    request = _request(compose_config, preset)
    ours, theirs = _returns(request, "envpool"), _returns(request, "gym")
    assert ours.returns.shape == theirs.returns.shape == (POLICIES, EPISODES)
    assert fisher_p(ours.returns, theirs.returns) > ALPHA, task_id


def test_the_distribution_check_refuses_observations_in_the_wrong_order(compose_config, monkeypatch):
    """On Hopper, where each random policy's returns vary little between its episodes (on HalfCheetah they vary more
    between episodes than between policies in 200 steps, so a policy fed permuted inputs looks like another draw of
    the same prior and the check cannot see it there)."""
    request = _request(compose_config, "hopper")
    import taskcomplexity.rwg.envpool_backend as backend

    flat = backend._flat
    monkeypatch.setattr(backend, "_flat", lambda obs, keys: flat(obs, keys)[:, ::-1])
    assert fisher_p(_returns(request, "envpool").returns, _returns(request, "gym").returns) < ALPHA


def test_envpools_episodes_depend_on_policy_and_episode_alone(compose_config):
    request = _request(compose_config, "hopper")
    whole = _returns(request, "envpool")
    settings = RWGSettings(policies=POLICIES, episodes=EPISODES, seed=3, chunk_policies=5, shard=1, shards=2)
    half = run_rwg(request.task, request.network, request.prior, settings, backend="envpool")
    assert np.array_equal(half.returns, whole.returns[POLICIES // 2:])  # other chunks, another shard
    assert np.array_equal(_returns(request, "envpool", EPISODES // 2).returns, whole.returns[:, :EPISODES // 2])
    assert not np.array_equal(whole.returns[:, 0], whole.returns[:, 1])  # each episode its own initial state


@pytest.mark.parametrize("env_id", PLANAR)
def test_envpool_follows_gymnasium_step_for_step_from_the_same_state(env_id):
    envpool = pytest.importorskip("envpool", reason="the envpool extra is not installed")
    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    import gymnasium

    pool = envpool.make(env_id, env_type="gymnasium", num_envs=1, env_seed=[5])
    obs, info = pool.reset()
    env = gymnasium.make(env_id)
    env.reset(seed=0)
    nq = env.unwrapped.model.nq
    env.unwrapped.set_state(np.concatenate([info["x_position"], obs[0, :nq - 1]]), obs[0, nq - 1:])
    rng = np.random.default_rng(0)
    same_mujoco = _envpools_mujoco(envpool) == _gymnasiums_mujoco()
    data = env.unwrapped.data
    for _ in range(ALIGNED_STEPS):
        action = rng.uniform(-1, 1, env.action_space.shape)
        touching = data.ncon
        theirs, reward, terminated, _, _ = pool.step(action[None], env_id=np.array([0]))
        ours, our_reward, our_terminated, _, _ = env.step(action)
        apart = np.max(np.abs(theirs[0] - ours)) >= OBS_TOLERANCE
        if apart and not same_mujoco and data.ncon > touching:
            break  # a new contact, which another version of MuJoCo may resolve otherwise (module docstring)
        assert not apart
        assert abs(reward[0] - our_reward) < REWARD_TOLERANCE and bool(terminated[0]) == our_terminated
        if our_terminated:
            break
    env.close()
    pool.close()


def _envpools_mujoco(envpool) -> str:
    """The version of the MuJoCo build inside EnvPool's MuJoCo tasks (``mj_versionString`` of its library)."""
    import ctypes
    from pathlib import Path

    library = ctypes.CDLL(str(Path(envpool.__file__).parent / "mujoco" / "mujoco_gym_envpool.so"))
    library.mj_versionString.restype = ctypes.c_char_p
    return library.mj_versionString().decode()


def _gymnasiums_mujoco() -> str:
    import mujoco

    return mujoco.__version__


def test_backend_envpool_is_refused_in_one_line_where_it_cannot_run(compose_config):
    from taskcomplexity.study.plan import rwg_request_from_config

    with pytest.raises(ConfigError, match=r"backend=envpool is not available for task Pendulum-v1 \(allowed: auto, "
                                          r"kernel, gym\)"):
        rwg_request_from_config(compose_config("task=gym", "task.env_id=Pendulum-v1", "backend=envpool"))


@pytest.mark.parametrize(("task_id", "preset"), PRESETS, ids=[t for t, _ in PRESETS])
def test_dict_observations_are_flattened_in_the_order_gymnasiums_env_gives(compose_config, task_id, preset):
    """A DM Control task's observation is a dict: EnvPool's keys and shapes, in its space's order, are those of the
    env through Shimmy, which gymnasium's ``FlattenObservation`` concatenates in that order."""
    import gymnasium

    from taskcomplexity.rwg.envpool_backend import environment_seeds, make_pool, observation_keys

    request = _request(compose_config, preset)
    pool = make_pool(request.task, environment_seeds(0, np.arange(1)))
    theirs = gymnasium.make(request.task.spec.id).observation_space
    if isinstance(theirs, gymnasium.spaces.Dict):
        assert observation_keys(pool) == tuple(theirs.spaces)
        assert [pool.observation_space[k].shape for k in theirs.spaces] == [s.shape for s in theirs.spaces.values()]
    else:
        assert observation_keys(pool) is None and pool.observation_space.shape == theirs.shape
    pool.close()
