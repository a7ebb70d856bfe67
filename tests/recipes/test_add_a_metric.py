"""docs/how-to/add-a-metric.md, followed on a scratch copy: its three files keep the tests green, and the metric
reaches the metrics artefact of a tiny run."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from howto import apply, blocks, commands, page, skip_if_followed, stated_counts, touched

PAGE = "add-a-metric.md"
GOLDEN = "tests/golden/test_golden.py::test_a_stages_numbers_are_those_recorded_at_its_version"


def test_the_page_adds_a_metric_in_the_files_it_states(scratch):
    text = page(PAGE)
    chosen = blocks(text)
    skip_if_followed(chosen)
    assert touched(chosen) == ["src/taskcomplexity/metrics/top_decile.py", "src/taskcomplexity/metrics/registry.py",
                               "src/taskcomplexity/metrics/__init__.py"]
    assert stated_counts(text)[0] == len(touched(chosen)) == 3
    apply(scratch.root, chosen)

    # the module is declared through the registry, the metric reaches the toy study's tables, the golden runs
    # report its new columns and rows (and compare every recorded one)
    done = scratch.pytest("tests/stages/test_numerics.py", "tests/metrics/test_registry.py",
                          "tests/test_docstring_references.py::test_each_package_docstring_names_every_module_of_its_folder",
                          f"{GOLDEN}[metrics]", f"{GOLDEN}[verdict]", "-W", "always::UserWarning")
    for stage in ("metrics", "verdict"):
        assert f"`PYTHONPATH=src python tests/golden/golden_runs.py --record {stage}`" in done.stdout, done.stdout
    assert "metrics.parquet › top_decile" in done.stdout and "rows of metric top_decile" in done.stdout

    # the page's commands: record the new values, then a tiny run of the metrics stage
    printed = {words[1]: scratch.command(env, words) for env, words in commands(text)}
    assert list(printed) == ["tests/golden/golden_runs.py", "pipelines/metrics.py"]
    assert "top_decile" in printed["pipelines/metrics.py"].stdout  # the printed table has its column
    (artefact,) = (scratch.root / "outputs" / "cache" / "metrics").glob("*/metrics.parquet")
    row = pd.read_parquet(artefact).iloc[0]
    (returns,) = (scratch.root / "outputs" / "cache" / "rwg").glob("*/returns.parquet")
    means = np.sort(pd.read_parquet(returns).groupby("policy")["return"].mean().to_numpy())
    assert row["top_decile"] == means[-math.ceil(len(means) / 10):].mean()
    assert {"top_decile_mean", "top_decile_sd"} <= set(row.index)
    assert "top_decile" in pd.read_parquet(artefact.with_name("batches.parquet")).columns

    # once recorded, the golden runs compare the metric's values too
    values = scratch.root / "tests" / "golden" / "values"
    with np.load(values / "metrics.npz") as metrics, np.load(values / "verdict.npz") as verdict:
        assert "one_link_1m0-dense › metrics.parquet › top_decile" in metrics.files
        assert "top_decile" in verdict["three tasks › verdict.parquet › metric"]
