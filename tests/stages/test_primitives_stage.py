"""The primitives stage: PIC and POIC of the study's arm tasks under the movement-primitive family."""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.sample import Sample
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.policies.primitives import PrimitiveSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.primitives_stage import PrimitivesSettings, study_primitives
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

METRICS = MetricsSettings(bins=50, resamples=20)


def _study_requests():
    rwg = RWGSettings(policies=12, episodes=5, seed=3)
    return {"dense": RWGRequest(make_task("one_link_1m0", "dense"), NetworkSpec(), PriorSpec(), rwg),
            "two": RWGRequest(make_task("two_link", "sparse"), NetworkSpec(), PriorSpec(), rwg),
            "pendulum": RWGRequest(GymTask("Pendulum-v1"), NetworkSpec(), PriorSpec(), rwg, "kernel")}


def test_the_stage_estimates_pic_and_poic_of_the_family_returns(tmp_path):
    cache = Cache(tmp_path)
    settings = PrimitivesSettings(policies=20, episodes=6, bins=40, batches=4, network=PrimitiveSpec(basis=6))
    artefacts = study_primitives(cache, _study_requests(), METRICS, settings)
    assert sorted(artefacts) == ["dense", "two"]  # Pendulum is not a reaching arm: left out
    for task_id, task in (("dense", make_task("one_link_1m0", "dense")), ("two", make_task("two_link", "sparse"))):
        row = pd.read_parquet(artefacts[task_id].file("primitives.parquet")).iloc[0]
        # the same numbers from the family's returns, computed here independently of the stage
        returns = run_rwg(task, PrimitiveSpec(basis=6), PriorSpec(), RWGSettings(policies=20, episodes=6, seed=3),
                          "batched").returns
        sample = Sample(returns, dataclasses.replace(METRICS, bins=40).estimation())
        assert (row["policies"], row["episodes"]) == (20, 6)
        assert row["dmp_pic"] == pytest.approx(sample.pic.pic, abs=1e-12)
        assert row["dmp_poic"] == pytest.approx(sample.poic.poic, abs=1e-12)
        assert row["dmp_h_r"] - row["dmp_h_r_given_theta"] == pytest.approx(row["dmp_pic"], abs=1e-12)
        assert row["dmp_pic_ci_low"] <= row["dmp_pic_mean"] <= row["dmp_pic_ci_high"]
        batches = pd.read_parquet(artefacts[task_id].file("batches.parquet"))
        assert list(batches["policies"]) == [5, 5, 5, 5]
        assert batches["dmp_pic"].notna().all()
    again = study_primitives(cache, _study_requests(), METRICS, settings)
    assert {t: a.key for t, a in again.items()} == {t: a.key for t, a in artefacts.items()}
    other = study_primitives(cache, _study_requests(), METRICS, dataclasses.replace(settings, bins=41))
    assert other["dense"].key != artefacts["dense"].key  # B keys the artefact


def test_null_n_and_m_follow_the_study_and_bad_settings_are_refused():
    request = _study_requests()["dense"]
    family = PrimitivesSettings().request(request)
    assert (family.settings.policies, family.settings.episodes, family.backend) == (12, 5, "batched")
    assert isinstance(family.network, PrimitiveSpec)
    assert PrimitivesSettings().request(_study_requests()["pendulum"]) is None
    with pytest.raises(ConfigError, match="primitives.policies must be an integer >= 2 or null"):
        PrimitivesSettings(policies=1).validate()
    with pytest.raises(ConfigError, match="primitives.policies must be at least 2 × primitives.batches = 10"):
        PrimitivesSettings(policies=6).validate()
    with pytest.raises(ConfigError, match="primitives.network.family must be 'dmp', got 'mlp'"):
        PrimitivesSettings.from_config({"network": {"hidden": [4]}})
    with pytest.raises(ConfigError, match="primitives.bins must be an integer >= 2 or null"):
        PrimitivesSettings.from_config({"bins": 1})
    built = PrimitivesSettings.from_config({"network": {"family": "dmp", "basis": 4}, "prior": {"kind": "uniform"},
                                            "policies": 30})
    assert built.network == PrimitiveSpec(basis=4) and built.prior.kind == "uniform" and built.policies == 30
