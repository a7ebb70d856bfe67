"""The SAC key follows from one declaration: every field that changes the curves is in it, no other."""

from __future__ import annotations

import dataclasses

from taskcomplexity.rl.settings import SACSettings
from taskcomplexity.stages.keys import stage_key
from taskcomplexity.stages.sac_stage import NUMERICS, STAGE, sac_identity
from taskcomplexity.tasks.spec import make_task

CHANGED = {  # a valid different value of every field
    "enabled": False, "hidden_sizes": (64, 64), "actor_lr": 3e-4, "critic_lr": 3e-4, "gamma": 0.9, "alpha": 0.1,
    "tau": 0.01, "loss_function": "smooth_l1", "batch_size": 32, "buffer_size": 5000, "updates_per_step": 2,
    "collect_steps": 20, "warmup_steps": 200, "eval_every": 200, "eval_episodes": 3, "total_steps": 4000,
    "budget_fraction": 0.5, "seeds": (0, 1), "train_seeds_together": False, "her": True, "her_ratio": 0.5, "her_strategy": "final",
    "checkpoint_every": 400, "num_threads": 2, "workers": 2, "device": "cpu", "backend": "batched",
    "entry": "two_link-sparse",
}
# enabled: read by the study only, it decides whether SAC runs, not what it computes; budget_fraction:
# with_budget resolves it into total_steps, which is hashed (test_settings.py checks the resolution);
# entry: which study task pipelines/sac.py trains, whose runs the study must find under its own keys;
# workers: how many runs a study trains at once, each run the same;
# device: auto and cpu are both the CPU here (the resolved device enters the key off the CPU: test below).
NOT_A_RESULT = {"enabled", "budget_fraction", "entry", "workers", "device"}


def key(settings: SACSettings) -> str:
    return stage_key(STAGE, NUMERICS, sac_identity(make_task("two_link", "sparse"), settings))


def test_every_field_that_changes_the_curves_changes_the_key_and_no_other_does():
    base = SACSettings(total_steps=2000, warmup_steps=100, eval_every=100, checkpoint_every=100)
    assert set(CHANGED) == {f.name for f in dataclasses.fields(SACSettings)}  # a new field must be declared here
    for name, value in CHANGED.items():
        changed = dataclasses.replace(base, **{name: value})
        assert (key(changed) == key(base)) == (name in NOT_A_RESULT), name


def test_checkpoint_every_and_num_threads_are_in_the_key():
    # Both change the curves (checkpoints re-seed and reset the envs; thread counts change float reductions).
    base = SACSettings(total_steps=2000)
    assert key(dataclasses.replace(base, checkpoint_every=100)) != key(dataclasses.replace(base, checkpoint_every=300))
    assert key(dataclasses.replace(base, num_threads=1)) != key(dataclasses.replace(base, num_threads=2))


def test_the_device_enters_the_key_only_off_the_cpu(monkeypatch):
    import torch

    base = SACSettings(total_steps=2000)
    on_cpu = key(base)
    assert key(dataclasses.replace(base, device="cpu")) == on_cpu  # every CPU curve keeps its key
    # a machine with a CUDA build of torch and a GPU: auto is CUDA there
    monkeypatch.setattr("taskcomplexity.rl.settings.cpu_build_of_torch", lambda: False)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert key(base) != on_cpu
    assert key(dataclasses.replace(base, device="cuda")) == key(base)
    assert key(dataclasses.replace(base, device="cpu")) == on_cpu
