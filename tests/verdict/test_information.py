"""The information check: a verdict never orders tasks by a value that measures only its estimator."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.metrics.batches import policies_to_resolve, welch_test
from taskcomplexity.metrics.bootstrap import bootstrap_indices
from taskcomplexity.metrics.diagnostics import permutation_null
from taskcomplexity.metrics.evaluate import batch_estimates
from taskcomplexity.metrics.pic import auto_bins, pic
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.study_data import Relation
from taskcomplexity.verdict import information, judge, null_means, summarise, uninformative
from taskcomplexity.verdict.information import CEILING_MARGIN, episodes_to_settle, null_test

RELATION = Relation("easy", "hard", "known")


def returns(policies: int, episodes: int, effect: float, *, seed: int, shift: float = 0.0) -> np.ndarray:
    """Returns = policy effect (sd ``effect``) + episode noise (sd 1) + ``shift``: i.i.d. when effect = 0."""
    rng = np.random.default_rng(seed)
    return shift + effect * rng.normal(size=(policies, 1)) + rng.normal(size=(policies, episodes))


def check(matrices: dict[str, np.ndarray], *, bins: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(information table, verdict) of PIC on ``matrices`` (task → returns), nulls of 10 permutations."""
    values, samples, nulls, policies = [], [], {}, {}
    pic_metric = DEFAULT_REGISTRY["pic"]
    for task, matrix in matrices.items():
        values.append({"task": task, "metric": "pic", "value": pic(matrix, bins=bins).pic})
        batches = batch_estimates(matrix, [pic_metric], batches=5, estimation=MetricsSettings(bins=bins).estimation())
        samples += [{"task": task, "metric": "pic", "value": v} for v in batches["pic"]]
        nulls[("pic", task)] = permutation_null(matrix, seed=1, repeats=10, bins=bins)["pic"].to_numpy()
        policies[("pic", task)] = matrix.shape[0]
    values, samples = pd.DataFrame(values), pd.DataFrame(samples)
    table = information(values, nulls, policies, registry=DEFAULT_REGISTRY)
    verdict = judge(values, samples, [RELATION], registry=DEFAULT_REGISTRY, uninformative=uninformative(table),
                    nulls=null_means(table), policies=policies)
    return table, verdict


def test_policies_without_effect_are_uninformative_at_small_n_m():
    # 64 policies × 8 episodes of i.i.d. returns at the published B = 10⁵: every return has its own bin,
    # PIC sits at ln 64 and equals its null, whatever the two "tasks" are.
    table, verdict = check({"easy": returns(64, 8, 0.0, seed=0), "hard": returns(64, 8, 0.0, seed=1, shift=3.0)},
                           bins=100_000)
    assert not table["informative"].any()
    assert table["reason"].str.contains("permutation null").all()
    assert table["reason"].str.contains("ceiling").all()
    assert (table["null_share"] > 0.99).all()
    assert verdict["outcome"].tolist() == ["uninformative"]
    summary = summarise(verdict, pd.DataFrame({"task": ["easy", "hard"], "metric": "pic", "value": [1.0, 2.0]}),
                        registry=DEFAULT_REGISTRY, orders={"o": ("easy", "hard")},
                        uninformative=uninformative(table))
    assert summary.loc[0, "uninformative"] == 1 and summary.loc[0, "agreements"] == 0
    assert math.isnan(summary.loc[0, "kendall_tau_o"])  # no informative value left to rank


def test_a_strong_policy_effect_is_informative():
    # The policy sets most of the return: PIC far above its null and far below ln N, at the paper's ratio of bins.
    matrices = {"easy": returns(400, 50, 3.0, seed=2), "hard": returns(400, 50, 0.5, seed=3)}
    table, verdict = check(matrices, bins=auto_bins(400, 50))
    assert table["informative"].all(), table
    assert (table["null_pvalue"] < 0.005).all() and table.set_index("task").loc["easy", "null_pvalue"] < 1e-9
    assert (table["ceiling_gap"] > CEILING_MARGIN).all()
    # the stronger effect carries more information, significantly: PIC agrees (higher = easier)
    assert verdict["outcome"].tolist() == ["agree"]
    assert verdict.loc[0, "null_share_of_difference"] < 0.5


def test_a_difference_that_is_the_nulls_is_uninformative_even_when_each_value_beats_its_null():
    # Two tasks with the same small policy effect but different return spreads: their nulls differ, their
    # excesses do not; the raw PIC difference is the estimator's.
    matrices = {"easy": returns(400, 50, 0.3, seed=4), "hard": 3.0 * returns(400, 50, 0.3, seed=5)}
    table, verdict = check(matrices, bins=100_000)
    share = verdict.loc[0, "null_share_of_difference"]
    assert share > 0.5
    assert verdict.loc[0, "outcome"] == "uninformative"


def test_the_null_test_is_a_one_sided_prediction_test():
    draws = np.array([1.0, 1.1, 0.9, 1.05, 0.95])
    assert null_test(float(draws.mean()), draws) == pytest.approx(0.5)
    assert null_test(2.0, draws) < 1e-3 < 0.9 < null_test(0.0, draws)
    assert null_test(1.0, np.full(5, 0.5)) == 0.0 and null_test(0.5, np.full(5, 0.5)) == 1.0
    assert math.isnan(null_test(1.0, np.array([1.0])))


def test_a_value_at_its_ceiling_is_uninformative_without_a_null():
    values = pd.DataFrame({"task": ["easy", "hard"], "metric": "dmp_pic", "value": [math.log(100) - 0.01, 2.0]})
    table = information(values, {}, {("dmp_pic", "easy"): 100, ("dmp_pic", "hard"): 100}, registry=DEFAULT_REGISTRY)
    assert table.set_index("task")["informative"].to_dict() == {"easy": False, "hard": True}
    assert table.set_index("task").loc["easy", "reason"] == "sits at its ceiling ln N"
    # a metric without a declared check is not listed (its values are judged as they are)
    plain = pd.DataFrame({"task": ["easy"], "metric": "score", "value": [0.5]})
    assert information(plain, {}, {("score", "easy"): 100}, registry=DEFAULT_REGISTRY).empty


def test_auto_bins_is_the_papers_ratio_and_a_pinned_protocol_keeps_its_b():
    assert auto_bins(10_000, 500) == 100_000  # the published scale: Table 1 does not move
    assert auto_bins(400, 50) == 400 and auto_bins(10, 4) == 2
    settings = MetricsSettings()
    assert settings.bins == "auto" and settings.at_scale(64, 8).bins == 10
    pinned = MetricsSettings(pinned=(1000, 1000, 100_000))
    assert pinned.at_scale(1000, 1000).bins == 100_000  # Furuta et al.'s B at their N, M
    assert pinned.at_scale(100, 1000).bins == 2000       # elsewhere the paper's ratio
    assert MetricsSettings(bins=777, pinned=(1000, 1000, 100_000)).at_scale(1000, 1000).bins == 777  # typed wins
    assert MetricsSettings().at_scale(64, 8).identity() == MetricsSettings(bins=10).identity()  # same key


def test_the_bootstrap_sd_falls_as_one_over_root_n():
    # The assumption behind the N-to-resolve estimate, on a synthetic matrix: 4× the policies halve the sd
    # of the bootstrap distribution of the mean return and of PIC (at a fixed B well below N·M).
    def bootstrap_sd(matrix, estimate):
        draws = [estimate(matrix[i]) for i in bootstrap_indices(matrix.shape[0], resamples=300, seed=0)]
        return float(np.std(draws, ddof=1))

    small, large = returns(200, 20, 1.0, seed=6), returns(800, 20, 1.0, seed=7)
    for estimate in (lambda m: float(m.mean()), lambda m: pic(m, bins=20).pic):
        ratio = bootstrap_sd(small, estimate) / bootstrap_sd(large, estimate)
        assert 1.6 < ratio < 2.5, ratio


def test_the_n_to_resolve_is_within_a_factor_two_of_where_a_simulated_difference_becomes_significant():
    # Two tasks whose mean returns differ by a little: at N = 50 the Welch test on 5 batches does not resolve
    # them (expected t ≈ 2, p ≈ 0.08). The estimate from such a run is compared with simulations: at half
    # of it the difference is resolved in fewer than half the runs, at twice it in more than half.
    metric = DEFAULT_REGISTRY["r_mean"]
    gap, n0 = 0.42, 50

    def batch_means(policies, seed):
        easy = returns(policies, 10, 1.0, seed=seed, shift=gap)
        hard = returns(policies, 10, 1.0, seed=seed + 10_000)
        return [batch_estimates(m, [metric], batches=5)["r_mean"].to_numpy() for m in (easy, hard)]

    estimates = [policies_to_resolve(*batch_means(n0, seed), n0) for seed in range(60)]
    estimate = float(np.median(estimates))  # one run's estimate is noisy (4 df a side): its median over runs
    assert estimate > n0

    def resolved_share(policies):
        runs = [welch_test(*batch_means(policies, 100 + seed)).pvalue < 0.005 for seed in range(80)]
        return float(np.mean(runs))

    assert resolved_share(int(estimate / 2)) < 0.5 < resolved_share(int(estimate * 2))


def test_the_n_to_resolve_is_below_n_when_resolved_and_infinite_without_a_difference():
    a, b = np.array([1.0, 1.1, 0.9, 1.0, 1.0]), np.array([2.0, 2.1, 1.9, 2.0, 2.0])
    assert policies_to_resolve(a, b, 100) < 100
    assert policies_to_resolve(a, a.copy(), 100) == math.inf
    assert policies_to_resolve(a, a + 0.01, 100) > 1000  # a difference well within the noise
    assert math.isnan(policies_to_resolve(a[:1], b, 100))


def test_kendall_tau_is_undefined_when_the_order_it_ranks_is_the_nulls():
    values = pd.DataFrame({"task": ["a", "b", "c"], "metric": "pic", "value": [3.0, 2.0, 1.0]})
    order = {"o": ("a", "b", "c")}
    clean = summarise(judge(values, values, [], registry=DEFAULT_REGISTRY), values, registry=DEFAULT_REGISTRY,
                      orders=order, nulls={("pic", t): 0.5 for t in "abc"})
    assert clean.loc[0, "kendall_tau_o"] == pytest.approx(1.0)  # equal nulls: the order is the excesses'
    driven = summarise(judge(values, values, [], registry=DEFAULT_REGISTRY), values, registry=DEFAULT_REGISTRY,
                       orders=order, nulls={("pic", "a"): 2.9, ("pic", "b"): 1.95, ("pic", "c"): 0.9})
    assert math.isnan(driven.loc[0, "kendall_tau_o"])


def test_what_the_more_sampling_sentences_say_of_the_histogram_nulls_holds_on_simulated_tasks():
    # The report says: under metrics.bins=auto (B = N·M/50) B grows with N and PIC's values approach their nulls;
    # at a held B they do not; at a held B the nulls shrink with more episodes M. A task with information (policy
    # effect sd 0.5, episode noise sd 1), M = 20, N = 250 → 1000 → 4000, nulls of 4 permutations.
    def excess_and_null(n, m, bins):
        matrix = returns(n, m, 0.5, seed=n + m)
        null = permutation_null(matrix, seed=1, repeats=4, bins=bins)["pic"].mean()
        return pic(matrix, bins=bins).pic - null, null

    auto = [excess_and_null(n, 20, auto_bins(n, 20)) for n in (250, 1000, 4000)]
    held = [excess_and_null(n, 20, 100) for n in (250, 1000, 4000)]
    # Margins from 4 seeds: the auto excess falls 4–25× from N = 250 to 4000; the held one ends at 1.0–2.1× where it
    # started and 3.4–25× above the auto one.
    assert auto[0][0] > auto[1][0] > auto[2][0] and auto[2][0] < auto[0][0] / 3  # it shrinks as B grows with N
    assert auto[0][1] < auto[1][1] < auto[2][1]  # while the nulls grow
    assert held[2][0] > 0.5 * held[0][0] and held[2][0] > 2 * auto[2][0]  # with B held the excess stays
    nulls = [excess_and_null(1000, m, 100)[1] for m in (10, 40)]
    assert nulls[1] < nulls[0] / 2  # and the nulls shrink with more episodes


def test_episodes_to_settle_brings_the_nulls_share_to_one_half():
    for share in (0.55, 0.8, 0.97):
        settled = episodes_to_settle(share, 50)
        factor = (50 / settled) ** 0.5  # the nulls scaled as M^-1/2
        assert factor * share / (1 - share + factor * share) <= 0.5 + 1e-12
        # one episode fewer leaves the share above one half: M′ is the smallest (rounded up)
        fewer = (50 / (settled - 1)) ** 0.5
        assert fewer * share / (1 - share + fewer * share) > 0.5
    assert np.isnan(episodes_to_settle(0.4, 50)) and np.isnan(episodes_to_settle(1.2, 50))
