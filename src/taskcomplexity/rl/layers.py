"""A linear layer holding one independent weight matrix per seed, so that several seeds train together.

Training the seeds of a task one after the other spends most of its time in Python and in small
matrix products; stacking the seeds' parameters along a leading dimension turns each layer of every
seed into one batched product (``torch.baddbmm``). The seeds stay independent: no parameter, gradient
or optimiser statistic is shared (Adam is element-wise, and each seed's loss only depends on its own
slice).

:class:`SeedBatchedLinear` is a drop-in ``layer_class`` for TorchRL's :class:`~torchrl.modules.MLP`,
so the actor and critics remain TorchRL modules.
"""

from __future__ import annotations

import math

import torch
from torch import nn

NARROW_OUTPUT = 16  # output widths below this store the weight as (S, out, in)


class SeedBatchedLinear(nn.Module):
    """``y[s] = x[s] @ W[s] + b[s]`` for each seed s.

    Parameters
    ----------
    in_features, out_features : int
    bias : bool, default True
    seeds : int, default 1
        Number of independent parameter sets S.
    device, dtype : optional

    Shapes
    ------
    Input ``(S, in)`` or ``(S, B, in)`` (or more batch dimensions after S, flattened internally);
    output ``(S, out)`` or ``(S, B, out)``. Weight ``(S, in, out)`` — or ``(S, out, in)`` for a
    narrow output (``out < NARROW_OUTPUT``), where MKL's batched product is faster on that
    layout — and bias ``(S, 1, out)``. The initialisation is :class:`torch.nn.Linear`'s
    (uniform ±1/√in for weights and biases).
    """

    def __init__(
        self,
        in_features: int,
        out_features: int,
        bias: bool = True,
        *,
        seeds: int = 1,
        device: torch.device | str | None = None,
        dtype: torch.dtype | None = None,
    ):
        super().__init__()
        if seeds < 1:
            raise ValueError(f"seeds must be >= 1, got {seeds}")
        self.in_features, self.out_features, self.seeds = in_features, out_features, seeds
        factory = {"device": device, "dtype": dtype}
        self.transposed = out_features < NARROW_OUTPUT
        shape = (seeds, out_features, in_features) if self.transposed else (seeds, in_features, out_features)
        self.weight = nn.Parameter(torch.empty(shape, **factory))
        self.bias = nn.Parameter(torch.empty(seeds, 1, out_features, **factory)) if bias else None
        self.reset_parameters()

    def reset_parameters(self, generators: list[torch.Generator] | None = None) -> None:
        """Draw every seed's slice like ``nn.Linear``; ``generators[s]`` (if given) draws seed s."""
        bound = 1.0 / math.sqrt(self.in_features)
        with torch.no_grad():
            for s in range(self.seeds):
                generator = generators[s] if generators is not None else None
                self.weight[s].uniform_(-bound, bound, generator=generator)
                if self.bias is not None:
                    self.bias[s].uniform_(-bound, bound, generator=generator)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.shape[0] != self.seeds:
            raise ValueError(f"expected a leading seed dimension of {self.seeds}, got input of shape {tuple(x.shape)}")
        batch_shape = x.shape[1:-1]
        flat = x.reshape(self.seeds, -1, self.in_features)
        out = seed_batched_linear(flat, self.weight, self.bias, self.out_features)
        return out.reshape(self.seeds, *batch_shape, self.out_features)

    def extra_repr(self) -> str:
        bias = self.bias is not None
        return f"in_features={self.in_features}, out_features={self.out_features}, seeds={self.seeds}, bias={bias}"


def seed_batched_linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None,
                        out_features: int) -> torch.Tensor:
    """``x[s] @ W[s] + b[s]`` for each parameter set s: x (S, B, in) → (S, B, out), with the weight stored as
    :class:`SeedBatchedLinear` stores it ((S, out, in) for a narrow output, else (S, in, out)) and bias (S, 1, out)."""
    if out_features < NARROW_OUTPUT:
        weight = weight.transpose(1, 2)
    return torch.bmm(x, weight) if bias is None else torch.baddbmm(bias, x, weight)


def reset_seed_parameters(module: nn.Module, seeds: list[int] | tuple[int, ...]) -> None:
    """Re-draw every :class:`SeedBatchedLinear` in ``module``, slice s from a generator seeded with ``seeds[s]``.

    Layers are visited in registration order, so seed s gets the same initial weights whatever other
    seeds it is trained with.
    """
    generators = [torch.Generator().manual_seed(int(seed)) for seed in seeds]
    for layer in module.modules():
        if isinstance(layer, SeedBatchedLinear):
            layer.reset_parameters(generators)
