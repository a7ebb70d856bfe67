"""The ``envpool`` backend's pools stepped in turn give the returns of one pool in lock-step, bit for bit.

:func:`taskcomplexity.rwg.envpool_backend.run_envpool` splits a batch's policies into ``POOLS`` groups, each with a
pool of its own, so that one pool steps while the next group's policies compute their actions; ``POOLS = 1`` is one
pool stepped in lock-step with the forward pass. Each environment is its policy's alone (seeded per policy), so the
order in which the pools step must change no return, no step count: on Hopper episodes end at different steps (the
groups drop policies at different times), on HalfCheetah they run to the limit, Humanoid has the largest state.
Needs the atlas extra (``pip install -e '.[atlas]'``); skipped without it.
"""

from __future__ import annotations

import numpy as np
import pytest

POLICIES = 9
"""An odd number, so that the groups differ in size."""
EPISODES = 3
STEPS = 60


@pytest.mark.parametrize(("env_id", "common"), [("Hopper-v5", False), ("HalfCheetah-v5", False),
                                                ("Humanoid-v5", False), ("Hopper-v5", True)])
def test_pools_stepped_in_turn_give_the_lock_step_returns_bit_for_bit(monkeypatch, env_id, common):
    pytest.importorskip("envpool", reason="the envpool extra is not installed")
    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    import taskcomplexity.rwg.envpool_backend as backend
    from taskcomplexity.policies.families import sample_family
    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
    from taskcomplexity.tasks.gym_task import GymTask

    task = GymTask(env_id, max_steps=STEPS)
    network = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")
    policies = sample_family(task, network, PriorSpec(), 3, np.arange(10, 10 + POLICIES))
    monkeypatch.setattr(backend, "POOLS", 1)
    returns, steps, success = backend.run_envpool(task, policies, 3, EPISODES, common)
    assert returns.shape == (POLICIES, EPISODES) and steps.min() >= 1 and not success.any()
    if env_id == "Hopper-v5" and not common:
        assert len(np.unique(steps)) > 1  # episodes end at different steps: the groups drop policies apart
    for pools in (2, 4):
        monkeypatch.setattr(backend, "POOLS", pools)
        theirs = backend.run_envpool(task, policies, 3, EPISODES, common)
        assert np.array_equal(theirs[0], returns) and np.array_equal(theirs[1], steps), pools
