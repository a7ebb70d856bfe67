"""The empirical difficulty derived from SAC curves: final return, normalised AUC, steps to 90 %."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import sac as sacs


def curve(task: str, seed: int, returns, *, variant: str = "sac", every: int = 1000) -> pd.DataFrame:
    returns = np.asarray(returns, dtype=float)
    return pd.DataFrame(
        {
            "task": task,
            "variant": variant,
            "seed": seed,
            "env_step": np.arange(returns.size) * every,
            "eval/return_mean": returns,
            "eval/return_std": 0.0,
            "eval/success_rate": 0.0,
            "train/episode_return": np.nan,
            "time/seconds": 0.0,
        }
    )


def test_a_linear_ramp_has_known_final_return_auc_and_steps_to_90_percent():
    # returns -10, -9, …, 0 at steps 0 … 10 000: final (last 5) = mean(-4 … 0) = -2; the curve normalised to
    # its own range [-10, 0] is a line from 0 to 1, so its mean over training is 0.5; 90 % of the way from
    # -10 to -2 is -2.8, first reached at -2 (step 8000).
    per_seed = sacs.seed_summary(curve("two_link-dense", 0, np.arange(-10, 1)))
    row = per_seed.iloc[0]
    assert row["final_return"] == pytest.approx(-2.0)
    assert row["auc_normalised"] == pytest.approx(0.5)
    assert row["steps_to_90"] == 8000
    assert row["budget"] == 10_000
    assert row["final_normalised"] == pytest.approx(0.8)


def test_random_policy_bounds_normalise_like_the_score():
    # worst random policy mean -20 and best random return -5, but SAC reaches 0: the range is [-20, 0].
    per_seed = sacs.seed_summary(curve("two_link-dense", 0, [-20, -10, 0, 0, 0, 0]),
                                 rwg_bounds={"two_link-dense": (-20.0, -5.0)}, final_evaluations=4)
    assert per_seed["final_normalised"].iloc[0] == pytest.approx(1.0)
    # trapezoid of 0, .5, 1, 1, 1, 1 over 5 unit intervals: (0.25 + 0.75 + 1 + 1 + 1) / 5
    assert per_seed["auc_normalised"].iloc[0] == pytest.approx(0.8)


def test_a_run_that_never_improves_has_no_steps_to_90_percent():
    per_seed = sacs.seed_summary(curve("two_link-sparse", 0, [-50.0] * 8))
    assert np.isnan(per_seed["steps_to_90"].iloc[0])


def test_the_summary_is_mean_and_sd_across_seeds_per_task_and_variant():
    curves = pd.concat(
        [
            curve("two_link-sparse", 0, [-50, -40, -30]),
            curve("two_link-sparse", 1, [-50, -30, -10]),
            curve("two_link-sparse", 0, [-50, -50, -50], variant="sac+her"),
        ]
    )
    summary = sacs.sac_summary(sacs.seed_summary(curves, final_evaluations=1))
    plain = summary.set_index("variant").loc["sac"]
    assert plain["seeds"] == 2
    assert plain["final_return_mean"] == pytest.approx(-20.0)
    assert plain["final_return_sd"] == pytest.approx(np.std([-30, -10], ddof=1))
    her = summary.set_index("variant").loc["sac+her"]
    assert her["seeds"] == 1 and np.isnan(her["final_return_sd"]) and her["improved"] == 0


def test_rows_without_an_evaluation_are_ignored():
    curves = curve("two_link-dense", 0, [-10, -5, 0])
    training = curves.assign(**{"eval/return_mean": np.nan, "env_step": curves["env_step"] + 500})
    per_seed = sacs.seed_summary(pd.concat([curves, training]))
    assert per_seed["evaluations"].iloc[0] == 3


def test_missing_columns_and_bad_options_are_named():
    with pytest.raises(ValueError, match="missing \\['eval/return_mean'\\]"):
        sacs.seed_summary(curve("two_link-dense", 0, [1, 2]).drop(columns="eval/return_mean"))
    with pytest.raises(ValueError, match="final_evaluations must be an integer >= 1, got 0"):
        sacs.seed_summary(curve("two_link-dense", 0, [1, 2]), final_evaluations=0)
