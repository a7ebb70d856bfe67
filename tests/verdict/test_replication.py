"""A published correlation beside ours: the outcome of each case, and the published numbers the studies declare."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.study_data import study_from_config
from taskcomplexity.verdict.references import correlations
from taskcomplexity.verdict.replication import (
    FINDING_ONLY,
    MEANINGS,
    REPLICATION_COLUMNS,
    fisher_interval,
    outcome,
    replications,
    shown_outcome,
)

STUDIES = Path(__file__).resolve().parents[2] / "src" / "taskcomplexity" / "conf" / "study"
NAN = float("nan")


def row(r, p, low=NAN, high=NAN, *, published=(0.8, 0.001), informative=(NAN, NAN, NAN), net=(NAN, NAN, NAN, NAN)):
    return {"published_r": published[0], "published_p": published[1], "pearson_r": r, "pearson_p": p,
            "pearson_low": low, "pearson_high": high, "informative_tasks": informative[0],
            "informative_r": informative[1], "informative_p": informative[2], "net_r": net[0], "net_p": net[1],
            "net_low": net[2], "net_high": net[3]}


@pytest.mark.parametrize(("case", "checked", "has_null", "expected"), [
    # holds on the values, the informative tasks and net of the null
    (row(0.8, 0.001, 0.6, 0.9, informative=(10, 0.7, 0.02), net=(0.7, 0.01, 0.5, 0.85)), True, True, "reproduced"),
    # holds on the values; net of the null its interval reaches 0: the estimator's bias
    (row(0.8, 0.001, 0.6, 0.9, informative=(10, 0.7, 0.02), net=(0.5, 0.03, -0.1, 0.8)), True, True,
     "estimator bias"),
    # holds on the values, but the metric carries information on two tasks only
    (row(0.8, 0.001, 0.6, 0.9, informative=(2, NAN, NAN), net=(0.7, 0.01, 0.5, 0.85)), True, True, "estimator bias"),
    # does not hold on the informative tasks
    (row(0.8, 0.001, 0.6, 0.9, informative=(8, 0.2, 0.6), net=(0.7, 0.01, 0.5, 0.85)), True, True, "estimator bias"),
    # ours excludes the published r over the policies and across the tasks
    (dict(row(0.1, 0.7, -0.2, 0.4, informative=(10, 0.1, 0.7)), tasks_low=-0.3, tasks_high=0.5), True, True,
     "not reproduced"),
    # ... over the policies only: too few tasks to tell
    (dict(row(0.1, 0.7, -0.2, 0.4, informative=(10, 0.1, 0.7)), tasks_low=-0.6, tasks_high=0.9), True, True,
     "unresolved at this budget"),
    # ours spans 0 and the published r
    (row(0.5, 0.1, -0.1, 0.9, informative=(10, 0.5, 0.1)), True, True, "unresolved at this budget"),
    # too few informative tasks to tell
    (row(0.1, 0.7, -0.2, 0.4, informative=(1, NAN, NAN)), True, True, "unresolved at this budget"),
    # significant only on the other side, without an interval
    (row(-0.8, 0.001), False, False, "not reproduced"),
    # a published correlation that is not significant, and ours neither
    (row(0.2, 0.5, -0.3, 0.6, published=(-0.3, 0.33), informative=(10, 0.2, 0.5)), True, True, "reproduced"),
    # ... and ours significant
    (row(0.8, 0.001, 0.6, 0.9, published=(-0.3, 0.33), informative=(10, 0.7, 0.01)), True, True, "not reproduced"),
])
def test_each_case_has_its_outcome(case, checked, has_null, expected):
    found, why = outcome(case, checked=checked, has_null=has_null)
    assert found == expected and why
    assert found in MEANINGS


def test_a_reproduced_finding_whose_value_ours_excludes_is_shown_as_the_finding_only():
    # the atlas's PIC row: theirs r = -0.295 (p = 0.33); ours r = 0.44, neither significant, and both of our
    # intervals (over resampled policies, Fisher's across 13 tasks) exclude -0.295
    pic = dict(row(0.44, 0.13, 0.38, 0.48, published=(-0.295, 0.328), informative=(13, 0.44, 0.13)),
               tasks_low=-0.15, tasks_high=0.80)
    found, why = outcome(pic, checked=True, has_null=True)
    assert found == "reproduced" and why == "neither the published correlation nor ours is significant"
    assert shown_outcome({**pic, "outcome": found}) == FINDING_ONLY
    # inside either interval, the value is not excluded: reproduced as it is
    assert shown_outcome({**pic, "outcome": found, "tasks_low": -0.4}) == "reproduced"
    assert shown_outcome({**pic, "outcome": found, "pearson_low": -0.3}) == "reproduced"
    # another outcome is shown as it is
    assert shown_outcome({**pic, "outcome": "unresolved at this budget"}) == "unresolved at this budget"


def test_a_study_declaring_published_correlations_gets_them_beside_ours():
    rng = np.random.default_rng(0)
    tasks = [f"t{i}" for i in range(6)]
    study = study_from_config({
        "name": "s", "tasks": [{"id": t, "env_id": "Pendulum-v1"} for t in tasks],
        "published": {"policies": 10, "episodes": 10, "bins": 10, "tables": {
            "printed": {"source": "a table", "correlations": {"reference": {"poic": [0.9, 0.01]}}}}},
    })
    score = pd.DataFrame({"task": tasks, "reference": "reference", "value": np.arange(6.0)})
    values = pd.DataFrame({"task": tasks, "quantity": "poic", "metric": "poic",
                           "value": np.arange(6.0) * 0.1 + rng.normal(0, 0.02, 6)})
    draws = pd.DataFrame([{"task": t, "metric": "poic", "resample": b, "value": 0.1 * i + rng.normal(0, 0.01)}
                          for i, t in enumerate(tasks) for b in range(50)])
    information = pd.DataFrame({"task": tasks, "metric": "poic", "informative": [True] * 4 + [False] * 2,
                                "null_mean": 0.01, "null_share": 0.1})
    correlated = correlations(values, score, draws=draws, information=information, registry=DEFAULT_REGISTRY)
    assert set(correlated["basis"]) == {"value", "informative", "net of null"}
    by_basis = correlated.set_index("basis")
    assert by_basis.loc["informative", "tasks"] == 4
    assert by_basis.loc["value", "pearson_low"] <= by_basis.loc["value", "pearson_r"] <= by_basis.loc["value",
                                                                                                      "pearson_high"]
    found = replications(correlated, study, registry=DEFAULT_REGISTRY)
    assert list(found.columns) == list(REPLICATION_COLUMNS) and len(found) == 1
    assert found["outcome"].item() == "reproduced" and found["published_r"].item() == 0.9


def published_tables():
    from hydra import compose, initialize_config_dir

    from taskcomplexity.cli import CONF_DIR
    from taskcomplexity.study.plan import study_from

    for path in sorted(STUDIES.glob("*.yaml")):
        with initialize_config_dir(str(CONF_DIR), version_base=None):
            study = study_from(compose("config", [f"study={path.stem}"]))
        for name, table in (study.published.tables if study.published else {}).items():
            yield path.stem, name, table


def test_declared_quantities_are_registered_metrics_details_or_reference_scores():
    from taskcomplexity.verdict.references import REFERENCES

    known = {m.name for m in DEFAULT_REGISTRY} | {d.name for m in DEFAULT_REGISTRY for d in m.details}
    known |= {r.name for r in REFERENCES}
    declared = list(published_tables())
    assert declared
    for study, name, table in declared:
        assert set(table.quantities) <= known, (study, name)
        assert set(table.correlations) <= {r.name for r in REFERENCES}, (study, name)


def test_each_published_correlation_follows_from_the_published_values_to_their_printed_digits():
    """A transcription check: the printed r of each quantity with each reference score, recomputed from the printed
    per-task values. Those are rounded (most to 3 decimals), which moves r by up to 0.002 and p by up to 0.005; a
    mistyped digit or a swapped column moves them by more."""
    checked = 0
    for study, _, table in published_tables():
        for reference, printed in table.correlations.items():
            for quantity, (r, p) in printed.items():
                tasks = [t for t, v in table.values.items() if quantity in v and reference in v]
                x = [table.values[t][reference] for t in tasks]
                y = [table.values[t][quantity] for t in tasks]
                found = scipy.stats.pearsonr(x, y)
                assert found.statistic == pytest.approx(r, abs=2e-3), (study, quantity, reference)
                assert found.pvalue == pytest.approx(p, abs=5e-3), (study, quantity, reference)
                checked += 1
    assert checked >= 14  # Furuta et al.'s row: 7 quantities × Score(A), Score(R)


def test_fishers_interval_is_scipys():
    x = np.arange(13.0)
    y = x + np.random.default_rng(1).normal(0, 4, 13)
    found = scipy.stats.pearsonr(x, y)
    expected = found.confidence_interval(0.95)
    assert fisher_interval(found.statistic, 13) == pytest.approx((expected.low, expected.high))


def test_the_rows_pearson_is_scipys():
    """The bootstrap interval's r per resample: scipy's to 1e-12 (the order of the sums differs, in the last bits)."""
    from taskcomplexity.verdict.references import pearson_rows

    rng = np.random.default_rng(2)
    x, rows = rng.normal(size=7), rng.normal(size=(5, 7))
    rows[1] = 3.0  # constant: undefined
    found = pearson_rows(x, rows)
    assert np.isnan(found[1])
    for i in (0, 2, 3, 4):
        assert found[i] == pytest.approx(scipy.stats.pearsonr(x, rows[i]).statistic, abs=1e-12)
