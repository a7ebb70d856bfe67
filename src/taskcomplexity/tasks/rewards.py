"""The reaching tasks' reward kinds: declared once, computed by one scalar function.

| kind | per-step reward r | function of the goals only |
|---|---|---|
| ``dense`` | −(d² + Σ aᵢ²), and with an obstacle − penalty·c − weight·(e^(−decay·d₁) + e^(−decay·d₂)) | no |
| ``sparse`` | 0 if d < threshold else −1 | yes |

d: end-effector distance to the target (m); aᵢ: the clipped action in [−1, 1]; c ∈ {0, 1}: a collision
(d₁ or d₂ ≤ the obstacle's collision distance); d₁, d₂: the upper arm's and the forearm's clearance
from the obstacle (m). Every kind terminates the episode at success (d < threshold) or a collision.

:func:`reward` is the one definition: the batched backend's step kernel calls it per environment
(numba inlines it), and the PyBullet reference (through
:func:`taskcomplexity.tasks.mechanics.reward_terms`) and the goal-conditioned view
(:func:`taskcomplexity.tasks.goal_env.compute_reward`) evaluate it on arrays through
:func:`rewards`. A new kind is a :class:`RewardKind` in :data:`KINDS` (declared in
:mod:`taskcomplexity.tasks.reward_kinds`, which reading a config imports without the kernels), a branch of
:func:`reward`, and its YAML file under ``taskcomplexity/conf/reward``.
"""

from __future__ import annotations

import numba
import numpy as np

from taskcomplexity.tasks.reward_kinds import DENSE as DENSE
from taskcomplexity.tasks.reward_kinds import KINDS as KINDS
from taskcomplexity.tasks.reward_kinds import OBSTACLE_TERMS as OBSTACLE_TERMS
from taskcomplexity.tasks.reward_kinds import REWARD_KINDS as REWARD_KINDS
from taskcomplexity.tasks.reward_kinds import SPARSE as SPARSE
from taskcomplexity.tasks.reward_kinds import TERMS as TERMS
from taskcomplexity.tasks.reward_kinds import RewardKind as RewardKind
from taskcomplexity.tasks.reward_kinds import reward_kind as reward_kind


@numba.njit(cache=True)
def success(distance, threshold):
    """Success (and termination): d < threshold. Scalars or arrays (in numba or from Python)."""
    return distance < threshold


@numba.njit(cache=True)
def collision(upper, forearm, collision_distance):
    """c: either clearance (m) at or below the collision distance (m); scalars or arrays."""
    return (upper <= collision_distance) | (forearm <= collision_distance)


@numba.njit(cache=True)
def proximity(upper, forearm, decay):
    """e^(−decay·d₁) + e^(−decay·d₂) for clearances d₁, d₂ (m) and decay (1/m); scalars or arrays."""
    return np.exp(-decay * upper) + np.exp(-decay * forearm)


@numba.njit(cache=True)
def shaped_terms(distance, effort, hit_obstacle, near_obstacle, penalty, weight):
    """The signed terms of :data:`TERMS`: −d², −Σ aᵢ², −penalty·c, −weight·proximity.

    ``effort`` = Σ aᵢ² of the clipped action; ``hit_obstacle`` = c as 0.0 or 1.0; ``near_obstacle`` =
    :func:`proximity`; without an obstacle, pass zeros for the last four (the terms are then −0.0,
    which adds nothing). Scalars or arrays.
    """
    return -(distance * distance), -effort, -(penalty * hit_obstacle), -(weight * near_obstacle)


@numba.njit(cache=True)
def reward(kind, distance, threshold, effort, hit_obstacle, near_obstacle, penalty, weight):
    """The per-step reward r of reward kind ``kind`` (a :attr:`RewardKind.code`) for one environment.

    Parameters
    ----------
    kind : float
        DENSE or SPARSE.
    distance : float
        End-effector distance to the target d, m.
    threshold : float
        Success distance, m.
    effort : float
        Σ aᵢ² of the clipped action.
    hit_obstacle : bool
        c: the arm collided with the obstacle (False without one).
    near_obstacle : float
        :func:`proximity` of the clearances (0 without an obstacle).
    penalty, weight : float
        The obstacle's collision penalty and proximity weight (0 without one).
    """
    if kind == SPARSE:
        return (1.0 if success(distance, threshold) else 0.0) - 1.0
    d, a, c, p = shaped_terms(distance, effort, 1.0 if hit_obstacle else 0.0, near_obstacle, penalty, weight)
    return ((d + a) + c) + p


@numba.njit(cache=True)
def _rewards(kind, distance, threshold, effort, hit_obstacle, near_obstacle, penalty, weight, out):
    for i in range(out.shape[0]):
        out[i] = reward(kind, distance[i], threshold, effort[i], hit_obstacle[i], near_obstacle[i], penalty, weight)


def rewards(kind: str, distance, threshold: float, effort=0.0, hit_obstacle=False, near_obstacle=0.0,
            penalty: float = 0.0, weight: float = 0.0) -> np.ndarray:
    """:func:`reward` over NumPy arrays (broadcast together), float64 of their broadcast shape.

    ``kind`` is the kind's name; the arguments are those of :func:`reward` (the defaults: no action
    term, no obstacle).
    """
    code = reward_kind(kind).code
    arrays = np.broadcast_arrays(np.asarray(distance, dtype=np.float64), np.asarray(effort, dtype=np.float64),
                                 np.asarray(hit_obstacle, dtype=np.bool_), np.asarray(near_obstacle, dtype=np.float64))
    shape = arrays[0].shape
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    out = np.empty(flat[0].shape[0])
    _rewards(code, flat[0], float(threshold), flat[1], flat[2], flat[3], float(penalty), float(weight), out)
    return out.reshape(shape)


__all__ = [
    "DENSE",
    "KINDS",
    "OBSTACLE_TERMS",
    "REWARD_KINDS",
    "SPARSE",
    "TERMS",
    "RewardKind",
    "collision",
    "proximity",
    "reward",
    "reward_kind",
    "rewards",
    "shaped_terms",
    "success",
]
