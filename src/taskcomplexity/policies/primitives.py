"""The movement-primitive policy family (``network=dmp``): RWG over the weights of a DMP per joint.

The paper's first proposal: a policy family with an inductive bias for reaching. A policy θ is one
discrete DMP per joint (:mod:`taskcomplexity.policies.movement_primitives`), K weights each; θ ~ the prior
(``prior=…``, as for an MLP: a (J, K) weight matrix with fan_in K and fan_out J), scaled by α_z·β_z
so that a unit weight shapes the movement as strongly as the spring pulls it to its goal.

One episode of policy θ on a reaching arm:

1. At reset, from the first observation: the start configuration y₀ (the observed joint angles) and
   the goal g, the joint angles that put the end effector on the target (inverse kinematics: the
   target's angle for one link; for two links the elbow branch closer to y₀). g is unwrapped to the
   representative nearest y₀, so the movement takes the shorter way round.
2. The DMP's trajectory y₀ … y_T over the episode's T steps (one output per environment step of
   Δt = substeps × time step seconds; the movement lasts ``movement_steps`` steps, after which the
   spring holds y at g).
3. At step t the arm is driven along it: the velocity it should have, (y_{t+1} − q_t)/Δt, minus the
   velocity it has (estimated from the last two observed configurations: the 2-link arms do not
   observe velocities), is the velocity change; the action is the impulse that makes it,
   a = clip(gain · M·Δv / (torque scale · time step), −1, 1), with M the arm's joint-space mass
   matrix (each action is one sub-step's impulse: ``spec/environments.md``).

The policy is deterministic and uses only what the task observes; it is open-loop in its shape
(fixed at reset) and closed-loop in its tracking.

Shapes: P policies, E environments each (the leading dimensions of ``begin`` and ``respond``), J joints,
K basis functions, T steps per episode.
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.seeding import policy_generator

if TYPE_CHECKING:  # torch, numba and the DMP kernels are imported by the functions that run the primitives
    import torch

    from taskcomplexity.policies.movement_primitives import DMPSpec

FAMILY = "dmp"
PARALLEL_ENVIRONMENTS = 16_384
"""Environments per thread below which :meth:`PrimitiveBatch.respond` stays on one thread."""


@dataclass(frozen=True)
class PrimitiveSpec:
    """A DMP policy family (``conf/network/dmp.yaml``).

    Attributes
    ----------
    family : str
        Always ``dmp`` (what tells this family from the MLPs in a config).
    basis : int
        K, Gaussian basis functions per joint.
    alpha_z, alpha_x : float
        The DMP's spring gain and phase decay (:class:`~taskcomplexity.policies.movement_primitives.DMPSpec`).
    movement_steps : int
        τ, the movement's duration, in environment steps.
    gain : float
        Tracking gain: the fraction of the needed velocity change asked of each action.
    substeps : int
        Euler sub-steps of the DMP integration per environment step.
    """

    family: str = FAMILY
    basis: int = 10
    alpha_z: float = 25.0
    alpha_x: float = 3.0
    movement_steps: int = 20
    gain: float = 1.0
    substeps: int = 10

    ADDED: ClassVar[dict] = {}

    def validate(self) -> None:
        if self.family != FAMILY:
            raise ConfigError(f"network.family must be {FAMILY!r} for a movement-primitive family, got {self.family!r}")
        for name in ("basis", "movement_steps", "substeps"):
            if getattr(self, name) < 1:
                raise ConfigError(f"network.{name} must be an integer >= 1, got {getattr(self, name)}")
        for name in ("alpha_z", "alpha_x", "gain"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"network.{name} must be a finite number > 0, got {value}")

    @property
    def dmp(self) -> DMPSpec:
        from taskcomplexity.policies.movement_primitives import DMPSpec

        return DMPSpec(basis=self.basis, alpha_z=self.alpha_z, alpha_x=self.alpha_x, substeps=self.substeps)

    @property
    def weight_unit(self) -> float:
        """α_z·β_z: a prior draw of 1 is a forcing as strong as the spring at the full amplitude."""
        return self.alpha_z * self.dmp.beta_z

    def identity(self) -> dict:
        """The fields that key the returns."""
        return dataclasses.asdict(self)

    @property
    def tag(self) -> str:
        """Short name in run labels, e.g. 'dmp10'."""
        return f"dmp{self.basis}"

    def describe(self) -> str:
        """The family in words (the report's methods box)."""
        return (f"DMP per joint, {self.basis} basis functions, α_z = {self.alpha_z:g}, movement over "
                f"{self.movement_steps} steps, goal by inverse kinematics, tracked with gain {self.gain:g}")

    def working_floats(self, observation_size: int, action_size: int, max_steps: int) -> int:
        """Floats one environment holds while it runs (its trajectory and the controller's state)."""
        return (max_steps + 3) * action_size + self.basis * action_size + observation_size

    def sample(self, task, prior: PriorSpec, seed: int, indices: np.ndarray) -> PrimitiveBatch:
        """θₙ for every n in ``indices`` on ``task``, a reaching arm (:func:`sample_primitives`)."""
        return sample_primitives(self, prior, task, seed, indices)


def primitive_parameters(spec: PrimitiveSpec, prior: PriorSpec, joints: int, seed: int, policy: int) -> np.ndarray:
    """θₙ as DMP weights (J, K): the prior's (fan_out J, fan_in K) matrix times α_z·β_z."""
    return spec.weight_unit * prior.draw(policy_generator(seed, policy), spec.basis, joints)


def _wrap_pi(angle: np.ndarray) -> np.ndarray:
    """Angles mapped to [−π, π)."""
    return np.remainder(angle + math.pi, 2 * math.pi) - math.pi


@dataclass(frozen=True)
class ArmGeometry:
    """What the family needs to know of an arm: how to read its observation and how it moves.

    Attributes
    ----------
    lengths : tuple of float
        Link lengths used for the end effector (l for one link; l₁, l₂), m.
    torque_scale : ndarray (J,)
        N·m per unit action.
    time_step : float
        Physics time step, s (an action is an impulse over one of them).
    step_seconds : float
        Δt, one environment step (sub-steps × time step), s.
    mass_matrix : ndarray (J, J)
        Joint-space mass matrix, kg·m² (constant for the reference arms).
    """

    lengths: tuple[float, ...]
    torque_scale: np.ndarray
    time_step: float
    step_seconds: float
    mass_matrix: np.ndarray

    @staticmethod
    def of(task) -> ArmGeometry:
        """The geometry of a reaching task (:class:`~taskcomplexity.tasks.spec.TaskSpec`)."""
        from taskcomplexity.tasks.dynamics import ArmDynamics
        from taskcomplexity.tasks.urdf import read_arm_urdf, urdf_path

        arm = task.arm
        return ArmGeometry(
            lengths=tuple(float(link.length) for link in arm.links),
            torque_scale=np.asarray(arm.torque_scale, dtype=np.float64),
            time_step=float(arm.time_step),
            step_seconds=float(arm.time_step * arm.substeps),
            mass_matrix=ArmDynamics(read_arm_urdf(urdf_path(arm))).mass_matrix(),
        )

    @property
    def joints(self) -> int:
        return len(self.lengths)

    def configuration(self, observations: np.ndarray) -> np.ndarray:
        """Observed joint angles (..., J) from observations (..., obs): w(q) for one link; for two,
        q₁ and q₂ from the observed cosines and sines of q₁ and q₁ + q₂."""
        if self.joints == 1:
            return observations[..., :1].copy()
        q1 = np.arctan2(observations[..., 2], observations[..., 0])
        q12 = np.arctan2(observations[..., 3], observations[..., 1])
        return np.stack([q1, _wrap_pi(q12 - q1)], axis=-1)

    def goal(self, observations: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Joint angles (..., J) that put the end effector on the observed target (columns 4, 5 of every
        arm's observation), unwrapped to the representative nearest ``start``."""
        gx, gy = observations[..., 4], observations[..., 5]
        heading = np.arctan2(gy, gx)
        if self.joints == 1:
            goal = heading[..., None]
        else:
            l1, l2 = self.lengths
            cos2 = np.clip((gx * gx + gy * gy - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0)
            branches = []
            for sign in (1.0, -1.0):
                q2 = sign * np.arccos(cos2)
                q1 = heading - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
                branches.append(np.stack([q1, q2], axis=-1))
            travel = [np.abs(_wrap_pi(b - start)).sum(axis=-1) for b in branches]
            goal = np.where((travel[0] <= travel[1])[..., None], branches[0], branches[1])
        return start + _wrap_pi(goal - start)

    def impulse_actions(self, velocity_change: np.ndarray, gain: float) -> np.ndarray:
        """Actions (..., J) in [−1, 1] whose one-sub-step impulse changes the joint velocities by
        ``gain`` × ``velocity_change`` (rad/s), as far as the torque limits allow."""
        torque = np.einsum("ij,...j->...i", self.mass_matrix, velocity_change) / self.time_step
        return np.clip(gain * torque / self.torque_scale, -1.0, 1.0)


@dataclass(frozen=True)
class PrimitiveEpisodes:
    """The running episodes of a :class:`PrimitiveBatch`: what its controller remembers.

    Attributes
    ----------
    trajectory : ndarray (P, E, T + 1, J)
        The DMP's joint angles at every step, rad.
    previous : ndarray (P, E, J)
        The configuration observed at the previous step (the first one at step 0), rad.
    step : int
        The next step's index t.
    """

    trajectory: np.ndarray
    previous: np.ndarray
    step: int

    def row(self, p: int, e: int) -> PrimitiveEpisodes:
        """Episode (p, e) alone, as a (1, 1) state."""
        return PrimitiveEpisodes(self.trajectory[p:p + 1, e:e + 1].copy(), self.previous[p:p + 1, e:e + 1].copy(),
                                 self.step)


@dataclass
class PrimitiveBatch:
    """P DMP policies of one family on one arm (the counterpart of :class:`~taskcomplexity.policies.mlp.PolicyBatch`).

    Attributes
    ----------
    weights : ndarray (P, J, K)
    indices : ndarray (P,)
        Sampling indices n.
    spec : PrimitiveSpec
    geometry : ArmGeometry
    max_steps : int
        T, steps per episode.
    """

    weights: np.ndarray
    indices: np.ndarray
    spec: PrimitiveSpec
    geometry: ArmGeometry
    max_steps: int
    _workers: ThreadPoolExecutor | None = field(default=None, init=False, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.indices)

    def __enter__(self) -> PrimitiveBatch:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """End the threads :meth:`respond` splits a large batch over (the counterpart of
        :meth:`~taskcomplexity.policies.mlp.PolicyBatch.close`)."""
        if self._workers is not None:
            self._workers.shutdown()
            self._workers = None

    def select(self, rows) -> PrimitiveBatch:
        """The policies at positions ``rows`` (a slice or an index array)."""
        rows = np.atleast_1d(np.arange(len(self))[rows])
        return dataclasses.replace(self, weights=self.weights[rows].copy(), indices=self.indices[rows].copy())

    def begin(self, observations: torch.Tensor) -> PrimitiveEpisodes:
        """Plan every episode from its first observation (P, E, obs): start, goal and trajectory."""
        import torch

        x = np.asarray(observations.numpy() if isinstance(observations, torch.Tensor) else observations)
        n_pol, n_env = x.shape[:2]
        start = self.geometry.configuration(x)
        goal = self.geometry.goal(x, start)
        joints, steps = self.geometry.joints, self.spec.movement_steps
        path = self.spec.dmp.rollout(
            self.weights, start.reshape(-1, joints), goal.reshape(-1, joints),
            duration=steps * self.geometry.step_seconds, steps=steps,
            extra_steps=max(0, self.max_steps - steps), repeats=n_env,
        )[:, : self.max_steps + 1]
        return PrimitiveEpisodes(path.reshape(n_pol, n_env, -1, joints), start, 0)

    def respond(self, observations: torch.Tensor, state: PrimitiveEpisodes) -> tuple[torch.Tensor, PrimitiveEpisodes]:
        """Actions (P, E, J) in [−1, 1] at step ``state.step`` and the state of the next step.

        Every environment's action is its own elementwise arithmetic, so a large batch is split over
        policies into one part per numba thread (NumPy releases the GIL): the same numbers, on every core.
        """
        import numba
        import torch

        x = np.asarray(observations.numpy() if isinstance(observations, torch.Tensor) else observations)
        n_pol, n_env = x.shape[:2]
        q = np.empty((n_pol, n_env, self.geometry.joints))
        actions = np.empty_like(q)
        t = min(state.step, state.trajectory.shape[2] - 2)

        def part(rows: slice) -> None:
            q[rows] = self.geometry.configuration(x[rows])
            path = state.trajectory[rows]
            wanted = path[:, :, t + 1] - path[:, :, t] + _wrap_pi(path[:, :, t] - q[rows])
            velocity = _wrap_pi(q[rows] - state.previous[rows]) / self.geometry.step_seconds
            actions[rows] = self.geometry.impulse_actions(wanted / self.geometry.step_seconds - velocity,
                                                          self.spec.gain)

        parts = min(numba.get_num_threads(), n_pol, max(1, n_pol * n_env // PARALLEL_ENVIRONMENTS))
        if parts <= 1:
            part(slice(None))
        else:
            if self._workers is None:
                self._workers = ThreadPoolExecutor(numba.get_num_threads(), thread_name_prefix="dmp-respond")
            bounds = np.linspace(0, n_pol, parts + 1).astype(int)
            list(self._workers.map(part, [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]))
        return torch.from_numpy(actions), PrimitiveEpisodes(state.trajectory, q, state.step + 1)


def sample_primitives(spec: PrimitiveSpec, prior: PriorSpec, task, seed: int, indices: np.ndarray) -> PrimitiveBatch:
    """θₙ for every n in ``indices`` on ``task`` (a reaching arm), stacked into a :class:`PrimitiveBatch`."""
    if getattr(task, "arm", None) is None:
        raise ConfigError(f"network.family={FAMILY} needs a reaching arm task (arm=…): it plans joint-space "
                          f"movements to the target; task {task.task_id} is not one (allowed: the MLP networks)")
    geometry = ArmGeometry.of(task)
    weights = np.stack([primitive_parameters(spec, prior, geometry.joints, seed, int(n)) for n in indices])
    return PrimitiveBatch(weights, np.asarray(indices), spec, geometry, task.max_steps)
