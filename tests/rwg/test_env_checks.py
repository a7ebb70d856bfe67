"""A researcher's env that breaks what a cached return matrix relies on is refused in one line, exit 2,
with nothing left under the cache: NaN rewards, a reset that ignores its seed, observations of the wrong
shape, rewards that are not one number, steps that draw random numbers outside the env's
seeded generator. An env that raises ends in one line too, naming where, with its traceback in the run log and the
chunks of the policies done kept. A well-behaved env of the same package still runs, and so do the built-in envs."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import preloaded
from taskcomplexity.errors import TaskComplexityError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.rwg.env_checks import check_env
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

ROOT = Path(__file__).resolve().parents[2]

PACKAGE = textwrap.dedent('''
    import gymnasium
    import numpy as np
    from gymnasium import spaces


    class Line(gymnasium.Env):
        """A point on a line pushed by the action; reward -|x|. Well behaved."""

        def __init__(self):
            self.observation_space = spaces.Box(-10.0, 10.0, (2,), dtype=np.float64)
            self.action_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float64)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            self.x, self.t = float(self.np_random.uniform(-1, 1)), 0
            return self._obs(), {}

        def _obs(self):
            return np.array([self.x, self.t / 10.0])

        def step(self, action):
            self.x = float(np.clip(self.x + action[0], -10, 10))
            self.t += 1
            return self._obs(), self._reward(), False, False, {}

        def _reward(self):
            return -abs(self.x)


    class FarStart(Line):
        """Remembers where its episode started (``start``)."""

        def reset(self, *, seed=None, options=None):
            obs, info = super().reset(seed=seed)
            self.start = self.x
            return obs, info


    class NanReward(FarStart):
        """NaN reward at step 3 of the episodes that start right of x = 0.9."""

        def _reward(self):
            return float("nan") if self.t == 3 and self.start > 0.9 else -abs(self.x)


    class Unseeded(Line):
        """Reset ignores its seed: the start comes from a counter shared by every instance."""

        resets = 0

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            Unseeded.resets += 1
            self.x, self.t = 0.01 * Unseeded.resets, 0
            return self._obs(), {}


    class WrongShape(Line):
        """Declares two observation values, returns three."""

        def _obs(self):
            return np.array([self.x, self.t / 10.0, 0.0])


    class LateWrongShape(Line):
        """Right shape at reset, a flat scalar from step 2 on."""

        def _obs(self):
            return np.array([self.x, self.t / 10.0]) if self.t < 2 else np.float64(self.x)


    class Boom(FarStart):
        """Raises in step 5 of the episodes that start right of x = 0.9."""

        def step(self, action):
            if self.t == 4 and self.start > 0.9:
                raise ValueError("boom")
            return super().step(action)


    class EarlyBoom(Line):
        """Raises in step 5 of every episode."""

        def step(self, action):
            if self.t == 4:
                raise ValueError("boom")
            return super().step(action)


    class ArrayReward(Line):
        """The reward as an array of one number."""

        def _reward(self):
            return np.array([-abs(self.x)])


    class PairReward(Line):
        """Two numbers as the reward."""

        def _reward(self):
            return np.array([-abs(self.x), 0.0])


    class GlobalRandom(Line):
        """Kicks the point with NumPy's global generator in every step, not with its seeded self.np_random."""

        def step(self, action):
            self.x += 0.01 * np.random.normal()
            return super().step(action)


    class LateGlobalRandom(Line):
        """Seeded for 30 steps, then kicked with NumPy's global generator: only a whole episode shows it."""

        def step(self, action):
            if self.t >= 30:
                self.x += 0.01 * np.random.normal()
            return super().step(action)


    gymnasium.register("LabLateGlobalRandom-v0", entry_point=LateGlobalRandom, max_episode_steps=50)
    for name, cls in [("Line", Line), ("NanReward", NanReward), ("Unseeded", Unseeded),
                      ("WrongShape", WrongShape), ("LateWrongShape", LateWrongShape), ("Boom", Boom),
                      ("EarlyBoom", EarlyBoom), ("ArrayReward", ArrayReward), ("PairReward", PairReward),
                      ("GlobalRandom", GlobalRandom)]:
        gymnasium.register(f"Lab{name}-v0", entry_point=cls, max_episode_steps=8)
''')

POLICIES, EPISODES = 4, 3


@pytest.fixture
def lab(tmp_path, monkeypatch):
    """The researcher's package ``lab_checks`` in ``tmp_path`` (importable here and in subprocesses)."""
    (tmp_path / "lab_checks").mkdir()
    (tmp_path / "lab_checks" / "__init__.py").write_text(PACKAGE)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def rwg(lab: Path, env: str) -> subprocess.CompletedProcess:
    """``python pipelines/rwg.py task=gym task.env_id=lab_checks:Lab<env>-v0`` with outputs in ``lab``."""
    command = [sys.executable, str(ROOT / "pipelines" / "rwg.py"), "task=gym", f"task.env_id=lab_checks:Lab{env}-v0",
               f"rwg.policies={POLICIES}", f"rwg.episodes={EPISODES}", f"paths.outputs={lab / 'outputs'}"]
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    environment["PYTHONPATH"] = os.pathsep.join([str(lab), str(ROOT / "src")])
    return preloaded.run(command, cwd=lab, env=environment, capture_output=True, text=True, timeout=300)


PROGRESS = re.compile(r"^rwg \S+ \[gym\]: +\d+%\|.*\| \d+/\d+ \[")
"""A frame of the RWG stage's progress bar (tqdm, ended by a carriage return)."""


def refusal(done: subprocess.CompletedProcess) -> str:
    """The one error line of a refused run (asserting exit status 2 and that, but for progress-bar frames,
    it is the only line)."""
    assert done.returncode == 2, done.stderr[-2000:]
    lines = [line for line in done.stderr.splitlines() if line.strip() and not PROGRESS.match(line)]
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr[-2000:]
    return lines[0]


def leftovers(lab: Path) -> list[str]:
    """Everything under the RWG cache: artefacts, partial-work directories, locks."""
    cache = lab / "outputs" / "cache" / "rwg"
    return sorted(p.name for p in cache.iterdir()) if cache.exists() else []


def first_far_start(lab: Path) -> tuple[int, int]:
    """(policy, episode) of the first NaN reward of NanReward and the first exception of Boom: the first episode,
    in the pool's order (policy-major, every episode in flight at once at this N, M), that starts right of x = 0.9."""
    module = importlib.import_module("lab_checks")
    env = module.FarStart()
    for policy in range(POLICIES):
        for episode in range(EPISODES):
            env.reset(seed=int(episode_reset_seeds(0, np.array([policy]), np.array([episode]))[0]))
            if env.start > 0.9:
                return policy, episode
    raise AssertionError("no episode starts right of x = 0.9: choose another seed")


def test_nan_rewards_are_refused_naming_policy_episode_and_step_and_nothing_is_cached(lab):
    policy, episode = first_far_start(lab)
    assert policy > 0 and episode > 0, "the test should tell the policy and the episode from the pool's slot"
    line = refusal(rwg(lab, "NanReward"))
    assert line == (f"error: task.env_id=lab_checks:LabNanReward-v0 returned a non-finite reward (nan) at policy "
                    f"{policy}, episode {episode}, step 3; returns must be finite to be cached")
    assert leftovers(lab) == []


def test_a_reset_that_ignores_its_seed_is_refused_as_not_reproducible(lab):
    line = refusal(rwg(lab, "Unseeded"))
    assert line.startswith("error: task.env_id=lab_checks:LabUnseeded-v0 is not reproducible: two resets with seed ")
    assert line.endswith("gave different observations (the env's reset ignores its seed), so the cache cannot "
                         "serve its returns")
    assert leftovers(lab) == []


@pytest.mark.parametrize(("env", "where", "shape"), [
    ("WrongShape", "reset(seed=", "(3,)"),
    ("LateWrongShape", "step 2 of policy 0, episode 0", "()"),
])
def test_observations_outside_the_declared_space_are_refused_naming_env_space_and_shape(lab, env, where, shape):
    line = refusal(rwg(lab, env))
    assert line.startswith(f"error: task.env_id=lab_checks:Lab{env}-v0: {where}")
    assert f"returned an observation of shape {shape}, which does not match the declared observation space " \
           "Box(-10.0, 10.0, (2,), float64)" in line
    assert "broadcast" not in line
    assert leftovers(lab) == []


def test_a_well_behaved_env_of_the_same_package_still_runs_and_is_cached(lab):
    done = rwg(lab, "Line")
    assert done.returncode == 0, done.stderr[-2000:]
    artefacts = [name for name in leftovers(lab) if not name.startswith(".")]
    assert len(artefacts) == 1
    returns = (lab / "outputs" / "cache" / "rwg" / artefacts[0] / "returns.parquet")
    import pandas as pd

    frame = pd.read_parquet(returns)
    assert len(frame) == POLICIES * EPISODES and np.isfinite(frame["return"]).all()
    assert (frame["steps"] == 8).all()


def request(env: str, **settings) -> RWGRequest:
    """The RWG request of ``lab_checks:Lab<env>-v0`` at this file's N, M on the gym backend."""
    return RWGRequest(GymTask(f"lab_checks:Lab{env}-v0"), NetworkSpec(), PriorSpec(),
                      RWGSettings(policies=POLICIES, episodes=EPISODES, **settings), backend="gym")


def check_seed() -> int:
    """The reset seed of the first episode the check before RWG replays (policy 0's episode 0 at seed 0)."""
    return int(episode_reset_seeds(0, np.array([0]), np.array([0]))[0])


def test_an_env_raising_in_step_ends_in_one_line_naming_policy_episode_step_and_its_message(lab):
    policy, episode = first_far_start(lab)
    line = refusal(rwg(lab, "Boom"))
    start = (f"error: task.env_id=lab_checks:LabBoom-v0 raised in step 5 of episode {episode} of policy {policy}: "
             f"ValueError: boom (the traceback is in the run log ")
    assert line.startswith(start) and line.endswith(")"), line
    run_log = Path(line[len(start):-1])
    assert run_log.is_file(), line
    assert "Traceback" in run_log.read_text() and 'raise ValueError("boom")' in run_log.read_text()
    assert not [name for name in leftovers(lab) if name.startswith(".partial-")]


def test_an_env_raising_in_the_check_before_rwg_ends_in_one_line_and_nothing_is_cached(lab):
    line = refusal(rwg(lab, "EarlyBoom"))
    assert line.startswith(f"error: task.env_id=lab_checks:LabEarlyBoom-v0 raised in step 5 after reset(seed="
                           f"{check_seed()}) of the env check before RWG: ValueError: boom (the traceback is in the "
                           f"run log "), line
    assert leftovers(lab) == []


def test_saved_chunks_of_the_policies_done_stay_when_the_env_raises_and_an_empty_scratch_goes(lab, tmp_path):
    policy, _ = first_far_start(lab)
    cache = Cache(tmp_path / "chunked")
    with pytest.raises(TaskComplexityError, match=f"raised in step 5 of episode .* of policy {policy}: ") as raised:
        run_rwg_stage(cache, request("Boom", chunk_policies=1, workers=1))
    assert isinstance(raised.value.__cause__, ValueError)
    scratch = cache.root / "rwg" / f".partial-{request('Boom').key}"
    assert sorted(p.name for p in scratch.glob("chunk-*")) == [f"chunk-{n:07d}-{n + 1:07d}.npz" for n in range(policy)]
    [record] = [json.loads(p.read_text()) for p in scratch.glob("job-*.json")]   # the record of what this run saved
    assert (record["units"], record["reused"], record["part"]) == (policy, 0, "all")
    cache = Cache(tmp_path / "one_chunk")
    with pytest.raises(TaskComplexityError, match="ValueError: boom"):
        run_rwg_stage(cache, request("Boom"))
    assert not list((cache.root / "rwg").glob(".partial-*"))


def test_on_worker_processes_the_env_raising_ends_in_the_same_line_and_the_chunks_done_stay(lab, tmp_path):
    policy, _ = first_far_start(lab)
    cache = Cache(tmp_path / "workers")
    with pytest.raises(TaskComplexityError, match=f"raised in step 5 of episode .* of policy {policy}: ValueError: "
                                                  "boom") as raised:
        run_rwg_stage(cache, request("Boom", chunk_policies=1, workers=2))
    assert "ValueError: boom" in str(raised.value.__cause__)  # the worker's traceback, as text
    scratch = cache.root / "rwg" / f".partial-{request('Boom').key}"
    saved = sorted(p.name for p in scratch.iterdir())
    # every chunk started before it (each done, or running on the other worker and let finish), and not its own
    assert {f"chunk-{n:07d}-{n + 1:07d}.npz" for n in range(policy)} <= set(saved)
    assert f"chunk-{policy:07d}-{policy + 1:07d}.npz" not in saved


def test_a_reward_of_one_number_in_an_array_gives_the_returns_of_the_float_reward(lab, tmp_path):
    array, _ = run_rwg_stage(Cache(tmp_path / "array"), request("ArrayReward"))
    number, _ = run_rwg_stage(Cache(tmp_path / "float"), request("Line"))
    np.testing.assert_array_equal(load_returns(array), load_returns(number))


def test_a_reward_of_more_than_one_number_is_refused_naming_env_type_and_shape(lab):
    line = refusal(rwg(lab, "PairReward"))
    assert line == (f"error: task.env_id=lab_checks:LabPairReward-v0 returned a reward of type ndarray, shape (2,) "
                    f"at step 1 after reset(seed={check_seed()}) of the env check before RWG; a reward must be one "
                    f"number (a float, an int, or an array holding one number)")
    assert leftovers(lab) == []


def test_an_env_drawing_global_random_numbers_in_step_is_refused_as_not_reproducible(lab):
    line = refusal(rwg(lab, "GlobalRandom"))
    assert line == (f"error: task.env_id=lab_checks:LabGlobalRandom-v0 is not reproducible: two replays of the "
                    f"episode reset with seed {check_seed()}, with the same actions, gave a different observation at "
                    f"step 1 (does the env draw random numbers outside its seeded generator self.np_random, or keep "
                    f"state its reset does not restore?), so the cache cannot serve its returns")
    assert leftovers(lab) == []


def test_an_env_drawing_global_random_numbers_late_in_its_episodes_is_refused(lab):
    line = refusal(rwg(lab, "LateGlobalRandom"))
    assert (f"two replays of the episode reset with seed {check_seed()}, with the same actions, gave a different "
            "observation at step 31") in line
    assert leftovers(lab) == []


@pytest.mark.parametrize("task", [
    GymTask("CartPole-v1"), GymTask("Pendulum-v1"), GymTask("MountainCar-v0"), GymTask("MountainCarContinuous-v0"),
    GymTask("Acrobot-v1"), GymTask("taskcomplexity/NoisyCartPole-v0", {"dynamics_noise": 0.3}),
    make_task("one_link_1m0", "sparse"), make_task("two_link_obstacle", "dense"),
], ids=lambda task: task.task_id)
def test_the_built_in_envs_pass_the_checks_before_rwg(task):
    check_env(task, 0)
