"""Results of older code are never served: every stage key holds a fingerprint of the code that computes it."""

from __future__ import annotations

from taskcomplexity.pipeline import keys


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
    rwg = keys._closure("taskcomplexity.pipeline.rwg_stage")
    # the physics kernel is imported by a function of the RWG runner, three imports away
    assert {"taskcomplexity.tasks.dynamics", "taskcomplexity.tasks.step_kernel", "taskcomplexity.policies",
            "taskcomplexity.seeding", "taskcomplexity.rwg.gym_backend"} <= rwg
    assert not any(m.startswith(("taskcomplexity.report", "taskcomplexity.rl")) for m in rwg)
    sac = keys._closure("taskcomplexity.pipeline.sac_stage")
    assert "taskcomplexity.rl.train" in sac and "taskcomplexity.tasks.batched" not in sac


def test_every_stage_key_holds_its_code_fingerprint(monkeypatch):
    payload = {"x": 1}
    before = keys.stage_key("rwg", 1, payload)
    monkeypatch.setattr(keys, "code_fingerprint", lambda module: "code of another version")
    assert keys.stage_key("rwg", 1, payload) != before
