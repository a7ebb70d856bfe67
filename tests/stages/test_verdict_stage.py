"""The verdict stage: one row per (metric, relation), cached by key, undefined outcomes from the library."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.stages.task_artefacts import study_metrics
from taskcomplexity.stages.verdict_stage import FILES, SAC_FILE, run_verdict_stage
from taskcomplexity.study_data import Relation, load_study_file
from taskcomplexity.tasks.spec import task_from_id

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
TASKS = ("one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense")


def curves(metrics, tasks, seeds=(0, 1, 2)) -> pd.DataFrame:
    """SAC curves rising from the task's worst random policy mean r_min to 90 %, 60 %, 30 % … of the way to its
    best random return r_max (seed noise 0.5 % of the range): normalised, later tasks are harder."""
    rng = np.random.default_rng(0)
    rows = []
    for rank, task in enumerate(tasks):
        row = pd.read_parquet(metrics[task].file("metrics.parquet")).iloc[0]
        low, span = row["r_min"], row["r_max"] - row["r_min"]
        for seed in seeds:
            for step in range(0, 2001, 200):
                level = (0.9 - 0.3 * rank) * (1 - np.exp(-step / 300)) + rng.normal(0, 0.005)
                rows.append({"task": task, "variant": "sac", "seed": seed, "env_step": step,
                             "eval/return_mean": low + span * level})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    cache = Cache(tmp_path_factory.mktemp("verdict") / "cache")
    requests = [RWGRequest(task_from_id(t), NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6))
                for t in TASKS]
    results = study_metrics(cache, requests, MetricsSettings(bins=500, resamples=10), names=list(TASKS))
    return cache, {r.task_id: r.metrics for r in results}


def test_the_artefact_has_a_row_for_every_metric_and_relation(stage):
    cache, metrics = stage
    artefact, hit = run_verdict_stage(cache, SEVEN_TASKS, metrics, sac_curves=curves(metrics, TASKS))
    assert not hit and all(artefact.file(f).is_file() for f in (*FILES, SAC_FILE))
    verdict = pd.read_parquet(artefact.file("verdict.parquet"))
    relations = SEVEN_TASKS.relations_among(TASKS)
    # no diagnostics given, and SAC ran without HER: the metrics with a value for at least one task
    judged = [m.name for m in DEFAULT_REGISTRY if m.stage == "metrics" or m.name in ("sac_final", "sac_auc")]
    assert len(relations) == 3 and len(verdict) == len(judged) * len(relations)
    assert list(dict.fromkeys(verdict["metric"])) == judged
    assert list(verdict.columns[:8]) == ["metric", "easier", "harder", "kind", "value_easier", "value_harder",
                                         "pvalue", "outcome"]
    assert [(r.easier, r.harder) for r in relations] == list(dict.fromkeys(zip(verdict["easier"], verdict["harder"],
                                                                               strict=True)))
    # SAC's normalised plateaus fall by 0.3 per task, seed noise 0.005: its final return agrees with every relation
    final = verdict[verdict["metric"] == "sac_final"]
    assert (final["outcome"] == "agree").all() and (final["samples_easier"] == 3).all()
    summary = pd.read_parquet(artefact.file("summary.parquet")).set_index("metric")
    assert summary.loc["sac_final", "agreements"] == 3
    assert summary.loc["sac_final", "kendall_tau_dense"] == pytest.approx(1.0)
    # the values judged are the metrics artefacts' values
    pic = pd.read_parquet(metrics[TASKS[0]].file("metrics.parquet"))["pic"].iloc[0]
    first = verdict[(verdict["metric"] == "pic") & (verdict["easier"] == TASKS[0])]
    assert (first["value_easier"] == pic).all() and len(first) == 2


def test_a_second_run_is_a_cache_hit_and_any_input_change_is_a_new_key(stage, caplog):
    cache, metrics = stage
    first, _ = run_verdict_stage(cache, SEVEN_TASKS, metrics)
    with caplog.at_level("DEBUG", logger="taskcomplexity"):
        again, hit = run_verdict_stage(cache, SEVEN_TASKS, metrics)
    assert hit and again.key == first.key and "cache hit: verdict" in caplog.text
    fewer = replace(SEVEN_TASKS, relations=SEVEN_TASKS.relations[:1])
    assert run_verdict_stage(cache, fewer, metrics)[0].key != first.key
    assert run_verdict_stage(cache, SEVEN_TASKS, metrics, sac_curves=curves(metrics, TASKS))[0].key != first.key
    assert run_verdict_stage(cache, SEVEN_TASKS, metrics, alpha=0.05)[0].key != first.key


def test_a_metric_without_a_value_for_a_task_is_undefined_not_dropped(stage):
    cache, metrics = stage
    artefact, _ = run_verdict_stage(cache, SEVEN_TASKS, metrics, sac_curves=curves(metrics, TASKS[:2]))  # no SAC on two_link
    verdict = pd.read_parquet(artefact.file("verdict.parquet"))
    sac = verdict[verdict["metric"] == "sac_auc"].set_index("harder")
    assert sac.loc["two_link-dense", "outcome"].tolist() == ["undefined", "undefined"]
    assert sac.loc["two_link-dense", "value_harder"].isna().all()
    assert sac.loc["one_link_1m65-dense", "outcome"] != "undefined"
    summary = pd.read_parquet(artefact.file("summary.parquet")).set_index("metric")
    assert summary.loc["sac_auc", "undefined"] == 2 and summary.loc["sac_auc", "relations"] == 3


def test_a_study_without_relations_gets_an_empty_verdict_and_a_summary(stage):
    cache, metrics = stage
    artefact, _ = run_verdict_stage(cache, replace(SEVEN_TASKS, relations=(), orders={}), metrics)
    assert pd.read_parquet(artefact.file("verdict.parquet")).empty
    summary = pd.read_parquet(artefact.file("summary.parquet"))
    assert summary["metric"].tolist() == [m.name for m in DEFAULT_REGISTRY.of_stage("metrics")]


def test_relations_between_tasks_outside_the_results_are_left_out(stage):
    cache, metrics = stage
    study = replace(SEVEN_TASKS, relations=(*SEVEN_TASKS.relations, Relation("two_link-dense", "two_link-sparse", "reward")))
    verdict = pd.read_parquet(run_verdict_stage(cache, study, metrics)[0].file("verdict.parquet"))
    assert "two_link-sparse" not in set(verdict["harder"])


def test_the_verdict_gathers_each_declared_stage_from_the_files_its_record_names(stage):
    """One toy metric per further judged stage, in an artefact holding only that stage's declared files: each
    metric gets its values and Welch samples from them, and a stage with no record is refused."""
    from taskcomplexity.metrics.registry import Metric
    from taskcomplexity.stages.declared import judged_stages
    from taskcomplexity.stages.stage import POLICIES

    cache, metrics = stage
    further = [s for s, how in judged_stages().items() if how.on == POLICIES and s not in ("metrics", "diagnostics")]
    assert {"occupancy", "learning_path", "primitives"} <= set(further)
    toys = [Metric(f"toy_{s}", s, s, "", True, "x", s, compute=lambda x: 0.0, batched=True) for s in further]
    artefacts = {}
    for rank, name in enumerate(further):
        how = judged_stages()[name]

        def write(directory, rank=rank, name=name, how=how):
            pd.DataFrame({f"toy_{name}": [float(rank)], "policies": [20]}).to_parquet(directory / how.values)
            pd.DataFrame({f"toy_{name}": rank + np.linspace(0, 0.1, 5)}).to_parquet(directory / how.samples)
            return {}

        artefacts[name] = {t: cache.get_or_compute(name, f"{name}{i}", write, config={})[0] for i, t in enumerate(TASKS)}
    registry = DEFAULT_REGISTRY.with_metrics(*toys)
    artefact, _ = run_verdict_stage(cache, SEVEN_TASKS, metrics, stages=artefacts, registry=registry)
    values = pd.read_parquet(artefact.file("values.parquet"))
    samples = pd.read_parquet(artefact.file("samples.parquet"))
    for rank, name in enumerate(further):
        got = values[values["metric"] == f"toy_{name}"]
        assert sorted(got["task"]) == sorted(TASKS) and (got["value"] == rank).all(), name
        assert (samples["metric"] == f"toy_{name}").sum() == 5 * len(TASKS), name
    with pytest.raises(ValueError, match="stages must be further stages of .*'primitives'.*got \\['rwg'\\]"):
        run_verdict_stage(cache, SEVEN_TASKS, metrics, stages={"rwg": artefacts["occupancy"]}, registry=registry)


def test_the_sac_curves_key_is_their_numbers_not_their_wall_clock():
    from taskcomplexity.rl import WALL_CLOCK
    from taskcomplexity.stages.verdict_stage import curves_digest

    curves = pd.DataFrame({"task": ["a", "a"], "env_step": [0, 10], "eval/return_mean": [-3.0, -1.5],
                           f"{WALL_CLOCK}seconds": [0.4, 8.1]})
    retrained = curves.assign(**{f"{WALL_CLOCK}seconds": [0.5, 9.7]})  # the same run again, on a busier machine
    assert curves_digest(retrained) == curves_digest(curves)
    assert curves_digest(curves.assign(**{"eval/return_mean": [-3.0, -1.25]})) != curves_digest(curves)
    assert curves_digest(curves.rename(columns={"env_step": "step"})) != curves_digest(curves)
