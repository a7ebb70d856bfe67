"""Snapshots of SAC actors along training, as policies of the RWG family.

The actor's deterministic action is low + (tanh(loc) + 1)·(high − low)/2 with loc the first n_act
outputs of a ReLU MLP with biases (``factories.make_actor_critic``), which is exactly an RWG policy
of :class:`~taskcomplexity.policies.mlp.NetworkSpec` (hidden, bias=True, relu, tanh output) whose last
layer keeps the loc rows only, decoded by :func:`~taskcomplexity.tasks.base.decode_actions`. A
snapshot can therefore run on every RWG backend, be perturbed like any weight vector, and have its
occupancy recorded like a random policy's.

A SAC artefact stores its snapshots in ``actors.npz`` (:meth:`ActorSnapshots.save`): the training
step of each snapshot and, per layer, the weights (K, S, fan_in, fan_out) and biases (K, S, fan_out)
of the S seeds, in the actor's own float32.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from taskcomplexity.policies.mlp import PolicyBatch
from taskcomplexity.rl.layers import SeedBatchedLinear

PERTURBATION_STREAM = 0x1EA4
"""Spawn-key label of the perturbations ε of :meth:`ActorSnapshots.around` (apart from every other stream)."""


def actor_layers(actor: torch.nn.Module, action_size: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The actor's current parameters per layer: weights (S, fan_in, fan_out), biases (S, fan_out).

    The last layer keeps its first ``action_size`` outputs (loc; the rest parameterise the scale).
    """
    layers = [m for m in actor.modules() if isinstance(m, SeedBatchedLinear)]
    if not layers:
        raise ValueError("actor_layers: the actor has no SeedBatchedLinear layer")
    weights, biases = [], []
    with torch.no_grad():
        for i, layer in enumerate(layers):
            w = layer.weight.transpose(1, 2) if layer.transposed else layer.weight  # (S, in, out)
            b = layer.bias[:, 0, :]
            if i == len(layers) - 1:
                w, b = w[..., :action_size], b[..., :action_size]
            weights.append(w.detach().cpu().numpy().copy())
            biases.append(b.detach().cpu().numpy().copy())
    return weights, biases


@dataclass(frozen=True)
class ActorSnapshots:
    """K snapshots of the actors of S seeds.

    Attributes
    ----------
    steps : ndarray (K,) int64
        Environment steps per seed at each snapshot, increasing.
    seeds : ndarray (S,) int64
    weights : list of ndarray (K, S, fan_in, fan_out), one per layer
    biases : list of ndarray (K, S, fan_out), one per layer
    """

    steps: np.ndarray
    seeds: np.ndarray
    weights: list[np.ndarray]
    biases: list[np.ndarray]

    @classmethod
    def stack(cls, steps, seeds, layers: list[tuple[list[np.ndarray], list[np.ndarray]]]) -> ActorSnapshots:
        """From per-snapshot :func:`actor_layers` results, in step order."""
        n_layers = len(layers[0][0])
        return cls(np.asarray(steps, dtype=np.int64), np.asarray(seeds, dtype=np.int64),
                   [np.stack([w[i] for w, _ in layers]) for i in range(n_layers)],
                   [np.stack([b[i] for _, b in layers]) for i in range(n_layers)])

    @classmethod
    def join_seeds(cls, parts: list[ActorSnapshots | None]) -> ActorSnapshots | None:
        """Seeds trained one after the other, joined along the seed axis (their steps must agree)."""
        if not parts or any(p is None for p in parts):
            return None
        if any(not np.array_equal(p.steps, parts[0].steps) for p in parts):
            raise ValueError("ActorSnapshots.join_seeds: the seeds' snapshot steps differ")
        return cls(parts[0].steps, np.concatenate([p.seeds for p in parts]),
                   [np.concatenate([p.weights[i] for p in parts], axis=1) for i in range(len(parts[0].weights))],
                   [np.concatenate([p.biases[i] for p in parts], axis=1) for i in range(len(parts[0].biases))])

    def save(self, path: Path) -> None:
        arrays = {"steps": self.steps, "seeds": self.seeds}
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            arrays[f"weight_{i}"], arrays[f"bias_{i}"] = w, b
        with open(path, "wb") as handle:
            np.savez(handle, **arrays)

    @classmethod
    def load(cls, path: Path) -> ActorSnapshots:
        with np.load(path) as data:
            n_layers = sum(1 for k in data.files if k.startswith("weight_"))
            return cls(data["steps"], data["seeds"], [data[f"weight_{i}"] for i in range(n_layers)],
                       [data[f"bias_{i}"] for i in range(n_layers)])

    def policies(self, snapshot: int = -1) -> PolicyBatch:
        """The S seeds' actors at ``snapshot`` (default: the last, the trained actor) as RWG policies.

        ``indices`` are the seeds' positions 0 … S−1; outputs are tanh(loc) in (−1, 1).
        """
        weights = [torch.as_tensor(w[snapshot], dtype=torch.float64).contiguous() for w in self.weights]
        biases = [torch.as_tensor(b[snapshot], dtype=torch.float64)[:, None, :] for b in self.biases]
        return PolicyBatch(weights=weights, biases=biases, indices=np.arange(len(self.seeds)),
                           activation="relu", input_bias=False, output="tanh")

    def around(self, snapshot: int, *, sigma: float, seed: int, indices: np.ndarray,
               seed_index: int = 0) -> PolicyBatch:
        """Policies θₙ = θ_k + σ·εₙ, εₙ ~ N(0, I) over every parameter (weights and biases) of the actor.

        Parameters
        ----------
        snapshot : int
            k, the snapshot's position (0 … K−1).
        sigma : float
            σ ≥ 0 (0: copies of the actor).
        seed : int
            Seed of the perturbations; εₙ depends on (seed, k, n) only, not on which other n are drawn.
        indices : ndarray of int
            n of each policy (its reset streams in RWG, too).
        seed_index : int
            Which SAC seed's actor θ_k is (position in :attr:`seeds`).
        """
        rows = []
        k = int(np.arange(len(self.steps))[snapshot])
        centre = [(w[k, seed_index].astype(np.float64), b[k, seed_index].astype(np.float64))
                  for w, b in zip(self.weights, self.biases, strict=True)]
        for n in np.asarray(indices, dtype=np.int64):
            rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(PERTURBATION_STREAM, k, int(n))))
            rows.append([(w + sigma * rng.standard_normal(w.shape), b + sigma * rng.standard_normal(b.shape))
                         for w, b in centre])
        weights = [torch.from_numpy(np.stack([r[i][0] for r in rows])).contiguous() for i in range(len(centre))]
        biases = [torch.from_numpy(np.stack([r[i][1] for r in rows]))[:, None, :] for i in range(len(centre))]
        return PolicyBatch(weights=weights, biases=biases, indices=np.asarray(indices, dtype=np.int64),
                           activation="relu", input_bias=False, output="tanh")
