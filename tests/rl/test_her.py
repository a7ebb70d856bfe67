"""HER relabels a fraction her_ratio of the sampled transitions with future achieved goals, re-scored by the task."""

from __future__ import annotations

import math

import pytest
import torch

from taskcomplexity.rl.factories import make_env
from taskcomplexity.rl.her import make_her_replay_buffer
from taskcomplexity.rl.train import sample_minibatches
from taskcomplexity.tasks.goal_env import compute_reward, goal_reached
from taskcomplexity.tasks.spec import make_task

STEPS = 400  # random-action transitions in the buffer: 8+ episodes of at most 50 steps
RATIO = 0.8
STORED = [
    "observation",
    "desired_goal",
    "action",
    ("next", "observation"),
    ("next", "desired_goal"),
    ("next", "achieved_goal"),
    ("next", "reward"),
    ("next", "done"),
    ("next", "terminated"),
    ("next", "truncated"),
]


def _filled_buffer(task, seed: int = 0):
    """A HER buffer holding STEPS consecutive random-action transitions of one environment."""
    env = make_env(task, 1, goal_conditioned=True)
    try:
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            start = env.reset(seed=[seed])
            data = env.rollout(STEPS, auto_reset=False, tensordict=start, break_when_any_done=False)
    finally:
        env.close()
    buffer = make_her_replay_buffer(task, STEPS, her_ratio=RATIO, strategy="future")
    buffer.extend(data[0].select(*STORED))
    return buffer


def _episode_end(done: torch.Tensor) -> torch.Tensor:
    """For every storage index, the index of the last transition of its episode."""
    ends = torch.empty(len(done), dtype=torch.long)
    last = len(done) - 1
    for i in range(len(done) - 1, -1, -1):
        if done[i]:
            last = i
        ends[i] = last
    return ends


@pytest.mark.parametrize(("arm", "reward"), [("one_link_1m0", "sparse"), ("two_link", "sparse"), ("two_link", "dense")])
def test_relabelled_transitions_carry_a_future_goal_and_the_task_reward_for_it(arm, reward):
    task = make_task(arm, reward)
    buffer = _filled_buffer(task)
    stored = buffer[:]
    ends = _episode_end(stored["next", "done"].squeeze(-1))
    assert int(stored["next", "done"].sum()) >= 5, "the buffer should hold several whole episodes"
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(1)
        batch, info = buffer.sample(6400, return_info=True)
    index = info["index"]
    original = stored[index]
    relabelled = (batch["desired_goal"] != original["desired_goal"]).any(-1)

    # exactly the configured fraction is relabelled (torchrl relabels floor(ratio · n) rows)
    assert int(relabelled.sum()) == math.floor(RATIO * 6400)

    new = batch[relabelled]
    # the goal seen at the next state is relabelled too
    torch.testing.assert_close(new["next", "desired_goal"], new["desired_goal"], rtol=0, atol=0)
    # "future": the new goal is an end-effector position reached at a step t' ∈ [t, end of t's episode]
    achieved = stored["next", "achieved_goal"]
    for row, t in zip(new.unbind(0), index[relabelled].tolist(), strict=True):
        candidates = achieved[t : int(ends[t]) + 1]
        assert (candidates == row["desired_goal"]).all(-1).any(), f"goal of row {t} is not a future achieved goal"
    # re-scored with the task's own rules (float32 storage: 1e-5 covers the rounding of −d² − Σa²)
    expected = compute_reward(task, new["next", "achieved_goal"], new["desired_goal"])
    if reward == "dense":
        expected = expected - new["action"].pow(2).sum(-1)
    torch.testing.assert_close(new["next", "reward"].squeeze(-1), expected, rtol=0, atol=1e-5)
    reached = goal_reached(task, new["next", "achieved_goal"], new["desired_goal"])
    assert torch.equal(new["next", "terminated"].squeeze(-1), reached)
    assert torch.equal(new["next", "done"], new["next", "terminated"] | new["next", "truncated"])
    assert reached.any(), "some relabelled goals are reached (at least those with t' = t)"

    # the other rows are returned as stored
    kept = batch[~relabelled]
    for key in STORED:
        assert torch.equal(kept[key], original[~relabelled][key]), key


def test_each_minibatch_holds_her_ratio_of_relabelled_rows_within_sampling_error():
    task = make_task("one_link_1m0", "sparse")
    buffer = _filled_buffer(task, seed=2)
    stored = buffer[:]
    updates, batch_size = 100, 64
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(3)
        minibatches = sample_minibatches(
            [buffer], updates=updates, batch_size=batch_size, keys=[*STORED, "index"], shuffle=True
        )[0]
    original_goal = stored["desired_goal"][minibatches["index"]]
    counts = (minibatches["desired_goal"] != original_goal).any(-1).sum(-1).double()  # (updates,)

    n = updates * batch_size
    assert counts.sum() == math.floor(RATIO * n)  # over the whole draw: exactly the ratio
    # Per minibatch the count is hypergeometric (64 rows out of 6400, 5120 of them relabelled):
    # mean 51.2, sd ≈ 3.18. Every minibatch lies within 5 sd (probability of a miss < 1e-4 over 100),
    # and the spread matches the hypergeometric one to within 30 % (4 sd of a 100-sample sd estimate):
    # without the shuffle the leading 80 minibatches would be fully relabelled (sd ≈ 26).
    mean = RATIO * batch_size
    sd = math.sqrt(batch_size * RATIO * (1 - RATIO) * (n - batch_size) / (n - 1))
    assert ((counts - mean).abs() <= 5 * sd).all()
    assert 0.7 * sd <= counts.std() <= 1.3 * sd
