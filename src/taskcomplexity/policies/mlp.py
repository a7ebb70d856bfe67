"""The random policy family of RWG: MLPs whose weights are drawn from a prior, batched over policies.

A batch of P policies is a list of per-layer tensors with a leading policy dimension, so one forward
pass over all P policies and their environments costs one batched matmul per layer. Kernels that run
the policies themselves (the batched reaching backend's fused rollout) take them packed into one
float64 row per policy (:meth:`PolicyBatch.packed`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import weakref
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from taskcomplexity.errors import ConfigError
from taskcomplexity.seeding import policy_generator

if TYPE_CHECKING:  # torch is imported by the functions that build and run the policies
    import torch

PRIOR_KINDS = ("normal", "uniform", "xavier_normal", "xavier_uniform")


ACTIVATIONS = ("relu", "tanh")
OUTPUTS = ("tanh", "linear")


def _identity(spec, added: dict) -> dict:
    """The fields of ``spec`` for cache keys; ``added`` fields (newer than the paper's runs) only when set.

    Omitting a newer field at its default keeps every key computed before it existed.
    """
    fields = {f.name: getattr(spec, f.name) for f in dataclasses.fields(spec)}
    return {k: v for k, v in fields.items() if k not in added or v != added[k]}


@dataclass(frozen=True)
class NetworkSpec:
    """obs [, 1] → hidden[0] → activation → … → n_act → output.

    The paper's family (the default) is ReLU hidden layers and a tanh output; the original PIC/POIC
    family (Furuta et al. 2021) is 0–2 tanh hidden layers, a linear output and, optionally, a constant
    input 1.0 as its bias (``conf/network/pic_*.yaml``).

    Attributes
    ----------
    hidden : tuple of int
        Hidden layer widths (empty: a linear policy).
    bias : bool
        Whether layers have biases. Biases follow PyTorch's default ``nn.Linear`` initialisation,
        U(±1/√fan_in), whatever the weight prior (as in the reference variants).
    activation : {'relu', 'tanh'}
        Hidden activation.
    input_bias : bool
        Append a constant 1.0 to the observation: the first layer's weights on it, drawn from the
        prior like every other weight, are the network's bias (the original family's bias).
    output : {'tanh', 'linear'}
        Output activation. ``linear``: Discrete actions are the argmax of the raw outputs, Box actions
        decode tanh(output), i.e. high·tanh(output) for symmetric bounds (as in the original family).
    family : str
        ``mlp`` (:mod:`taskcomplexity.policies.families` declares the others).
    """

    hidden: tuple[int, ...] = (32, 32)
    bias: bool = False
    activation: str = "relu"
    input_bias: bool = False
    output: str = "tanh"
    family: str = "mlp"

    ADDED: ClassVar[dict] = {"activation": "relu", "input_bias": False, "output": "tanh", "family": "mlp"}

    def validate(self) -> None:
        if self.family != "mlp":
            raise ConfigError(f"network.family must be 'mlp' for an MLP, got {self.family!r}")
        if any(h < 1 for h in self.hidden):
            raise ConfigError(f"network.hidden must be a list of integers >= 1 (empty: no hidden layer), "
                              f"got {list(self.hidden)}")
        if self.activation not in ACTIVATIONS:
            raise ConfigError(f"network.activation must be one of {list(ACTIVATIONS)}, got {self.activation!r}")
        if self.output not in OUTPUTS:
            raise ConfigError(f"network.output must be one of {list(OUTPUTS)}, got {self.output!r}")

    def layer_sizes(self, observation_size: int, action_size: int) -> list[tuple[int, int]]:
        sizes = [observation_size + int(self.input_bias), *self.hidden, action_size]
        return list(zip(sizes[:-1], sizes[1:], strict=True))

    def identity(self) -> dict:
        """The fields that key the returns (the newer ones only when they differ from their defaults), and the
        forward pass's tanh where it is not NumPy's (:func:`taskcomplexity.policies.tanh.implementation`: the last
        bits of its values differ; every network of the family computes a tanh, in its units or its output)."""
        from taskcomplexity.policies.tanh import NUMPY, implementation

        fields = _identity(self, self.ADDED)
        if implementation() != NUMPY:
            fields["tanh"] = implementation()
        return fields

    @property
    def tag(self) -> str:
        """Short name in run labels, e.g. 'mlp32x32+b'."""
        return "mlp" + "x".join(map(str, self.hidden)) + ("+b" if self.bias else "")

    def describe(self) -> str:
        """E.g. 'MLP 64×64, tanh hidden, linear output, without biases' (the report's methods box)."""
        hidden = "×".join(map(str, self.hidden)) or "linear (no hidden layer)"
        bias = "a constant input 1.0 as bias" if self.input_bias else ("with" if self.bias else "without") + " biases"
        return f"MLP {hidden}, {self.activation} hidden, {self.output} output, {bias}"

    def working_floats(self, observation_size: int, action_size: int, max_steps: int) -> int:
        """Floats of activations and temporaries one environment holds during a forward pass."""
        return 4 * (max(self.hidden, default=0) + observation_size + 4 * action_size + 16)

    def sample(self, task, prior: PriorSpec, seed: int, indices: np.ndarray) -> PolicyBatch:
        """θₙ for every n in ``indices``, sized for ``task``'s observations and actions (:func:`sample_policies`)."""
        return sample_policies(self, prior, task.observation_size, task.action_size, seed, indices)


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
    gain : float
        Gain of the Xavier kinds: σ = gain·√(2/(fan_in+fan_out)), bound = gain·√(6/(fan_in+fan_out)).
        1 is Glorot & Bengio's; 5/3 is PyTorch's gain for tanh, the original PIC/POIC family's.
    """

    kind: str = "normal"
    variance: float = 1.0
    low: float = -1.0
    high: float = 1.0
    gain: float = 1.0

    ADDED: ClassVar[dict] = {"gain": 1.0}

    def identity(self) -> dict:
        """The fields that key the returns (the newer ones only when they differ from their defaults)."""
        return _identity(self, self.ADDED)

    def validate(self) -> None:
        if self.kind not in PRIOR_KINDS:
            raise ConfigError(f"prior.kind must be one of {list(PRIOR_KINDS)}, got {self.kind!r}")
        if not self.variance > 0:
            raise ConfigError(f"prior.variance must be > 0, got {self.variance}")
        if not self.low < self.high:
            raise ConfigError(f"prior.low must be < prior.high, got low={self.low}, high={self.high}")
        if not self.gain > 0:
            raise ConfigError(f"prior.gain must be > 0, got {self.gain}")

    def draw(self, rng: np.random.Generator, fan_in: int, fan_out: int) -> np.ndarray:
        """A (fan_out, fan_in) weight matrix (PyTorch's ``nn.Linear.weight`` layout)."""
        shape = (fan_out, fan_in)
        if self.kind == "normal":
            return rng.normal(0.0, math.sqrt(self.variance), shape)
        if self.kind == "uniform":
            return rng.uniform(self.low, self.high, shape)
        if self.kind == "xavier_normal":
            return rng.normal(0.0, self.gain * math.sqrt(2.0 / (fan_in + fan_out)), shape)
        bound = self.gain * math.sqrt(6.0 / (fan_in + fan_out))
        return rng.uniform(-bound, bound, shape)


@dataclass
class PolicyBatch:
    """P random MLP policies.

    :meth:`act` splits large batches over threads of a pool the batch owns: :meth:`close` it (or use
    the batch as a context manager) when done; a batch that is garbage collected shuts its pool down.

    Attributes
    ----------
    weights : list of Tensor (P, fan_in, fan_out)
    biases : list of Tensor (P, 1, fan_out) or None
    indices : ndarray (P,)
        Sampling indices n of the policies.
    activation, input_bias, output
        As in :class:`NetworkSpec`.
    """

    weights: list[torch.Tensor]
    biases: list[torch.Tensor] | None
    indices: np.ndarray
    activation: str = "relu"
    input_bias: bool = False
    output: str = "tanh"
    _threads: ThreadPoolExecutor | None = field(default=None, init=False, repr=False, compare=False)

    def unit_outputs(self, outputs: np.ndarray, box: bool) -> np.ndarray:
        """The outputs of :meth:`act` as a backend decodes them: in (−1, 1) for a Box action space.

        A linear output is squashed by tanh for Box spaces (then decoded affinely onto [low, high],
        which is high·tanh(output) for symmetric bounds); Discrete spaces take the argmax of the raw
        outputs.
        """
        if box and self.output == "linear":
            from taskcomplexity.policies.tanh import tanh

            return tanh(outputs)
        return outputs

    def __len__(self) -> int:
        return len(self.indices)

    def __enter__(self) -> PolicyBatch:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Shut down the threads of :meth:`act` (started again if :meth:`act` is called later)."""
        threads, self._threads = self._threads, None
        if threads is not None:
            threads.shutdown()

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The policies' parameters as one float64 row per policy, for kernels that run the MLPs.

        Returns
        -------
        weights : ndarray (P, S) float64
            Per layer, the weight as (fan_out, fan_in) row-major (``nn.Linear``'s layout), then its bias
            (fan_out) when the network has biases.
        layer_sizes : ndarray (L + 1,) int64
            The first layer's fan_in (observation size, plus 1 with ``input_bias``), then each fan_out.
        """
        n_pol = len(self)
        parts = []
        for i, w in enumerate(self.weights):
            parts.append(w.numpy().transpose(0, 2, 1).reshape(n_pol, -1))
            if self.biases is not None:
                parts.append(self.biases[i].numpy().reshape(n_pol, -1))
        sizes = [self.weights[0].shape[1], *(w.shape[2] for w in self.weights)]
        weights = np.ascontiguousarray(np.concatenate(parts, axis=1), dtype=np.float64)
        return weights, np.asarray(sizes, dtype=np.int64)

    def select(self, rows) -> PolicyBatch:
        """The policy at position ``rows`` (an int: a batch of one) or the policies at positions ``rows``."""
        return select_policy(self, rows) if isinstance(rows, (int, np.integer)) else select_policies(self, rows)

    def begin(self, observations: torch.Tensor) -> None:
        """Nothing to plan: an MLP acts on each observation alone (a movement primitive plans its episodes)."""
        return None

    def respond(self, observations: torch.Tensor, state: None = None) -> tuple[torch.Tensor, None]:
        """(:meth:`act`, the unchanged state): the stepping interface every policy family shares."""
        return self.act(observations), state

    def act(self, observations: torch.Tensor) -> torch.Tensor:
        """Deterministic actions.

        Parameters
        ----------
        observations : Tensor (P, E, obs_size)
            E environments per policy.

        Returns
        -------
        Tensor (P, E, act_size): in (−1, 1) for the tanh output, raw for the linear one.
        """
        x = observations.numpy()
        if self.input_bias:
            x = np.concatenate([x, np.ones(x.shape[:2] + (1,))], axis=2)
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
            list(self._pool().map(lambda job: self._forward(x, out, *job), work))
        import torch

        return torch.from_numpy(out)

    def _pool(self) -> ThreadPoolExecutor:
        """Threads for the forward pass (NumPy's matmul releases the GIL), started on first use."""
        if self._threads is None:
            self._threads = ThreadPoolExecutor(_workers(), thread_name_prefix="policy")
            weakref.finalize(self, self._threads.shutdown, wait=False)
        return self._threads

    def _forward(self, x: np.ndarray, out: np.ndarray, start: int, stop: int, step: int) -> None:
        # NumPy's stacked matmul runs float64 batched products 2-3× faster than torch.bmm on this
        # CPU (bench/bench_rwg.py); the arrays are shared, not copied. tanh is NumPy's where NumPy has its AVX-512
        # loop, else a numba kernel of the CPU's vector width (taskcomplexity.policies.tanh).
        from taskcomplexity.policies.tanh import tanh

        last = len(self.weights) - 1
        for a in range(start, stop, step):
            b = min(a + step, stop)
            h = x[a:b]
            for i, w in enumerate(self.weights):
                h = np.matmul(h, w.numpy()[a:b])
                if self.biases is not None:
                    h += self.biases[i].numpy()[a:b]
                if i < last:
                    h = np.maximum(h, 0.0, out=h) if self.activation == "relu" else tanh(h, out=h)
                elif self.output == "tanh":
                    h = tanh(h, out=h)
            out[a:b] = h


CACHE_ENVIRONMENTS = 2048  # environments whose activations are computed together (fits in L2)


def _workers() -> int:
    import torch

    return max(1, min(os.cpu_count() or 1, torch.get_num_threads()))


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
    dtype: torch.dtype | None = None,
) -> PolicyBatch:
    """Draw θₙ for every n in ``indices`` and stack them into a :class:`PolicyBatch` (of ``dtype``, float64 by
    default)."""
    import torch

    dtype = torch.float64 if dtype is None else dtype
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
    return PolicyBatch(weights=weights, biases=biases, indices=np.asarray(indices), activation=network.activation,
                       input_bias=network.input_bias, output=network.output)


def select_policies(batch: PolicyBatch, rows: np.ndarray) -> PolicyBatch:
    """The policies at positions ``rows`` of ``batch`` (copies of their parameters)."""
    import torch

    index = torch.from_numpy(np.asarray(rows, dtype=np.int64))
    return dataclasses.replace(
        batch,
        weights=[w[index] for w in batch.weights],
        biases=None if batch.biases is None else [b[index] for b in batch.biases],
        indices=batch.indices[np.asarray(rows)],
    )


def select_policy(batch: PolicyBatch, i: int) -> PolicyBatch:
    """The i-th policy of ``batch`` as a batch of one."""
    return dataclasses.replace(
        batch,
        weights=[w[i : i + 1] for w in batch.weights],
        biases=None if batch.biases is None else [b[i : i + 1] for b in batch.biases],
        indices=batch.indices[i : i + 1],
    )
