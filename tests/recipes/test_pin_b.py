"""docs/how-to/pin-b.md: its key is the metrics stage's B, and its one-task command pins it as printed."""

from __future__ import annotations

import json

import yaml
from howto import REPOSITORY, blocks, commands, page

PAGE = "pin-b.md"


def test_the_page_changes_no_file_and_names_the_metrics_key():
    text = page(PAGE)
    assert blocks(text) == [] and "no file changes" in text
    defaults = yaml.safe_load((REPOSITORY / "src" / "taskcomplexity" / "conf" / "metrics" / "default.yaml").read_text())
    assert defaults["bins"] == "auto" and "`metrics.bins`" in text
    printed = commands(text)
    assert printed and all(any(w.startswith("metrics.bins=") for w in words) for _, words in printed)


def test_its_one_task_command_runs_the_metrics_at_the_pinned_b(scratch):
    # the study commands run every stage of the chain; the one-task command is the metrics stage alone
    ((env, words),) = [(env, words) for env, words in commands(page(PAGE)) if words[1] == "pipelines/metrics.py"]
    bins = int(next(w for w in words if w.startswith("metrics.bins=")).split("=")[1])
    scratch.command(env, words, "metrics.resamples=5", "metrics.batches=2")
    (manifest,) = (scratch.root / "outputs" / "cache" / "metrics").glob("*/manifest.json")
    assert json.loads(manifest.read_text())["config"]["bins"] == bins
