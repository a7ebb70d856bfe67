"""Batched random policies: one forward pass over P policies equals P separate MLPs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from taskcomplexity.policies import NetworkSpec, PriorSpec, policy_parameters, sample_policies, select_policy


@pytest.mark.parametrize("network", [NetworkSpec(), NetworkSpec(hidden=(64,), bias=True)])
def test_batched_forward_pass_equals_each_policy_on_its_own(network):
    obs_size, act_size, seed = 10, 2, 3
    indices = np.arange(5, 26)
    batch = sample_policies(network, PriorSpec(), obs_size, act_size, seed, indices)
    x = np.random.default_rng(0).normal(0.0, 2.0, (len(indices), 300, obs_size))
    actions = batch.act(torch.from_numpy(x)).numpy()
    assert actions.shape == (len(indices), 300, act_size)
    for i, n in enumerate(indices):
        h = x[i]
        layers = policy_parameters(network, PriorSpec(), obs_size, act_size, seed, int(n))
        for k, (weight, bias) in enumerate(layers):
            h = h @ weight.T + (0.0 if bias is None else bias)
            h = np.maximum(h, 0.0) if k < len(layers) - 1 else np.tanh(h)
        np.testing.assert_allclose(actions[i], h, rtol=0, atol=1e-12)
        # and the same policy alone, as the PyBullet reference runs it (BLAS may round differently per shape)
        alone = select_policy(batch, i).act(torch.from_numpy(x[i : i + 1, :7])).numpy()
        np.testing.assert_allclose(alone[0], actions[i, :7], rtol=0, atol=1e-12)
