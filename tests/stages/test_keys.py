"""Results of older code are never served: every stage key holds a fingerprint of the code that computes it."""

from __future__ import annotations

from taskcomplexity.stages import keys


def test_the_fingerprint_ignores_docstrings_comments_and_layout_but_not_code(tmp_path):
    original = tmp_path / "a.py"
    original.write_text('"""Doc."""\n\ndef f(x):\n    """Say."""\n    return x + 1  # one\n')
    cosmetic = tmp_path / "b.py"
    cosmetic.write_text('"""Other doc."""\n# a comment\ndef f(x):\n    return (x +\n            1)\n')
    changed = tmp_path / "c.py"
    changed.write_text('"""Doc."""\n\ndef f(x):\n    """Say."""\n    return x + 2  # one\n')
    assert keys._tree_digest(original) == keys._tree_digest(cosmetic)
    assert keys._tree_digest(original) != keys._tree_digest(changed)


def test_a_stage_fingerprint_covers_what_it_imports_at_any_depth_and_nothing_else():
    rwg = keys._closure("taskcomplexity.stages.rwg_stage")
    # the physics kernel is imported by a function of the RWG runner, three imports away
    assert {"taskcomplexity.tasks.dynamics", "taskcomplexity.tasks.step_kernel", "taskcomplexity.policies",
            "taskcomplexity.seeding", "taskcomplexity.rwg.gym_backend"} <= rwg
    assert not any(m.startswith(("taskcomplexity.report", "taskcomplexity.rl")) for m in rwg)
    sac = keys._closure("taskcomplexity.stages.sac_stage")
    assert "taskcomplexity.rl.train" in sac and "taskcomplexity.tasks.batched" not in sac


def test_every_stage_key_holds_its_code_fingerprint(monkeypatch):
    payload = {"x": 1}
    before = keys.stage_key("rwg", 1, payload)
    monkeypatch.setattr(keys, "code_fingerprint", lambda module: "code of another version")
    assert keys.stage_key("rwg", 1, payload) != before


def _one_at_a_time(settings, changed: dict, not_a_result: set, key) -> None:
    import dataclasses

    assert set(changed) == {f.name for f in dataclasses.fields(settings)}  # a new field must be declared here
    for name, value in changed.items():
        other = dataclasses.replace(settings, **{name: value})
        assert (key(other) == key(settings)) == (name in not_a_result), name


def test_metrics_and_diagnostics_keys_follow_their_declarations():
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings
    from taskcomplexity.stages.metrics_stage import MetricsSettings

    _one_at_a_time(MetricsSettings(), {"bins": 500, "temperature_range": (1e-3, 1e3), "resamples": 10, "batches": 4,
                                       "alpha": 0.05, "seed": 3, "pinned": (1000, 1000, 100_000)},
                   {"alpha", "pinned"}, lambda s: keys.stage_key("metrics", 1, s.identity()))
    # the key holds the resolved B: auto at the paper's ratio hashes as the same integer typed
    assert MetricsSettings().at_scale(400, 50).identity() == MetricsSettings(bins=400).identity()
    _one_at_a_time(DiagnosticsSettings(), {"repeats": 3, "bins_sweep": (10, 100), "subsample_fractions": (0.5, 1.0),
                                           "knn_neighbors": 4, "knn_max_samples": 1000, "knn_episodes_per_policy": 9,
                                           "seed": 2},
                   set(), lambda s: keys.stage_key("diagnostics", 1, s.identity()))
    # order of a sweep is not a setting
    assert (DiagnosticsSettings(bins_sweep=(100, 10)).identity() == DiagnosticsSettings(bins_sweep=(10, 100)).identity())


def test_the_rwg_key_follows_the_settings_declaration():
    from taskcomplexity.policies import NetworkSpec, PriorSpec
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.rwg_stage import RWGRequest
    from taskcomplexity.tasks.spec import make_task

    def key_of(task):
        return lambda s: RWGRequest(task, NetworkSpec(), PriorSpec(), s).key

    changed = {"policies": 12, "episodes": 7, "seed": 4, "chunk_policies": 3, "chunk_memory_mb": 64, "shard": 1,
               "shards": 2, "contacts": "model", "common_initial_states": True}
    split = {"chunk_policies", "chunk_memory_mb", "shard", "shards"}
    _one_at_a_time(RWGSettings(), changed, split, key_of(make_task("two_link_obstacle")))
    # the contact handling cannot change a task without the block: not in its key
    _one_at_a_time(RWGSettings(), changed, split | {"contacts"}, key_of(make_task("two_link")))
