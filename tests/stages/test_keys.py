"""A stage key is its name, its declared numerics version, its settings and its inputs' keys — not its code.

So a refactor (a function moved between modules, a log line, glue) keeps every key, and a version bump (what
``tests/golden`` demands when a stage's numbers change) re-keys the stage.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import sys
from pathlib import Path

import pytest

import preloaded
import taskcomplexity
from taskcomplexity.stages import keys
from taskcomplexity.study.chain import CHAIN

STAGES = tuple(stage.name for stage in CHAIN)
"""Every stage, read from the stage records (the verdict last)."""

# Prints {stage: key} for fixed settings: the real keys of the RWG, SAC and metrics stages of a task, and
# every stage's key of a fixed payload. Run in a subprocess on a copy of the sources.
KEYS_SCRIPT = """
import importlib, json, sys
import taskcomplexity
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rl.settings import SACSettings
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.keys import stage_key
from taskcomplexity.stages.metrics_stage import MetricsSettings, metrics_key
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.stages.sac_stage import NUMERICS, STAGE, sac_identity
from taskcomplexity.tasks.spec import make_task

task = make_task("one_link_1m0", "dense")
rwg = RWGRequest(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6)).key
out = {"source": taskcomplexity.__file__, "rwg request": rwg,
       "metrics of it": metrics_key(rwg, MetricsSettings(bins=100)),
       "sac run": stage_key(STAGE, NUMERICS, sac_identity(task, SACSettings(total_steps=300)))}
for stage in sys.argv[1:]:
    module = importlib.import_module(f"taskcomplexity.stages.{stage}_stage")
    out[stage] = stage_key(module.STAGE, module.NUMERICS, {"x": 1})
print(json.dumps(out))
"""


def _keys_from(source_root: Path) -> dict:
    done = preloaded.run([sys.executable, "-c", KEYS_SCRIPT, *STAGES], env={**os.environ, "PYTHONPATH": str(source_root)},
                         capture_output=True, text=True, check=True, timeout=300)
    return json.loads(done.stdout.splitlines()[-1])


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert text.count(old) == 1, f"{path}: the refactor's anchor {old!r} is not there once"
    path.write_text(text.replace(old, new), encoding="utf-8")


def test_a_refactor_outside_the_numbers_and_logging_in_them_change_no_key(tmp_path):
    """A key holds the version of a stage's numbers, not its code: move a function between modules outside every
    stage's numerics, rename a helper and add log lines inside SAC's and RWG's declared modules; every key, SAC's
    included, stays, so a refactor never throws away hours of SAC curves."""
    package = Path(taskcomplexity.__file__).parent
    copy = tmp_path / "src" / "taskcomplexity"
    shutil.copytree(package, copy, ignore=shutil.ignore_patterns("__pycache__"))
    # move stage_log.outcome (glue, imported by the SAC stage) into progress.py
    stage_log, progress = copy / "stages" / "stage_log.py", copy / "progress.py"
    source = stage_log.read_text(encoding="utf-8")
    start = source.index("def outcome(")
    end = source.index("\n\n\n", start)
    progress.write_text(progress.read_text(encoding="utf-8") + "\n\n" + source[start:end] + "\n", encoding="utf-8")
    stage_log.write_text(source[:start] + "from taskcomplexity.progress import outcome  # noqa: E402\n"
                         + source[end:], encoding="utf-8")
    _edit(copy / "stages" / "sac_stage.py", "from taskcomplexity.stages.stage_log import outcome",
          "from taskcomplexity.progress import outcome")
    # a log line in SAC's training loop and a renamed private helper of the RWG stage (both declared modules)
    _edit(copy / "rl" / "train.py", "    refuse_untrainable(task, settings)\n",
          "    refuse_untrainable(task, settings)\n    logging.getLogger(__name__).debug('training %s', task.task_id)\n")
    _edit(copy / "rl" / "train.py", "from __future__ import annotations\n", "from __future__ import annotations\n\nimport logging\n")
    rwg = copy / "stages" / "rwg_stage.py"
    rwg.write_text(rwg.read_text(encoding="utf-8").replace("_chunk_file(", "_saved_chunk_path("), encoding="utf-8")

    here = _keys_from(package.parent)
    moved = _keys_from(copy.parent)
    assert Path(moved.pop("source")).is_relative_to(copy) and Path(here.pop("source")).is_relative_to(package)
    assert moved == here
    assert len(set(here.values())) == len(here)  # every stage's key of the same payload is its own


@pytest.mark.parametrize("stage", STAGES)
def test_a_version_bump_re_keys_a_stage_and_the_declared_modules_do_not(stage):
    import importlib

    module = importlib.import_module(f"taskcomplexity.stages.{stage}_stage")
    numerics, payload = module.NUMERICS, {"settings": {"n": 3}, "rwg": "0123456789abcdef"}
    key = keys.stage_key(module.STAGE, numerics, payload)
    assert len(key) == 16 and int(key, 16) >= 0
    bumped = dataclasses.replace(numerics, version=numerics.version + 1)
    assert keys.stage_key(module.STAGE, bumped, payload) != key
    moved = dataclasses.replace(numerics, modules=tuple(f"elsewhere.{m}" for m in numerics.modules))
    assert keys.stage_key(module.STAGE, moved, payload) == key  # a layout change of the numbers' modules
    assert keys.stage_key(module.STAGE, numerics, {**payload, "rwg": "fedcba9876543210"}) != key  # an input


def test_a_declaration_is_a_positive_version_and_distinct_modules():
    with pytest.raises(ValueError, match="integer >= 1"):
        keys.Numerics(0, ("policies",))
    with pytest.raises(ValueError, match="declared twice"):
        keys.Numerics(1, ("policies", "policies"))
    assert keys.Numerics(2, ("rl.train",)).qualified() == ("taskcomplexity.rl.train",)


def _one_at_a_time(settings, changed: dict, not_a_result: set, key) -> None:
    assert set(changed) == {f.name for f in dataclasses.fields(settings)}  # a new field must be declared here
    for name, value in changed.items():
        other = dataclasses.replace(settings, **{name: value})
        assert (key(other) == key(settings)) == (name in not_a_result), name


def test_metrics_and_diagnostics_keys_follow_their_declarations():
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings
    from taskcomplexity.stages.metrics_stage import MetricsSettings

    one = keys.Numerics(1, ())
    _one_at_a_time(MetricsSettings(), {"bins": 500, "temperature_range": (1e-3, 1e3), "resamples": 10, "batches": 4,
                                       "alpha": 0.05, "seed": 3, "pinned": (1000, 1000, 100_000)},
                   {"alpha", "pinned"}, lambda s: keys.stage_key("metrics", one, s.identity()))
    # the key holds the resolved B: auto at the paper's ratio hashes as the same integer typed
    assert MetricsSettings().at_scale(400, 50).identity() == MetricsSettings(bins=400).identity()
    _one_at_a_time(DiagnosticsSettings(), {"repeats": 3, "bins_sweep": (10, 100), "subsample_fractions": (0.5, 1.0),
                                           "knn_neighbors": 4, "knn_max_samples": 1000, "knn_episodes_per_policy": 9,
                                           "seed": 2},
                   set(), lambda s: keys.stage_key("diagnostics", one, s.identity()))
    # order of a sweep is not a setting
    assert (DiagnosticsSettings(bins_sweep=(100, 10)).identity() == DiagnosticsSettings(bins_sweep=(10, 100)).identity())


def test_the_rwg_key_follows_the_settings_declaration():
    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.rwg_stage import RWGRequest
    from taskcomplexity.tasks.spec import make_task

    def key_of(task):
        return lambda s: RWGRequest(task, NetworkSpec(), PriorSpec(), s).key

    changed = {"policies": 12, "episodes": 7, "seed": 4, "chunk_policies": 3, "chunk_memory_mb": 64, "shard": 1,
               "shards": 2, "workers": 3, "contacts": "model", "common_initial_states": True, "precision": "float32",
               "entry": "two_link-dense"}
    split = {"chunk_policies", "chunk_memory_mb", "shard", "shards", "workers", "entry"}  # entry: which task, not how
    # the obstacle task's forward pass stays float64 (chaotic contacts): the precision is not in its key
    _one_at_a_time(RWGSettings(), changed, split | {"precision"}, key_of(make_task("two_link_obstacle")))
    # the contact handling cannot change a task without the block: not in its key
    _one_at_a_time(RWGSettings(), changed, split | {"contacts"}, key_of(make_task("two_link")))
