"""A researcher's env that breaks what a cached return matrix relies on is refused in one line, exit 2,
with nothing left under the cache: NaN rewards, a reset that ignores its seed, observations of the wrong
shape (issue 29, item 5). A well-behaved env of the same package still runs."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from taskcomplexity.seeding import episode_reset_seeds

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


    class NanReward(Line):
        """NaN reward at step 3 of the episodes that start right of x = 0.9."""

        def reset(self, *, seed=None, options=None):
            obs, info = super().reset(seed=seed)
            self.start = self.x
            return obs, info

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


    for name, cls in [("Line", Line), ("NanReward", NanReward), ("Unseeded", Unseeded),
                      ("WrongShape", WrongShape), ("LateWrongShape", LateWrongShape)]:
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
    return subprocess.run(command, cwd=lab, env=environment, capture_output=True, text=True, timeout=300)


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


def first_nan(lab: Path) -> tuple[int, int]:
    """(policy, episode) of the first NaN reward: the first episode, in the pool's order (policy-major, every
    episode in flight at once at this N, M), that starts right of x = 0.9."""
    module = importlib.import_module("lab_checks")
    env = module.NanReward()
    for policy in range(POLICIES):
        for episode in range(EPISODES):
            env.reset(seed=int(episode_reset_seeds(0, np.array([policy]), np.array([episode]))[0]))
            if env.start > 0.9:
                return policy, episode
    raise AssertionError("no episode starts right of x = 0.9: choose another seed")


def test_nan_rewards_are_refused_naming_policy_episode_and_step_and_nothing_is_cached(lab):
    policy, episode = first_nan(lab)
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
