"""Ordered difficulty groups (verdict/groups.py): the rank agreement and the group relations, on synthetic values
whose order is known, and the study file's groups checked when it is read."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY
from taskcomplexity.study_data import study_from_config
from taskcomplexity.verdict.groups import (
    AGREE,
    CONTRADICT,
    NOT_SIGNIFICANT,
    UNINFORMATIVE,
    _taus,
    group_relations,
    rank_agreement,
)
from taskcomplexity.verdict.information import INFORMATION_COLUMNS

GROUPS = ("easy",) * 8 + ("medium",) * 6 + ("hard",) * 6
"""Twenty tasks in three groups, easiest first."""


def study(groups=GROUPS):
    return study_from_config({
        "name": "g", "tasks": [{"id": f"t{i}", "env_id": "CartPole-v1", "group": g} for i, g in enumerate(groups)],
        "groups": {"order": ["easy", "medium", "hard"], "source": "a test"}})


def values(easiness: np.ndarray, metric: str = "poic") -> pd.DataFrame:
    """A metric whose values give ``easiness`` (POIC: higher is easier)."""
    return pd.DataFrame({"task": [f"t{i}" for i in range(len(easiness))], "metric": metric, "value": easiness})


def draws(easiness: np.ndarray, spread: float, resamples: int = 200, metric: str = "poic") -> pd.DataFrame:
    rng = np.random.default_rng(1)
    rows = [{"task": f"t{i}", "metric": metric, "resample": b, "value": v + spread * rng.standard_normal()}
            for b in range(resamples) for i, v in enumerate(easiness)]
    return pd.DataFrame(rows)


RANKS = np.array([{"easy": 0, "medium": 1, "hard": 2}[g] for g in GROUPS], dtype=float)


def test_a_metric_that_follows_the_groups_agrees_and_its_intervals_hold_its_tau():
    easiness = 1.0 - RANKS / 3 + np.random.default_rng(0).normal(0, 0.05, RANKS.size)
    table = rank_agreement(values(easiness), study(), registry=DEFAULT_REGISTRY, alpha=0.005,
                           draws=draws(easiness, 0.02))
    row = table[(table["metric"] == "poic") & (table["basis"] == "value")].iloc[0]
    assert row["outcome"] == AGREE and row["kendall_tau"] > 0.6 and row["spearman_rho"] > 0.7
    assert row["policies_low"] <= row["kendall_tau"] <= row["policies_high"] and row["resamples"] == 200
    assert row["tasks_low"] <= row["kendall_tau"] <= row["tasks_high"]
    again = rank_agreement(values(easiness), study(), registry=DEFAULT_REGISTRY, alpha=0.005,
                           draws=draws(easiness, 0.02))
    pd.testing.assert_frame_equal(table, again)  # the resampled tasks are seeded: the same table every time


def test_a_reversed_metric_contradicts_and_a_flat_one_is_not_significant():
    reversed_ = rank_agreement(values(RANKS + 0.01 * np.arange(RANKS.size)), study(), registry=DEFAULT_REGISTRY,
                               alpha=0.005)
    assert reversed_.iloc[0]["outcome"] == CONTRADICT and reversed_.iloc[0]["kendall_tau"] < 0
    noise = np.random.default_rng(3).normal(size=RANKS.size)
    flat = rank_agreement(values(noise), study(), registry=DEFAULT_REGISTRY, alpha=0.005)
    assert flat.iloc[0]["outcome"] == NOT_SIGNIFICANT


def test_lower_is_easier_metrics_are_ranked_by_their_easiness():
    """The sign comes from the registry: a metric whose lower value is easier agrees when its values rise with the
    group's difficulty."""
    lower = next(m for m in DEFAULT_REGISTRY if not m.higher_is_easier and m.comparable_across_tasks)
    table = rank_agreement(values(RANKS + 0.01 * np.arange(RANKS.size), lower.name), study(),
                           registry=DEFAULT_REGISTRY, alpha=0.005)
    assert table.iloc[0]["outcome"] == AGREE


def test_an_order_that_is_the_nulls_is_gone_net_of_the_null():
    """Values that follow the groups only because their nulls do: agree on the value, not net of the null, and
    the report reads that metric net of its null."""
    from taskcomplexity.report.groups import verdict_of

    null = 1.0 - RANKS / 3
    value = null + np.random.default_rng(5).normal(0, 0.01, RANKS.size)
    checked = pd.DataFrame([{"task": f"t{i}", "metric": "poic", "value": v, "null_mean": n, "null_sd": 0.01,
                             "null_repeats": 10, "null_share": 1.0, "informative": False}
                            for i, (v, n) in enumerate(zip(value, null, strict=True))])
    checked = checked.reindex(columns=list(INFORMATION_COLUMNS))
    table = rank_agreement(values(value), study(), registry=DEFAULT_REGISTRY, alpha=0.005, information=checked)
    outcomes = dict(zip(table["basis"], table["outcome"], strict=True))
    assert outcomes == {"value": AGREE, "informative": UNINFORMATIVE, "net of null": NOT_SIGNIFICANT}
    assert verdict_of(table, "poic")[0] == "estimator"


def test_group_relations_compare_every_ordered_pair_of_groups():
    easiness = 1.0 - RANKS / 3 + np.random.default_rng(0).normal(0, 0.02, RANKS.size)
    table = group_relations(values(easiness), study(), registry=DEFAULT_REGISTRY, alpha=0.005)
    pairs = list(zip(table["easier"], table["harder"], strict=True))
    assert pairs == [("easy", "medium"), ("easy", "hard"), ("medium", "hard")]
    assert set(table["outcome"]) == {AGREE}
    assert table["tasks_easier"].tolist() == [8, 8, 6]


def test_a_study_without_groups_has_no_group_tables():
    plain = study_from_config({"name": "p", "tasks": [{"id": "a", "env_id": "CartPole-v1"}]})
    assert rank_agreement(values(np.ones(1)), plain, registry=DEFAULT_REGISTRY, alpha=0.005).empty
    assert group_relations(values(np.ones(1)), plain, registry=DEFAULT_REGISTRY, alpha=0.005).empty


@pytest.mark.parametrize(("groups", "message"), [
    ({"order": ["easy", "hard"]}, r"study\.groups must be \{order: \[easiest, …, hardest\], source"),
    ({"order": ["easy"], "source": "s"}, r"study\.groups\.order must be a list of at least 2 distinct group names"),
    ({"order": ["easy", "easy"], "source": "s"}, r"study\.groups\.order must be a list of at least 2 distinct"),
    ({"order": ["easy", "hard"], "source": ""}, r"study\.groups\.source must be a non-empty string"),
    ({"order": ["easy", "medium"], "source": "s"},
     r"study\.tasks\[1\]\.group='hard' is not one of study\.groups\.order \(allowed: easy, medium\)"),
])
def test_a_bad_groups_block_is_one_line(groups, message):
    node = {"name": "g", "tasks": [{"id": "a", "env_id": "CartPole-v1", "group": "easy"},
                                   {"id": "b", "env_id": "CartPole-v1", "group": "hard"}], "groups": groups}
    with pytest.raises(ConfigError, match=message):
        study_from_config(node)


def test_a_group_the_study_lacks_leaves_the_others_compared_by_their_own_names():
    """Tasks in easy and hard only (no medium): one relation, easy < hard, over the right tasks."""
    easiness = np.array([1.0, 0.9, 0.95, 0.1, 0.2, 0.15])
    table = group_relations(values(easiness), study(("easy",) * 3 + ("hard",) * 3), registry=DEFAULT_REGISTRY,
                            alpha=0.005)
    row = table.iloc[0]
    assert len(table) == 1 and (row["easier"], row["harder"]) == ("easy", "hard")
    assert (row["tasks_easier"], row["tasks_harder"]) == (3, 3) and row["mean_easier"] > row["mean_harder"]


def test_the_resampled_taus_are_scipys_kendalltau_of_each_resample():
    # The intervals' τ of every resample at once (scipy's axis=1) are those of one kendalltau call per resample:
    # bootstrap picks (ties in both orders, constant rows: NaN) and a matrix of draws against one known order.
    rng = np.random.default_rng(3)
    known = np.repeat([0.0, 1.0, 2.0], [3, 2, 2])
    values = rng.normal(size=known.size)
    picks = rng.integers(0, known.size, size=(300, known.size))
    one_by_one = np.array([scipy.stats.kendalltau(values[p], known[p]).statistic for p in picks])
    assert np.isnan(one_by_one).any() and np.isfinite(one_by_one).sum() > 200
    np.testing.assert_array_equal(_taus(values[picks], known[picks]), one_by_one)
    draws = rng.normal(size=(50, known.size))
    draws[0] = 1.0   # a constant draw
    np.testing.assert_array_equal(_taus(draws, known[np.newaxis, :]),
                                  [scipy.stats.kendalltau(draw, known).statistic for draw in draws])
    assert _taus(draws[:0], known[np.newaxis, :]).shape == (0,)
