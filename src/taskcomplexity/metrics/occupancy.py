"""Distance of random policies to an optimal policy: Wasserstein-2 between state–action occupancies.

The paper's third proposal: a task is easy for a policy prior when its random policies already
behave like the optimal policy. Behaviour is a policy's empirical state–action occupancy, the
(observation, action) pairs its episodes visit; the distance between two behaviours is the
Wasserstein-2 distance between their occupancies (exact optimal transport, POT's network simplex).

Ground metric and normalisation
-------------------------------
Every feature (each observation entry, each action entry) is standardised by :class:`Standardiser`,
fitted once per task on the pooled pairs of all the random policies and the reference policy:
z = (x − mean) / sd (a constant feature keeps scale 1). The ground cost is the squared Euclidean
distance between standardised pairs, so

    W₂(μ, ν) = ( min over couplings π of μ and ν  of  Σᵢⱼ πᵢⱼ ‖zᵢ − zⱼ‖² )^½,

in units of pooled standard deviations. Each empirical occupancy weighs its pairs equally.
Standardising on the pooled sample makes features of different units (angles, metres, torques)
commensurable and the distance invariant to a feature's units and offset.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Standardiser:
    """z = (x − mean) / scale, feature by feature.

    Attributes
    ----------
    mean, scale : ndarray (D,)
        Pooled mean and standard deviation of each feature (scale 1 where the sd is 0).
    """

    mean: np.ndarray
    scale: np.ndarray

    @classmethod
    def fit(cls, samples: Sequence[np.ndarray]) -> Standardiser:
        """Pool ``samples`` (arrays (nᵢ, D)) and take each feature's mean and sd."""
        pooled = np.concatenate([np.asarray(s, dtype=np.float64) for s in samples], axis=0)
        if pooled.ndim != 2 or pooled.shape[0] == 0:
            raise ValueError(f"Standardiser.fit needs arrays (n, D) with n >= 1 in total, got {pooled.shape}")
        scale = pooled.std(axis=0)
        scale[~(scale > 0)] = 1.0
        return cls(pooled.mean(axis=0), scale)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return (np.asarray(x, dtype=np.float64) - self.mean) / self.scale


def wasserstein2(a: np.ndarray, b: np.ndarray) -> float:
    """W₂ between the empirical distributions of the rows of ``a`` (n, D) and ``b`` (m, D), uniform weights.

    Exact (network simplex); the rows are used as given (standardise first).
    """
    import ot  # POT, imported where used: the rest of the package does not need it

    a, b = np.atleast_2d(np.asarray(a, dtype=np.float64)), np.atleast_2d(np.asarray(b, dtype=np.float64))
    if a.shape[0] == 0 or b.shape[0] == 0 or a.shape[1] != b.shape[1]:
        raise ValueError(f"wasserstein2 needs two non-empty arrays with the same columns, got {a.shape}, {b.shape}")
    cost = ot.dist(a, b, metric="sqeuclidean")
    weights_a = np.full(a.shape[0], 1.0 / a.shape[0])
    weights_b = np.full(b.shape[0], 1.0 / b.shape[0])
    return float(np.sqrt(max(ot.emd2(weights_a, weights_b, cost, numItermax=1_000_000), 0.0)))


def occupancy_distances(policies: Sequence[np.ndarray], reference: np.ndarray) -> np.ndarray:
    """W₂ of each random policy's occupancy to the reference occupancy, standardised on the pooled pairs.

    Parameters
    ----------
    policies : sequence of K arrays (nₖ, D)
        State–action pairs of each random policy.
    reference : ndarray (m, D)
        State–action pairs of the reference (optimal) policy.

    Returns
    -------
    ndarray (K,): distances in pooled standard deviations.
    """
    standardise = Standardiser.fit([*policies, reference])
    target = standardise(reference)
    return np.array([wasserstein2(standardise(p), target) for p in policies])


@dataclass(frozen=True)
class OccupancySample:
    """What the occupancy metrics are computed on: one distance per random policy.

    Attributes
    ----------
    distances : ndarray (K,)
        W₂ of each policy's occupancy to the reference's (pooled standard deviations).
    """

    distances: np.ndarray

    def subsample(self, rows: np.ndarray, *, batch: int | None = None) -> OccupancySample:
        """The distances of the policies at ``rows`` (``batch``: accepted for the stages' batch tables)."""
        return OccupancySample(np.asarray(self.distances)[np.asarray(rows)])

    @property
    def mean(self) -> float:
        return float(np.mean(self.distances))

    @property
    def variance(self) -> float:
        """Variance over policies (ddof = 1; NaN for a single policy)."""
        d = np.asarray(self.distances)
        return float(d.var(ddof=1)) if d.size > 1 else float("nan")
