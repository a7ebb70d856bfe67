"""Computing ahead (stages/ahead.py): the per-task stages a background process computes from each task's
returns are the artefacts the chain would compute itself, under the same keys, and the process never outlives
the chain."""

from __future__ import annotations

import json
import multiprocessing

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import open_dict

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.stages import ahead
from taskcomplexity.stages.declared import STAGES
from taskcomplexity.stages.rwg_stage import STAGE as RWG
from taskcomplexity.stages.rwg_stage import study_returns
from taskcomplexity.study.chain import study_artefacts
from taskcomplexity.study.plan import read_plan

AHEAD = tuple(stage.name for stage in ahead.ahead_stages(STAGES, RWG))


def _plan(outputs):
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=["experiment=smoke", "sac.enabled=false"])
    GlobalHydra.instance().clear()
    with open_dict(cfg):
        cfg.paths.outputs = str(outputs)
        cfg.paths.cache = str(outputs / "cache")
    return read_plan(cfg)


def _files(artefact) -> dict:
    """An artefact's files and their SHA-256, from its manifest."""
    return {name: entry["sha256"] for name, entry in json.loads((artefact.path / "manifest.json").read_text())["files"]
            .items()}


@pytest.fixture(scope="module")
def by_the_chain(tmp_path_factory):
    """The smoke study's artefacts, every stage computed by the chain itself."""
    return study_artefacts(_plan(tmp_path_factory.mktemp("chain")), progress=False, ahead=False)


def test_the_stages_computed_ahead_are_those_that_read_only_a_tasks_returns():
    assert {"metrics", "diagnostics", "primitives"} <= set(AHEAD)  # the paper's stages on returns among them
    for stage in STAGES:
        assert (stage.name in AHEAD) == (stage.inputs == (RWG,))


def test_artefacts_computed_ahead_are_the_chains_own(tmp_path, by_the_chain):
    plan = _plan(tmp_path)
    study_returns(plan.cache, plan.tasks)
    computed = []
    ahead.compute_ahead(plan, AHEAD, RWG, computed.append)
    tasks = list(plan.tasks)
    every_task = [stage for stage in AHEAD if stage != "primitives"]  # the family runs on reaching arms only
    assert [(stage, task) for stage, task, _ in computed if stage != "primitives"] == [
        (stage, task) for task in tasks for stage in every_task]
    assert {task for stage, task, _ in computed if stage == "primitives"} == set(by_the_chain.further["primitives"])
    assert all(seconds >= 0 for *_, seconds in computed)

    again = []
    ahead.compute_ahead(plan, AHEAD, RWG, again.append)
    assert again == []  # everything is in the cache now: nothing is computed twice

    chain = study_artefacts(plan, progress=False, ahead=False)  # every artefact of AHEAD is a cache hit now
    pairs = [(chain.diagnostics, by_the_chain.diagnostics), (chain.further["primitives"],
                                                             by_the_chain.further["primitives"])]
    pairs += [({r.task_id: r.metrics for r in chain.results}, {r.task_id: r.metrics for r in by_the_chain.results})]
    for mine, theirs in pairs:
        assert mine.keys() == theirs.keys() and mine
        for task in mine:
            assert mine[task].key == theirs[task].key
            assert _files(mine[task]) == _files(theirs[task])
    assert chain.verdict.key == by_the_chain.verdict.key
    assert _files(chain.verdict) == _files(by_the_chain.verdict)


def test_the_background_process_ends_with_the_chain_and_changes_no_result(tmp_path, by_the_chain):
    artefacts = study_artefacts(_plan(tmp_path), progress=False, ahead=True)
    assert multiprocessing.active_children() == []
    assert artefacts.verdict.key == by_the_chain.verdict.key
    assert _files(artefacts.verdict) == _files(by_the_chain.verdict)


def test_the_process_starts_only_when_the_returns_are_worth_it(tmp_path):
    plan = _plan(tmp_path)
    episodes = sum(r.settings.policies * r.settings.episodes for r in plan.requests)
    assert episodes < ahead.MIN_EPISODES and not ahead.worth_it(plan, ahead.DEFAULT_REGISTRY)
