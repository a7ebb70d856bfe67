"""The random policy family of RWG: MLPs whose weights are drawn from a prior, batched over policies.

A batch of P policies is a list of per-layer tensors with a leading policy dimension, so one forward
pass over all P policies and their environments costs one batched matmul per layer.
"""

from __future__ import annotations

import dataclasses
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import torch

from taskcomplexity.errors import ConfigError
from taskcomplexity.seeding import policy_generator

PRIOR_KINDS = ("normal", "uniform", "xavier_normal", "xavier_uniform")


@dataclass(frozen=True)
class NetworkSpec:
    """obs → hidden[0] → ReLU → … → n_act → tanh.

    Attributes
    ----------
    hidden : tuple of int
        Hidden layer widths.
    bias : bool
        Whether layers have biases. Biases follow PyTorch's default ``nn.Linear`` initialisation,
        U(±1/√fan_in), whatever the weight prior (as in the reference variants).
    """

    hidden: tuple[int, ...] = (32, 32)
    bias: bool = False

    def validate(self) -> None:
        if not self.hidden or any(h < 1 for h in self.hidden):
            raise ConfigError(f"network.hidden must be a non-empty list of integers >= 1, got {list(self.hidden)}")

    def layer_sizes(self, observation_size: int, action_size: int) -> list[tuple[int, int]]:
        sizes = [observation_size, *self.hidden, action_size]
        return list(zip(sizes[:-1], sizes[1:], strict=True))


@dataclass(frozen=True)
class PriorSpec:
    """The weight prior p(θ).

    Attributes
    ----------
    kind : {'normal', 'uniform', 'xavier_normal', 'xavier_uniform'}
    variance : float
        Variance of ``normal``.
    low, high : float
        Bounds of ``uniform``.
    """

    kind: str = "normal"
    variance: float = 1.0
    low: float = -1.0
    high: float = 1.0

    def validate(self) -> None:
        if self.kind not in PRIOR_KINDS:
            raise ConfigError(f"prior.kind must be one of {list(PRIOR_KINDS)}, got {self.kind!r}")
        if not self.variance > 0:
            raise ConfigError(f"prior.variance must be > 0, got {self.variance}")
        if not self.low < self.high:
            raise ConfigError(f"prior.low must be < prior.high, got low={self.low}, high={self.high}")

    def draw(self, rng: np.random.Generator, fan_in: int, fan_out: int) -> np.ndarray:
        """A (fan_out, fan_in) weight matrix (PyTorch's ``nn.Linear.weight`` layout)."""
        shape = (fan_out, fan_in)
        if self.kind == "normal":
            return rng.normal(0.0, math.sqrt(self.variance), shape)
        if self.kind == "uniform":
            return rng.uniform(self.low, self.high, shape)
        if self.kind == "xavier_normal":
            return rng.normal(0.0, math.sqrt(2.0 / (fan_in + fan_out)), shape)
        bound = math.sqrt(6.0 / (fan_in + fan_out))
        return rng.uniform(-bound, bound, shape)


@dataclass
class PolicyBatch:
    """P random MLP policies.

    Attributes
    ----------
    weights : list of Tensor (P, fan_in, fan_out)
    biases : list of Tensor (P, 1, fan_out) or None
    indices : ndarray (P,)
        Sampling indices n of the policies.
    """

    weights: list[torch.Tensor]
    biases: list[torch.Tensor] | None
    indices: np.ndarray

    def unit_outputs(self, outputs: np.ndarray, box: bool) -> np.ndarray:
        """The outputs a backend decodes into actions (the outputs of :meth:`act`, tanh-squashed)."""
        return outputs

    def __len__(self) -> int:
        return len(self.indices)

    def act(self, observations: torch.Tensor) -> torch.Tensor:
        """Deterministic actions.

        Parameters
        ----------
        observations : Tensor (P, E, obs_size)
            E environments per policy.

        Returns
        -------
        Tensor (P, E, act_size) in (−1, 1).
        """
        x = observations.numpy()
        out = np.empty(x.shape[:2] + (self.weights[-1].shape[-1],))
        n_pol = x.shape[0]
        # A few policies at a time, so that the activations stay in cache, on every core; every
        # policy's arithmetic is the same whatever the split (one stacked-matmul slice each).
        step = max(1, CACHE_ENVIRONMENTS // max(1, x.shape[1]))
        parts = np.linspace(0, n_pol, min(_workers(), -(-n_pol // step)) + 1).round().astype(int)
        work = [(a, b, step) for a, b in zip(parts[:-1], parts[1:], strict=True) if b > a]
        if len(work) == 1:
            self._forward(x, out, *work[0])
        else:
            list(_pool().map(lambda job: self._forward(x, out, *job), work))
        return torch.from_numpy(out)

    def _forward(self, x: np.ndarray, out: np.ndarray, start: int, stop: int, step: int) -> None:
        # NumPy's stacked matmul runs float64 batched products 2-3× faster than torch.bmm on this
        # CPU (bench/bench_rwg.py); the arrays are shared, not copied.
        last = len(self.weights) - 1
        for a in range(start, stop, step):
            b = min(a + step, stop)
            h = x[a:b]
            for i, w in enumerate(self.weights):
                h = np.matmul(h, w.numpy()[a:b])
                if self.biases is not None:
                    h += self.biases[i].numpy()[a:b]
                h = np.maximum(h, 0.0, out=h) if i < last else np.tanh(h, out=h)
            out[a:b] = h


CACHE_ENVIRONMENTS = 2048  # environments whose activations are computed together (fits in L2)
_POOL: list[ThreadPoolExecutor] = []


def _workers() -> int:
    return max(1, min(os.cpu_count() or 1, torch.get_num_threads()))


def _pool() -> ThreadPoolExecutor:
    """Threads for the policy forward pass (NumPy's matmul releases the GIL)."""
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(_workers(), thread_name_prefix="policy"))
    return _POOL[0]


def policy_parameters(
    network: NetworkSpec, prior: PriorSpec, observation_size: int, action_size: int, seed: int, policy: int
) -> list[tuple[np.ndarray, np.ndarray | None]]:
    """θₙ: per layer, the (fan_out, fan_in) weight and the (fan_out,) bias (or None)."""
    rng = policy_generator(seed, policy)
    layers = []
    for fan_in, fan_out in network.layer_sizes(observation_size, action_size):
        weight = prior.draw(rng, fan_in, fan_out)
        bias = None
        if network.bias:
            bound = 1.0 / math.sqrt(fan_in)
            bias = rng.uniform(-bound, bound, fan_out)
        layers.append((weight, bias))
    return layers


def sample_policies(
    network: NetworkSpec,
    prior: PriorSpec,
    observation_size: int,
    action_size: int,
    seed: int,
    indices: np.ndarray,
    dtype: torch.dtype = torch.float64,
) -> PolicyBatch:
    """Draw θₙ for every n in ``indices`` and stack them into a :class:`PolicyBatch`."""
    per_policy = [policy_parameters(network, prior, observation_size, action_size, seed, int(n)) for n in indices]
    n_layers = len(per_policy[0])
    weights = [
        torch.as_tensor(np.stack([p[i][0].T for p in per_policy]), dtype=dtype).contiguous() for i in range(n_layers)
    ]
    biases = None
    if network.bias:
        biases = [
            torch.as_tensor(np.stack([p[i][1] for p in per_policy]), dtype=dtype)[:, None, :] for i in range(n_layers)
        ]
    return PolicyBatch(weights=weights, biases=biases, indices=np.asarray(indices))


def select_policies(batch: PolicyBatch, rows: np.ndarray) -> PolicyBatch:
    """The policies at positions ``rows`` of ``batch`` (copies of their parameters)."""
    index = torch.from_numpy(np.asarray(rows, dtype=np.int64))
    return dataclasses.replace(
        batch,
        weights=[w[index] for w in batch.weights],
        biases=None if batch.biases is None else [b[index] for b in batch.biases],
        indices=batch.indices[np.asarray(rows)],
    )


def select_policy(batch: PolicyBatch, i: int) -> PolicyBatch:
    """The i-th policy of ``batch`` as a batch of one."""
    return PolicyBatch(
        weights=[w[i : i + 1] for w in batch.weights],
        biases=None if batch.biases is None else [b[i : i + 1] for b in batch.biases],
        indices=batch.indices[i : i + 1],
    )
