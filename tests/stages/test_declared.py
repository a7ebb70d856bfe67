"""The stages' records are what the command line, the plan, the chain and the verdict read, so that a stage is
declared once and nothing keeps a second list of stages."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from omegaconf import OmegaConf, open_dict

import taskcomplexity
from taskcomplexity.cli import CONF_DIR, config_groups
from taskcomplexity.commands.rwg import UNREAD
from taskcomplexity.errors import ConfigError
from taskcomplexity.stages.declared import STAGES, judged_stages
from taskcomplexity.stages.stage import SEEDS
from taskcomplexity.stages.verdict_stage import VERDICT
from taskcomplexity.study.chain import CHAIN
from taskcomplexity.study.plan import read_plan

SOURCE = Path(taskcomplexity.__file__).parent


def test_every_stage_module_has_one_record_and_the_chain_runs_them_in_order_then_the_verdict():
    modules = sorted(p.stem.removesuffix("_stage") for p in (SOURCE / "stages").glob("*_stage.py"))
    assert sorted(s.name for s in CHAIN) == modules
    assert CHAIN[-1] is VERDICT and CHAIN[:-1] == STAGES
    for i, stage in enumerate(CHAIN):  # a stage runs after every stage it reads
        assert set(stage.inputs) <= {s.name for s in CHAIN[:i]}, stage.name


def test_every_declared_group_is_a_config_group_with_a_default_that_the_main_config_chooses():
    defaults = OmegaConf.to_container(OmegaConf.load(CONF_DIR / "config.yaml").defaults)
    chosen = {key for item in defaults if isinstance(item, dict) for key in item}
    for stage in STAGES:
        assert stage.group in config_groups(), stage.name
        assert (CONF_DIR / stage.group / "default.yaml").is_file(), stage.name
        assert stage.group in chosen, f"conf/config.yaml does not choose the {stage.group} group"


def test_the_rwg_command_refuses_every_other_stages_group():
    assert set(UNREAD) >= {s.group for s in STAGES if s.name != "rwg"} and "rwg" not in UNREAD


def test_the_verdict_reads_exactly_the_judged_stages_and_judges_seeds_from_the_sac_curves():
    judged = judged_stages()
    assert VERDICT.inputs == tuple(judged)
    assert [s for s, how in judged.items() if how.on == SEEDS] == ["sac"]
    for stage in STAGES:  # a stage's judged files are files its artefact holds
        if stage.judged is not None and stage.judged.on != SEEDS:
            assert {stage.judged.values, stage.judged.samples} <= set(stage.files), stage.name


def test_no_module_below_the_stages_lists_stages_by_name():
    """The metric registry, the verdict's gathering and the report take what they need of the records."""
    names = {s.name for s in CHAIN} - {"metrics"}  # "metrics" is also a package and a column name
    for path in [*(SOURCE / "verdict").glob("*.py"), SOURCE / "metrics" / "registry.py", SOURCE / "report" / "beyond.py"]:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Tuple, ast.List, ast.Set, ast.Dict)):
                items = node.keys if isinstance(node, ast.Dict) else node.elts
                listed = {i.value for i in items if isinstance(i, ast.Constant) and isinstance(i.value, str)}
                assert len(listed & names) < 2, f"{path.name}:{node.lineno} lists stages {sorted(listed & names)}"


@pytest.fixture
def smoke(compose_config, tmp_path):
    cfg = compose_config("experiment=smoke")
    with open_dict(cfg):
        cfg.paths.outputs = str(tmp_path / "outputs")
        cfg.paths.cache = str(tmp_path / "outputs" / "cache")
    return cfg


def test_the_plan_holds_every_stages_typed_settings_and_writes_nothing(smoke, tmp_path):
    plan = read_plan(smoke)
    assert set(plan.settings) == {s.name for s in STAGES if s.group is not None}
    for stage in STAGES:
        assert isinstance(plan.settings[stage.name], stage.settings), stage.name
    assert plan.settings["rwg"] == plan.requests[0].settings and list(plan.tasks) == [e.id for e in plan.entries]
    assert plan.name == "seven_tasks-smoke" and plan.outputs == tmp_path / "outputs" and not plan.force
    assert not (tmp_path / "outputs").exists(), "reading the plan makes no directory"
    assert plan.cache.root == tmp_path / "outputs" / "cache"


def test_the_chain_refuses_a_cache_it_cannot_write_before_any_stage_naming_the_key(smoke, tmp_path):
    from taskcomplexity.errors import ArtefactError
    from taskcomplexity.study.chain import study_artefacts

    (tmp_path / "outputs").mkdir()
    (tmp_path / "outputs" / "cache").write_text("a file where the cache's directory would be")
    plan = read_plan(smoke)
    with pytest.raises(ArtefactError, match=r"^paths\.cache: cannot write to "):
        study_artefacts(plan, progress=False, ahead=False)
    assert sorted(p.name for p in (tmp_path / "outputs").iterdir()) == ["cache"]


BAD = {  # per stage group: a value its settings refuse, and what the message says
    "rwg": ("policies", 1, "rwg.policies"),
    "metrics": ("resamples", 0, "metrics.resamples must be an integer >= 1"),
    "diagnostics": ("repeats", 1, "diagnostics.repeats must be an integer >= 2"),
    "sac": ("gamma", "high", "sac.gamma must be a number"),
    "occupancy": ("pairs", 0, "occupancy.pairs must be an integer >= 1"),
    "learning_path": ("every", 0, "learning_path.every must be an integer >= 1"),
    "primitives": ("batches", 1, "primitives.batches must be an integer >= 2"),
}


def test_the_bad_values_are_of_declared_groups():
    assert set(BAD) <= {s.group for s in STAGES if s.group is not None}


@pytest.mark.parametrize("stage", [s for s in STAGES if s.group is not None], ids=lambda s: s.name)
def test_the_plan_reads_every_declared_group_through_its_settings_type(smoke, stage):
    with open_dict(smoke):
        smoke[stage.group]["no_such_key"] = 1
    with pytest.raises(ConfigError, match=rf"{stage.group}\.no_such_key is not a known key \(allowed: "):
        read_plan(smoke)


@pytest.mark.parametrize("group", sorted(BAD))
def test_the_plan_refuses_a_bad_value_of_each_stages_settings_naming_the_key_before_any_work(smoke, group, tmp_path):
    key, value, message = BAD[group]
    with open_dict(smoke):
        smoke[group][key] = value
    with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
        read_plan(smoke)
    assert not (tmp_path / "outputs" / "cache").exists() or not any((tmp_path / "outputs" / "cache").iterdir())


def test_a_check_that_joins_a_stage_to_the_studys_tasks_runs_when_the_plan_is_read(smoke):
    with open_dict(smoke):
        smoke.diagnostics.knn_neighbors = int(smoke.rwg.episodes)  # M must exceed k
    with pytest.raises(ConfigError, match="diagnostics.knn_neighbors"):
        read_plan(smoke)
