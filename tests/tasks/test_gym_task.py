"""Any gymnasium id as a task: the Task seam, GymTask, and the generic RWG backend against the env itself."""

from __future__ import annotations

import sys
import textwrap

import gymnasium
import numpy as np
import pytest
import torch
from gymnasium import spaces

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policy
from taskcomplexity.rwg import ReturnChunk, RWGSettings, resolve_backend, run_rwg
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, decode_actions, encode_observations
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

CLASSIC = {  # id -> (observation size, policy outputs, registered time limit)
    "CartPole-v1": (4, 2, 500),
    "Pendulum-v1": (3, 1, 200),
    "MountainCar-v0": (2, 3, 200),
    "MountainCarContinuous-v0": (2, 1, 999),
    "Acrobot-v1": (6, 3, 500),
}


@pytest.mark.parametrize("env_id", sorted(CLASSIC))
def test_a_gym_task_reads_its_spaces_and_time_limit_from_the_registered_env(env_id):
    task = GymTask(env_id).validate()
    assert isinstance(task, Task)
    assert (task.observation_size, task.action_size, task.max_steps) == CLASSIC[env_id]
    assert task.task_id == env_id and task.backends == ("kernel", "gym")  # numba kernels first (tasks/classic/)
    assert GymTask(env_id, max_steps=CLASSIC[env_id][2]).identity() == task.identity()  # null = the env's own
    assert GymTask(env_id, max_steps=7).identity() != task.identity()


def test_the_reaching_arms_implement_the_same_seam():
    task = make_task("two_link", "sparse")
    assert isinstance(task, Task)
    assert task.env_id == "taskcomplexity/TwoLink-Sparse-v0" and task.backends[0] == "batched"
    assert (task.observation_space.shape, task.action_space.shape) == ((10,), (2,))
    env = task.make_env()
    try:
        obs, _ = env.reset(seed=0)
        assert obs.shape == (10,)
    finally:
        env.close()


def test_an_unknown_id_names_the_closest_registered_ones():
    with pytest.raises(ConfigError, match=r"task.env_id=Pendulm-v1 is not a registered gymnasium id \(closest "
                                          r"registered: Pendulum-v1"):
        GymTask("Pendulm-v1")


def test_a_module_prefixed_id_imports_the_researchers_package(tmp_path, monkeypatch):
    package = tmp_path / "my_lab_envs"
    package.mkdir()
    (package / "__init__.py").write_text(textwrap.dedent("""
        import gymnasium
        import numpy as np
        from gymnasium import spaces

        class Drift(gymnasium.Env):
            observation_space = spaces.Box(-10.0, 10.0, (1,), dtype=np.float64)
            action_space = spaces.Box(-0.5, 0.5, (1,), dtype=np.float64)

            def reset(self, *, seed=None, options=None):
                super().reset(seed=seed)
                self.x = self.np_random.uniform(-1, 1, 1)
                return self.x.copy(), {}

            def step(self, action):
                self.x = self.x + action
                return self.x.copy(), -float(abs(self.x[0])), bool(abs(self.x[0]) < 0.05), False, {}

        gymnasium.register("MyLabDrift-v0", entry_point=Drift, max_episode_steps=20)
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    task = GymTask("my_lab_envs:MyLabDrift-v0").validate()
    assert (task.task_id, task.max_steps, task.observation_size, task.action_size) == ("MyLabDrift-v0", 20, 1, 1)
    chunk = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=4, episodes=3), backend="auto")
    assert chunk.returns.shape == (4, 3) and np.all(chunk.returns <= 0) and np.all(chunk.steps <= 20)
    sys.modules.pop("my_lab_envs", None)


def test_missing_module_ids_without_a_time_limit_and_unsupported_spaces_are_refused():
    with pytest.raises(ConfigError, match="cannot import module 'no_such_lab_module'"):
        GymTask("no_such_lab_module:Env-v0")

    class BinaryObservation(gymnasium.Env):
        observation_space = spaces.MultiBinary(3)
        action_space = spaces.Discrete(2)

        def reset(self, *, seed=None, options=None):
            return np.zeros(3, dtype=np.int8), {}

        def step(self, action):
            return np.zeros(3, dtype=np.int8), 0.0, True, False, {}

    gymnasium.register("TestBinaryObservation-v0", entry_point=BinaryObservation)
    try:
        with pytest.raises(ConfigError, match="task.max_steps must be set for task.env_id=TestBinaryObservation-v0"):
            GymTask("TestBinaryObservation-v0")
        with pytest.raises(ConfigError, match=r"the observation space MultiBinary\(3\) is not supported \(allowed: "
                                              r"Box, Discrete\)"):
            GymTask("TestBinaryObservation-v0", max_steps=5).validate()
    finally:
        del gymnasium.registry["TestBinaryObservation-v0"]


def test_actions_fill_the_box_bounds_and_discrete_actions_are_the_argmax():
    box = spaces.Box(np.array([-2.0, 0.0], dtype=np.float32), np.array([2.0, 1.0], dtype=np.float32))
    actions = decode_actions(box, np.array([[-1.0, 1.0], [0.0, 0.0]]))
    np.testing.assert_allclose(actions, [[-2.0, 1.0], [0.0, 0.5]])
    assert actions.dtype == np.float32
    discrete = spaces.Discrete(3, start=-1)
    np.testing.assert_array_equal(decode_actions(discrete, np.array([[0.1, 0.9, -1.0], [0.5, 0.0, 0.6]])), [0, 1])
    np.testing.assert_array_equal(encode_observations(spaces.Discrete(3), np.array([2, 0])), [[0, 0, 1], [1, 0, 0]])


def test_backends_a_task_lacks_are_refused():
    with pytest.raises(ConfigError, match=r"backend=batched is not available for task Pendulum-v1 \(allowed: auto, "
                                          r"kernel, gym\)"):
        resolve_backend(GymTask("Pendulum-v1"), "batched")
    assert resolve_backend(make_task("two_link"), "auto") == "batched"


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


class DictObservations(gymnasium.Env):
    """Observations as DM Control's reach gymnasium through Shimmy: a Dict of Boxes (and here a Discrete)."""

    observation_space = spaces.Dict({"position": spaces.Box(-1.0, 1.0, (2,)), "phase": spaces.Discrete(3),
                                     "velocity": spaces.Box(-5.0, 5.0, (1,))})
    action_space = spaces.Box(-1.0, 1.0, (1,))

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), float(action[0]), False, False, {}


def test_a_dict_observation_is_flattened_into_one_box_and_runs():
    gymnasium.register("DictObservations-v0", entry_point=DictObservations, max_episode_steps=5)
    try:
        task = GymTask("DictObservations-v0").validate()
        assert isinstance(task.observation_space, spaces.Box) and task.observation_size == 2 + 3 + 1  # one-hot phase
        result = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=4, episodes=2, workers=1),
                         backend="gym")
        assert result.returns.shape == (4, 2) and (result.steps == 5).all()
    finally:
        gymnasium.registry.pop("DictObservations-v0")


def test_a_task_pickles_without_its_spec_and_finds_it_again_but_keeps_its_spaces():
    import pickle

    task = GymTask("Pendulum-v1")
    assert task.observation_size == 3 and "spec" in task.__dict__  # both cached
    copy = pickle.loads(pickle.dumps(task))
    assert "spec" not in copy.__dict__ and copy == task and copy.spec.id == "Pendulum-v1"
    assert "_spaces" in copy.__dict__ and copy.observation_space == task.observation_space  # no env made to read them


def test_a_dm_control_id_needs_the_dmc_extra_or_runs_flattened_with_it():
    try:
        import shimmy  # noqa: F401
    except ImportError:
        with pytest.raises(ConfigError, match=r"task\.env_id=shimmy:dm_control/reacher-easy-v0 needs shimmy, which is "
                                              r"not installed: pip install -e '\.\[dmc\]'"):
            GymTask("shimmy:dm_control/reacher-easy-v0", max_steps=1000)
        return
    task = GymTask("shimmy:dm_control/reacher-easy-v0", max_steps=1000).validate()
    assert isinstance(task.observation_space, spaces.Box) and task.observation_size == 6 and task.action_size == 2


def test_mujocos_warnings_go_to_the_log_once_not_to_standard_error(capfd, caplog, tmp_path, monkeypatch):
    pytest.importorskip("shimmy", reason="the dmc extra is not installed")
    monkeypatch.chdir(tmp_path)  # MuJoCo's default handler would write MUJOCO_LOG.TXT here
    caplog.set_level("DEBUG", logger="taskcomplexity.tasks.gym_task")
    task = GymTask("shimmy:dm_control/cheetah-run-v0", max_steps=1000)
    for _ in range(3):
        task.make_env().reset(seed=0)
    assert "settotalmass" not in capfd.readouterr().err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert sum("settotalmass" in r.getMessage() for r in caplog.records) <= 1


def test_rwg_workers_is_refused_below_zero():
    with pytest.raises(ConfigError, match=r"rwg.workers must be an integer >= 0 \(0 = one per core\), got -1"):
        RWGSettings(workers=-1).validate()


def test_a_mujoco_id_needs_the_mujoco_extra_or_runs_with_it():
    try:
        import mujoco  # noqa: F401
    except ImportError:
        with pytest.raises(ConfigError, match=r"task\.env_id=Ant-v5 needs MuJoCo, which is not installed: "
                                              r"pip install -e '\.\[mujoco\]'"):
            GymTask("Ant-v5")
        return
    task = GymTask("Ant-v5").validate()
    assert task.action_size == 8 and task.max_steps == 1000


def test_an_edit_to_the_envs_source_makes_it_a_new_task(tmp_path, monkeypatch):
    package = tmp_path / "edited_lab"
    package.mkdir()
    source = textwrap.dedent("""
        import gymnasium
        import numpy as np
        from gymnasium import spaces

        class Still(gymnasium.Env):
            observation_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float64)
            action_space = spaces.Discrete(2)

            def reset(self, *, seed=None, options=None):
                return np.zeros(1), {}

            def step(self, action):
                return np.zeros(1), REWARD, False, False, {}

        REWARD = 1.0
        if "EditedStill-v0" not in gymnasium.registry:
            gymnasium.register("EditedStill-v0", entry_point="edited_lab:Still", max_episode_steps=3)
    """)
    (package / "__init__.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    before = GymTask("edited_lab:EditedStill-v0").identity()
    (package / "__init__.py").write_text(source.replace("REWARD = 1.0", "REWARD = 2.0"))
    after = GymTask("edited_lab:EditedStill-v0").identity()
    assert before["source"] and before["source"] != after["source"]
    assert {k: v for k, v in before.items() if k != "source"} == {k: v for k, v in after.items() if k != "source"}
    del gymnasium.registry["EditedStill-v0"]
    sys.modules.pop("edited_lab", None)


def slow_first_failing_second(task, network, prior, settings, start, stop):
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
        workers.run_on_workers(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(),
                               [(0, 1), (1, 2), (2, 3), (3, 4)], 2, done.__setitem__)
    assert (0, 1) in done and (1, 2) not in done  # chunk 0 was running when chunk 1 failed: it is kept
