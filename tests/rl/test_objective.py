"""The direct SAC objective is TorchRL's SACLoss: the same losses and gradients on the same minibatch and draws.

Tolerance: float32 with other summation orders (one product over both critics instead of ``vmap``), so the losses
agree to a relative 1e-5 and every gradient element to 1e-4 of that tensor's largest element.
"""

from __future__ import annotations

import pandas as pd
import pytest
import torch

from taskcomplexity.rl import WALL_CLOCK
from taskcomplexity.rl.factories import _TaskObservation, make_actor_critic, make_env, make_loss, make_target_updater
from taskcomplexity.rl.objective import SACObjective
from taskcomplexity.tasks.spec import make_task

SEEDS = [0, 1, 2]
STEPS = 24


def _minibatch(task, goal_conditioned: bool, loss):
    """A (seeds, STEPS) batch of real transitions under random actions, some of them terminal."""
    env = make_env(task, len(SEEDS), goal_conditioned=goal_conditioned)
    try:
        first = env.reset(seed=SEEDS)
        torch.manual_seed(7)
        data = env.rollout(STEPS, break_when_any_done=False, auto_reset=False, tensordict=first)
    finally:
        env.close()
    batch = data.select(*loss.in_keys)
    batch.get("next").set("terminated", torch.rand(*batch.shape, 1) < 0.2)  # the target's (1 - terminated) acts
    return batch


@pytest.mark.parametrize(("arm", "reward", "goal_conditioned", "loss_function"), [
    ("one_link_1m0", "dense", False, "l2"),
    ("two_link", "sparse", True, "smooth_l1"),
])
def test_the_direct_objective_gives_sacloss_s_losses_and_gradients(arm, reward, goal_conditioned, loss_function):
    task = make_task(arm, reward)
    actor, critics = make_actor_critic(task, hidden_sizes=(48, 40), seeds=SEEDS, goal_conditioned=goal_conditioned)
    loss = make_loss(actor, critics, gamma=0.95, alpha=0.3, loss_function=loss_function)
    make_target_updater(loss, tau=0.005)  # as in training (the loss expects one)
    batch = _minibatch(task, goal_conditioned, loss)
    params = [*loss.actor_network_params.flatten_keys().values(), *loss.qvalue_network_params.flatten_keys().values()]

    torch.manual_seed(11)
    out = loss(batch.clone())
    reference = (out.get("loss_actor") + out.get("loss_qvalue")) * len(SEEDS)
    expected = torch.autograd.grad(reference, params)

    objective = SACObjective(loss, actor, gamma=0.95, loss_function=loss_function,
                             policy_input=_TaskObservation(task) if goal_conditioned else None)
    torch.manual_seed(11)  # the same draws, in SACLoss's order
    value = objective(batch.clone())
    got = torch.autograd.grad(value, params)

    assert value.item() == pytest.approx(reference.item(), rel=1e-5)
    assert reference.item() != pytest.approx(0.0, abs=1e-3)
    names = [*(f"actor {k}" for k in loss.actor_network_params.flatten_keys().keys()),
             *(f"critic {k}" for k in loss.qvalue_network_params.flatten_keys().keys())]
    for name, mine, theirs in zip(names, got, expected, strict=True):
        scale = theirs.abs().max().item()
        assert scale > 0, name
        assert (mine - theirs).abs().max().item() <= 1e-4 * scale, name

    torch.manual_seed(12)  # other draws: another value (the objective samples its actions)
    assert objective(batch.clone()).item() != pytest.approx(value.item(), rel=1e-6)


def test_training_with_the_direct_objective_gives_the_curves_of_training_with_sacloss(monkeypatch):
    """The old path (SACLoss's forward, as training ran it before) and the new train the 1-link dense task with the
    same seeds: the same curves, every column but the wall clock (float32 on one machine: the same bits)."""
    import taskcomplexity.rl.train as train
    from taskcomplexity.rl import SACSettings, train_sac_seeds

    settings = SACSettings(hidden_sizes=(32, 32), batch_size=32, total_steps=240, warmup_steps=80, eval_every=80,
                           eval_episodes=2, seeds=(0, 1))
    task = make_task("one_link_1m0", "dense")
    new = train_sac_seeds(task, settings, progress=False)

    def sacloss_objective(loss, actor, task, *, gamma, loss_function, goal_conditioned):
        def objective(batch):
            out = loss(batch)
            return (out.get("loss_actor") + out.get("loss_qvalue")) * len(settings.seeds)
        return objective

    monkeypatch.setattr(train, "make_objective", sacloss_objective)
    old = train_sac_seeds(task, settings, progress=False)
    numbers = [c for c in new.columns if not c.startswith(WALL_CLOCK)]
    assert new["eval/return_mean"].nunique() > 2  # the curves move
    pd.testing.assert_frame_equal(new[numbers], old[numbers])
