"""docs/how-to/add-a-stage.md, followed on a scratch copy: its five files keep the tests that go over the stages
green and run in a study's chain, judged by the verdict; its golden run is one more file and a record."""

from __future__ import annotations

import json

import pandas as pd
from howto import apply, blocks, commands, page, skip_if_followed, stated_counts, touched

PAGE = "add-a-stage.md"
GOLDEN = "tests/golden/test_golden.py::test_a_stages_numbers_are_those_recorded_at_its_version"
GOLDEN_SECTION = "Its golden run"
RECORD = "PYTHONPATH=src python tests/golden/golden_runs.py --record spread"

# A study of the first two tasks of the seven and the one relation between them, at the smoke size, through the
# real plan and chain, with the new stage's setting typed on the command line: prints where the verdict is.
STUDY = """
import sys
from hydra import compose, initialize_config_dir
from omegaconf import open_dict
from taskcomplexity.cli import CONF_DIR
from taskcomplexity.study.chain import study_artefacts
from taskcomplexity.study.plan import read_plan

if __name__ == "__main__":
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=["experiment=smoke", "sac.enabled=false", "primitives.enabled=false",
                                           "spread.batches=3", f"paths.outputs={sys.argv[1]}"])
    with open_dict(cfg):
        cfg.study.tasks = cfg.study.tasks[:2]
        cfg.study.relations = cfg.study.relations[:1]
        cfg.study.orders = {}
    done = study_artefacts(read_plan(cfg), progress=False, ahead=False)
    print(done.verdict.file("verdict.parquet"))
"""


def _stage_blocks():
    text = page(PAGE)
    chosen = blocks(text)
    skip_if_followed(chosen)
    stage = [b for b in chosen if b.section != GOLDEN_SECTION]
    golden = [b for b in chosen if b.section == GOLDEN_SECTION]
    return text, stage, golden


def test_the_page_adds_a_stage_in_the_files_it_states_and_a_study_runs_it(scratch):
    text, stage, golden = _stage_blocks()
    assert touched(stage) == ["src/taskcomplexity/stages/spread_stage.py", "src/taskcomplexity/conf/spread/default.yaml",
                              "src/taskcomplexity/conf/config.yaml", "src/taskcomplexity/stages/__init__.py",
                              "src/taskcomplexity/metrics/registry.py"]
    assert stated_counts(text)[:2] == [len(touched(stage)), len(touched(golden))] == [5, 1]
    apply(scratch.root, stage)

    done = scratch.pytest("tests/stages/test_declared.py", "tests/stages/test_numerics.py", f"{GOLDEN}[spread]",
                          "tests/test_docstring_references.py::test_each_package_docstring_names_every_module_of_its_folder",
                          "-rs")
    assert "stage spread has no golden run" in done.stdout, done.stdout  # skipped, saying how to add it

    (script := scratch.root / "study.py").write_text(STUDY, encoding="utf-8")
    outputs = scratch.root / "outputs"
    verdict = pd.read_parquet(scratch.run(str(script), str(outputs)).stdout.strip().splitlines()[-1])
    judged = verdict[verdict["metric"] == "mean_spread"]
    assert len(judged) == 1 and judged["samples_easier"].tolist() == [3]  # its own batches are its Welch samples
    artefacts = sorted((outputs / "cache" / "spread").glob("*/spread.parquet"))
    assert len(artefacts) == 2 and all("mean_spread" in pd.read_parquet(a).columns for a in artefacts)


def test_its_golden_run_is_one_more_file_and_a_record(scratch):
    _, stage, golden = _stage_blocks()
    assert touched(golden) == ["tests/golden/golden_runs.py"]
    apply(scratch.root, stage + golden)

    ((env, words),) = commands(page(PAGE))  # the page's command: record the golden run
    assert words[1:] == ["tests/golden/golden_runs.py", "--record", "spread"]
    scratch.command(env, words)
    assert json.loads((scratch.root / "tests" / "golden" / "records.json").read_text())["spread"]["version"] == 1
    assert (scratch.root / "tests" / "golden" / "values" / "spread.npz").is_file()

    done = scratch.pytest(f"{GOLDEN}[spread]", "tests/golden/test_golden.py::test_every_golden_run_is_a_declared_stage"
                          "_and_every_record_has_its_run", "tests/stages/test_keys.py", "tests/metrics/test_registry.py",
                          "-rs")
    assert "skipped" not in done.stdout and RECORD not in done.stdout, done.stdout
