"""SAC with the batched kernel stepping the environments (``sac.backend=batched``) against PyBullet.

The kernel equals PyBullet to 1e-6 per step (tests/tasks/test_batched_vector.py); the networks read float32
observations, so the two runs start from the same evaluation and train to the same level: at a short budget
the final returns agree within the seeds' spread. The keys differ (another computation), and the obstacle task
keeps PyBullet and its key.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import SACSettings, train_sac_seeds
from taskcomplexity.rl.settings import env_backend
from taskcomplexity.stages.keys import stage_key
from taskcomplexity.stages.sac_stage import NUMERICS, STAGE, sac_identity
from taskcomplexity.tasks.spec import make_task


def _final(curve):
    last = curve[curve["env_step"] == curve["env_step"].max()]
    return last.set_index("seed")["eval/return_mean"]


@pytest.mark.parametrize(("arm", "reward", "her"), [("one_link_1m0", "dense", False), ("two_link", "sparse", True)])
def test_training_on_the_batched_backend_reaches_the_pybullet_level(arm, reward, her):
    settings = SACSettings(hidden_sizes=(32, 32), batch_size=32, total_steps=600, warmup_steps=100, eval_every=100,
                           eval_episodes=4, seeds=(0, 1, 2), her=her)
    task = make_task(arm, reward)
    reference = train_sac_seeds(task, settings, progress=False)
    batched = train_sac_seeds(task, dataclasses.replace(settings, backend="batched"), progress=False)
    assert list(batched.columns) == list(reference.columns) and len(batched) == len(reference)
    start = reference["env_step"] == 0
    # the same initial actors on the same start states: the first evaluation is the same to float32 rounding
    np.testing.assert_allclose(batched.loc[start, "eval/return_mean"], reference.loc[start, "eval/return_mean"],
                               rtol=1e-4, atol=1e-4)
    final_b, final_r = _final(batched), _final(reference)
    spread = max(final_b.std(), final_r.std())
    assert abs(final_b.mean() - final_r.mean()) <= spread, (final_b.tolist(), final_r.tolist())
    assert reference["eval/return_mean"].nunique() > 2  # the curves move: the comparison is not of two constants


def test_the_backend_enters_the_key_only_where_the_kernel_steps_the_environments():
    base = SACSettings(total_steps=2000)
    batched = dataclasses.replace(base, backend="batched")

    def key(task, settings):
        return stage_key(STAGE, NUMERICS, sac_identity(task, settings))

    free, obstacle = make_task("two_link", "dense"), make_task("two_link_obstacle", "dense")
    assert env_backend(free, batched).name == "batched" and env_backend(obstacle, batched) is None  # its own env
    assert key(free, batched) != key(free, base)
    assert key(obstacle, batched) == key(obstacle, base)  # the obstacle task keeps PyBullet, and its curves


def test_an_unknown_backend_is_refused_naming_the_key():
    with pytest.raises(ConfigError, match=r"sac\.backend must be one of \['pybullet', 'batched'\], got 'bullet'"):
        SACSettings(backend="bullet").validate()


def _plan(tmp_path, study):
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import open_dict

    from taskcomplexity.cli import CONF_DIR
    from taskcomplexity.study.plan import read_plan

    overrides = [f"study={study}", "experiment=smoke", "sac.enabled=true", "sac.total_steps=100",
                 "sac.backend=batched"]
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    GlobalHydra.instance().clear()
    with open_dict(cfg):
        cfg.paths.outputs = str(tmp_path)
        cfg.paths.cache = str(tmp_path / "cache")
    return read_plan(cfg)


def test_a_study_without_a_contact_free_arm_refuses_the_batched_backend(tmp_path):
    with pytest.raises(ConfigError, match="sac.backend=batched steps the environments of none of study"):
        _plan(tmp_path, "classic_control")
    assert not (tmp_path / "cache").exists()  # refused before any work
    assert _plan(tmp_path, "seven_tasks") is not None  # six of its seven tasks step on the kernel, the obstacle not
