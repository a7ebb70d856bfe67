"""A run interrupted after a checkpoint and restarted gives exactly the uninterrupted curve.

The guarantee (``taskcomplexity.rl.train``): same arguments, same machine and thread count → every
column identical bit for bit, except ``time/seconds`` (wall-clock).
"""

from __future__ import annotations

import logging

import pandas as pd
import pytest

from taskcomplexity.rl import CURVE_COLUMNS, WALL_CLOCK, SACSettings, train_sac_seeds
from taskcomplexity.rl.checkpoint import checkpoint_path
from taskcomplexity.tasks.spec import make_task

# The richest state: two seeds trained together, HER buffers, a checkpoint during the warm-up
# (step 100) and one after updates began (step 200).
SETTINGS = SACSettings(
    total_steps=300,
    warmup_steps=150,
    eval_every=50,
    eval_episodes=2,
    checkpoint_every=100,
    collect_steps=10,
    seeds=(0, 1),
    her=True,
)
TASK = make_task("one_link_1m0", "sparse")
DETERMINISTIC = [c for c in CURVE_COLUMNS if not c.startswith(WALL_CLOCK)]


@pytest.fixture(scope="module")
def uninterrupted():
    return train_sac_seeds(TASK, SETTINGS)


def test_restarting_from_each_checkpoint_reproduces_the_uninterrupted_curve(uninterrupted, tmp_path):
    first = train_sac_seeds(TASK, SETTINGS, checkpoint_dir=tmp_path, stop_after=100)
    assert first["env_step"].max() == 100 and checkpoint_path(tmp_path).exists()
    second = train_sac_seeds(TASK, SETTINGS, checkpoint_dir=tmp_path, stop_after=200)
    assert second["env_step"].max() == 200
    resumed = train_sac_seeds(TASK, SETTINGS, checkpoint_dir=tmp_path)
    pd.testing.assert_frame_equal(resumed[DETERMINISTIC], uninterrupted[DETERMINISTIC], check_exact=True)
    # the partial curves are prefixes of the whole one
    pd.testing.assert_frame_equal(second[DETERMINISTIC], uninterrupted[DETERMINISTIC].iloc[: len(second)])


def test_the_same_call_gives_the_same_curve_with_or_without_checkpoints(uninterrupted, tmp_path):
    # the environments are reset at checkpoint boundaries whether or not a directory is given
    with_checkpoints = train_sac_seeds(TASK, SETTINGS, checkpoint_dir=tmp_path)
    pd.testing.assert_frame_equal(with_checkpoints[DETERMINISTIC], uninterrupted[DETERMINISTIC], check_exact=True)


def test_a_resumed_run_says_where_it_resumes(tmp_path, caplog):
    tiny = SACSettings(total_steps=60, warmup_steps=20, eval_every=30, eval_episodes=1, checkpoint_every=30,
                       seeds=(0,), hidden_sizes=(16, 16))
    task = make_task("one_link_1m0", "dense")
    with caplog.at_level(logging.INFO, logger="taskcomplexity"):
        train_sac_seeds(task, tiny, checkpoint_dir=tmp_path, stop_after=30)
        assert not [r for r in caplog.records if "resuming" in r.getMessage()]  # a fresh run does not
        train_sac_seeds(task, tiny, checkpoint_dir=tmp_path)
    resumed = [r.getMessage() for r in caplog.records if "resuming" in r.getMessage()]
    assert resumed == ["resuming one_link_1m0-dense sac seed 0 from its checkpoint at step 30 of 60"]
