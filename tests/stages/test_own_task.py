"""A researcher's own env, in a package our code has never seen, through rwg → metrics → verdict → report.

The package registers its env with gymnasium; the study file lives in the researcher's directory and is
found through Hydra's search path; its one relation is judged by the verdict.
"""

from __future__ import annotations

import os
import sys
import textwrap
from pathlib import Path

import pandas as pd

import preloaded
from taskcomplexity.verdict import OUTCOMES

ROOT = Path(__file__).resolve().parents[2]

PACKAGE = textwrap.dedent('''
    import gymnasium
    import numpy as np
    from gymnasium import spaces


    class Drift(gymnasium.Env):
        """Push a point to the origin; ``noise`` kicks it about."""

        def __init__(self, noise: float = 0.0):
            self.noise = noise
            self.observation_space = spaces.Box(-10.0, 10.0, (1,), dtype=np.float64)
            self.action_space = spaces.Box(-0.5, 0.5, (1,), dtype=np.float64)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            self.x = self.np_random.uniform(-1, 1, 1)
            return self.x.copy(), {}

        def step(self, action):
            self.x = np.clip(self.x + action + self.noise * self.np_random.normal(size=1), -10, 10)
            done = bool(abs(self.x[0]) < 0.05)
            return self.x.copy(), -float(abs(self.x[0])), done, False, {"is_success": done}


    gymnasium.register("LabDrift-v0", entry_point=Drift, max_episode_steps=30)
''')

STUDY = textwrap.dedent('''
    name: lab
    tasks:
      - {id: calm, env_id: "lab_envs:LabDrift-v0", label: "drift, calm"}
      - {id: noisy, env_id: "lab_envs:LabDrift-v0", kwargs: {noise: 0.3}, label: "drift, noisy"}
    relations:
      - {easier: calm, harder: noisy, kind: noise}
''')


def test_a_researchers_own_env_and_study_run_through_to_a_verdict(tmp_path):
    (tmp_path / "lab_envs").mkdir()
    (tmp_path / "lab_envs" / "__init__.py").write_text(PACKAGE)
    (tmp_path / "studies" / "study").mkdir(parents=True)
    (tmp_path / "studies" / "study" / "lab.yaml").write_text(STUDY)
    outputs = tmp_path / "outputs"
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    command = [sys.executable, str(ROOT / "pipelines" / "study.py"), f"hydra.searchpath=[file://{tmp_path / 'studies'}]",
               "study=lab", "rwg.policies=24", "rwg.episodes=6", "metrics.bins=500", "metrics.resamples=10",
               "sac.enabled=false", f"paths.outputs={outputs}"]
    done = preloaded.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Report:" in done.stdout
    (verdict,) = (pd.read_csv(path) for path in (outputs / "reports" / "lab").glob("*/tables/verdict_tidy.csv"))
    judged = verdict[(verdict["easier"] == "calm") & (verdict["harder"] == "noisy")]
    assert {"pic", "poic"} <= set(judged["metric"])
    assert set(judged["outcome"]) <= set(OUTCOMES)
    assert (judged["kind"] == "noise").all()
    # the two entries are different computations: same id, different constructor arguments
    returns = sorted((outputs / "cache" / "rwg").glob("*/returns.parquet"))
    assert len(returns) == 2
    a, b = (pd.read_parquet(path)["return"].to_numpy() for path in returns)
    assert a.shape == b.shape == (24 * 6,) and not (a == b).all()
