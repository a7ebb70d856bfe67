"""Any gymnasium id as a task: the Task seam and GymTask (RWG's generic backend and its worker processes against the
env itself: ``tests/rwg/test_gym_backend.py``)."""

from __future__ import annotations

import sys
import textwrap

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, resolve_backend, run_rwg
from taskcomplexity.rwg.backends import task_backends
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
    assert task.task_id == env_id and task_backends(task) == ("kernel", "gym")  # numba kernels first (tasks/classic/)
    assert GymTask(env_id, max_steps=CLASSIC[env_id][2]).identity() == task.identity()  # null = the env's own
    assert GymTask(env_id, max_steps=7).identity() != task.identity()


def test_the_reaching_arms_implement_the_same_seam():
    task = make_task("two_link", "sparse")
    assert isinstance(task, Task)
    assert task.env_id == "taskcomplexity/TwoLink-Sparse-v0" and task_backends(task)[0] == "batched"
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


def test_the_mujoco_version_that_steps_an_env_is_part_of_its_identity(monkeypatch):
    """Two MuJoCo versions can take one state to different next states at a new contact (EnvPool's 3.6.0 and
    gymnasium's 3.3.0 part on Hopper-v5's first touch): a MuJoCo task's identity names the version that steps it,
    an env MuJoCo does not simulate names none."""
    import importlib.metadata

    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

    installed = importlib.metadata.version

    def version(name: str) -> str:
        if name == "mujoco":
            return "9.9.9"
        return installed(name)

    hopper = GymTask("Hopper-v5").identity()
    assert hopper["simulator"].startswith("mujoco ")
    assert "simulator" not in GymTask("CartPole-v1").identity()
    monkeypatch.setattr(importlib.metadata, "version", version)
    assert GymTask("Hopper-v5").identity()["simulator"] == "mujoco 9.9.9" != hopper["simulator"]
