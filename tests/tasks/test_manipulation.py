"""Meta-World's tasks (taskcomplexity.tasks.manipulation): every one of the 50 seeded per episode, and the unseeded
ways of making them refused by the RWG's replay check. Needs the metaworld extra (make test-manipulation)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.tasks.test_config import CONF_DIR

from taskcomplexity.errors import ConfigError
from taskcomplexity.rwg.env_checks import EnvContractError, check_env
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.registration import METAWORLD_ID

metaworld = pytest.importorskip("metaworld", reason="the metaworld extra is not installed")

STUDY = load_study_file(CONF_DIR / "study" / "metaworld.yaml")
STEPS = 40
"""Steps of each compared episode: enough for the arm to reach and push objects, short enough for 50 tasks."""


def episode(env, seed: int, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The reset observation and every step's observation and reward, under fixed actions."""
    observations, rewards = [env.reset(seed=seed)[0]], []
    for action in actions:
        observation, reward, *_ = env.step(action)
        observations.append(observation)
        rewards.append(reward)
    return np.array(observations), np.array(rewards)


def test_the_study_lists_meta_worlds_fifty_tasks_each_in_one_group():
    from metaworld.env_dict import ALL_V3_ENVIRONMENTS

    names = [t.selection["kwargs"]["task_name"] for t in STUDY.tasks]
    assert sorted(names) == sorted(n.removesuffix("-v3") for n in ALL_V3_ENVIRONMENTS)
    sizes = {g: sum(t.group == g for t in STUDY.tasks) for g in STUDY.groups.order}
    assert sizes == {"easy": 28, "medium": 11, "hard": 6, "very_hard": 5}  # Seo et al. 2022's grouping
    assert set(STUDY.reference) == set(STUDY.ids)


@pytest.mark.parametrize("name", [t.selection["kwargs"]["task_name"] for t in STUDY.tasks])
def test_every_task_gives_the_same_episode_for_the_same_seed_in_a_new_env(name):
    """Two envs (as two worker processes make them), the same reset seed and actions: the same episode, to the
    bit; another seed: another object and goal."""
    task = GymTask(METAWORLD_ID, kwargs={"task_name": name, "reward": "dense"})
    actions = np.random.default_rng(7).uniform(-1, 1, (STEPS, 4))
    one, other = task.make_env(), task.make_env()
    try:
        first = episode(one, 11, actions)
        episode(other, 12, actions)  # the second env has run another episode first
        again = episode(other, 11, actions)
        different = episode(one, 12, actions)
    finally:
        one.close()
        other.close()
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1])
    assert not np.array_equal(first[0][0, -3:], different[0][0, -3:]) or not np.array_equal(
        first[0][0, 4:7], different[0][0, 4:7])  # the goal or the object moved
    assert first[0].shape == (STEPS + 1, 39) and np.isfinite(first[1]).all()


def test_the_sparse_reward_is_success_minus_one():
    task = GymTask(METAWORLD_ID, kwargs={"task_name": "reach", "reward": "sparse"})
    env = task.make_env()
    try:
        env.reset(seed=3)
        for action in np.random.default_rng(0).uniform(-1, 1, (20, 4)):
            _, reward, _, _, info = env.step(action)
            assert reward == float(info["success"]) - 1.0
    finally:
        env.close()
    assert task.max_steps == 500


@pytest.mark.parametrize("name", ["reach", "pick-place"])
def test_the_replay_check_passes_the_seeded_task(name):
    check_env(GymTask(METAWORLD_ID, kwargs={"task_name": name}), seed=0)


def test_the_replay_check_refuses_meta_worlds_own_mt1_id():
    """Meta-World's reset ignores its seed and Meta-World/MT1 draws its goals from NumPy's global generator: the
    check that keeps its returns out of the cache."""
    with pytest.raises(EnvContractError, match="is not reproducible"):
        check_env(GymTask("Meta-World/MT1", kwargs={"env_name": "reach-v3"}, max_steps=500), seed=0)


def test_the_replay_check_refuses_a_variant_that_ignores_the_reset_seed(monkeypatch):
    """The seeding is what makes the check pass: without reseeding the env's generator, the same test fails."""
    from taskcomplexity.tasks import manipulation

    original = manipulation.MetaWorldEnv.reset

    def unseeded(self, *, seed=None, options=None):
        return original(self, seed=None, options=options)

    monkeypatch.setattr(manipulation.MetaWorldEnv, "reset", unseeded)
    with pytest.raises(EnvContractError, match="is not reproducible"):
        check_env(GymTask(METAWORLD_ID, kwargs={"task_name": "reach"}), seed=0)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"task_name": "pick-plaec"}, r"task\.kwargs\.task_name='pick-plaec' is not a Meta-World task .*closest: "
                                  r"pick-place"),
    ({"task_name": "reach", "reward": "shaped"}, r"task\.kwargs\.reward='shaped' is not allowed \(allowed: dense, "
                                                 r"sparse\)"),
])
def test_a_bad_task_name_or_reward_is_one_line(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        GymTask(METAWORLD_ID, kwargs=kwargs).validate()
