"""The policy families RWG samples from, declared once: ``network.family`` → its spec and its sampler.

- ``mlp`` (the default; a config without ``family`` is one): the paper's random MLPs,
  :class:`~taskcomplexity.policies.NetworkSpec` → :class:`~taskcomplexity.policies.PolicyBatch`;
- ``dmp``: the paper's first proposal, a movement primitive per joint of a reaching arm,
  :class:`~taskcomplexity.policies.primitives.PrimitiveSpec` →
  :class:`~taskcomplexity.policies.primitives.PrimitiveBatch`.

Both batches step the same way (``begin(observations) → state``, ``respond(observations, state) →
(actions, state)``, ``select(rows)``, ``indices``), so the backends run either.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskcomplexity.config import build, plain
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PolicyBatch, PriorSpec, sample_policies
from taskcomplexity.policies.primitives import PrimitiveBatch, PrimitiveSpec, sample_primitives

FAMILIES: dict[str, type] = {"mlp": NetworkSpec, "dmp": PrimitiveSpec}
"""``network.family`` → the dataclass of its settings."""

Family = NetworkSpec | PrimitiveSpec


def network_from_config(node: Any, key: str = "network") -> Family:
    """The spec of a ``network`` config node, of the family its ``family`` key names (``mlp`` without one)."""
    node = plain(node)
    if isinstance(node, tuple(FAMILIES.values())):
        return node
    family = node.get("family", "mlp") if hasattr(node, "get") else "mlp"
    if family not in FAMILIES:
        raise ConfigError(f"{key}.family must be one of {list(FAMILIES)}, got {family!r}")
    return build(FAMILIES[family], node, key)


def sample_family(task, network: Family, prior: PriorSpec, seed: int,
                  indices: np.ndarray) -> PolicyBatch | PrimitiveBatch:
    """θₙ for every n in ``indices`` on ``task``, from the family ``network`` belongs to."""
    if isinstance(network, PrimitiveSpec):
        return sample_primitives(network, prior, task, seed, indices)
    return sample_policies(network, prior, task.observation_size, task.action_size, seed, indices)
