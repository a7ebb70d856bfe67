"""The contact model's one-sweep rates, measured again on PyBullet (``make calibrate-contacts``).

:func:`taskcomplexity.tasks.contact.single_sweep` stands in for a chaotic effect of Bullet's solver: at a
physics step where the forearm touches the block, it sometimes stops after its first sweep instead of
iterating to convergence, with probability ``P_SINGLE_FRESH`` when the contact is new and
``P_SINGLE_CONTINUING`` otherwise. PyBullet does not report how many sweeps it made, so
:func:`measure_single_sweep_rates` finds out step by step in random-policy episodes of the obstacle task.
At each physics step where the forearm overlaps the block (the model's :func:`~taskcomplexity.tasks.contact.detect`
at the step's starting pose) the step is computed four times from the same state:

1. in the episode's world as it is: joint velocities v (the episode continues from this step);
2. in the same world restored to the step's start (``saveState``/``restoreState``, which leaves the
   episode bit for bit as without the probes: :func:`probes_leave_episodes_unchanged`), with
   ``numSolverIterations=1``: v₁, one sweep over the same rows;
3. in a shadow world without the ground plane (Bullet converges there, as the model's solve does),
   from the same joint state, with 1 and with PyBullet's 50 iterations: v₁′ and v∞′.

The step is *informative* when one sweep and convergence differ (max |v₁′ − v∞′| > 1e-9 rad/s; where
they agree, no sweep count could change the step); an informative step *stopped after one sweep* when
v equals v₁ bit for bit. A rate is the fraction of informative steps that stopped after one sweep,
with its binomial standard error √(p(1 − p)/n); a step is *fresh* when the forearm did not overlap
the block at the previous physics step of the episode (the docstring of ``single_sweep``). The
forearm–plane contact (which the mechanism needs) is recorded too, from PyBullet's contact points
after the step.

Steps of one episode are not independent (a sliding contact is many continuing steps), so the
binomial error understates the spread of the continuing rate somewhat; the fresh steps are few per
episode.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
import torch

if TYPE_CHECKING:
    from taskcomplexity.tasks.contact import ContactZone

INFORMATIVE = 1e-9
"""rad/s: one sweep and convergence differing by more than this make a step informative (float noise is
far below; a genuine difference far above)."""


@dataclasses.dataclass(frozen=True)
class SweepRate:
    """One-sweep stops among the informative steps of one kind (fresh or continuing contact)."""

    single: int
    """Informative steps that stopped after one sweep."""
    informative: int
    """Steps whose one-sweep and converged results differ."""
    steps: int
    """All steps of this kind (forearm overlapping the block)."""
    plane: int
    """Informative steps with a forearm–plane contact."""
    single_on_plane: int
    """Informative steps with a forearm–plane contact that stopped after one sweep."""

    @property
    def rate(self) -> float:
        return self.single / self.informative if self.informative else math.nan

    @property
    def standard_error(self) -> float:
        """Binomial standard error of :attr:`rate`."""
        p, n = self.rate, self.informative
        return math.sqrt(p * (1 - p) / n) if n else math.nan


@dataclasses.dataclass(frozen=True)
class Calibration:
    """What :func:`measure_single_sweep_rates` measured."""

    fresh: SweepRate
    continuing: SweepRate
    episodes: int
    physics_steps: int


class _Tally:
    def __init__(self):
        self.counts = {kind: np.zeros(5, dtype=np.int64) for kind in ("fresh", "continuing")}

    def add(self, fresh: bool, informative: bool, single: bool, plane: bool) -> None:
        counts = self.counts["fresh" if fresh else "continuing"]
        counts += (informative and single, informative, 1, informative and plane, informative and plane and single)

    def rate(self, kind: str) -> SweepRate:
        return SweepRate(*(int(c) for c in self.counts[kind]))


class _ProbingClient:
    """The episode world's PyBullet client, probing each physics step where the forearm overlaps the block.

    Stands in for :class:`~taskcomplexity.tasks.pybullet_env.ReachingEnv`'s client, so the episode is
    stepped by the env's own ``step`` (51 physics steps per action, torque in the first); every other
    call goes to the real client.
    """

    def __init__(self, env, shadow, tally: _Tally, zone: ContactZone):
        from taskcomplexity.tasks import contact

        self._client, self._shadow, self._tally, self._zone = env.client, shadow, tally, zone
        self._arm = env.arm_id
        self._plane = _body(self._client, "plane")
        self._joints = list(range(env.task.arm.dof))
        self._l1 = env.task.arm.links[0].length
        self._iterations = self._client.getPhysicsEngineParameters()["numSolverIterations"]
        self._work = contact.scratch()
        self._torque = None
        self._substep = 0
        self.overlapped = False  # the forearm overlapped the block at the previous physics step
        self.physics_steps = 0

    def __getattr__(self, name):
        return getattr(self._client, name)

    def setJointMotorControlArray(self, *args, **kwargs):  # PyBullet's name
        self._torque, self._substep = (args, kwargs), 0
        return self._client.setJointMotorControlArray(*args, **kwargs)

    def _apply_torque(self, client, arm: int) -> None:
        """The action's torque, where the first physics step of an action is stepped again.

        PyBullet adds the torques of repeated calls and clears them at each step, and ``restoreState``
        does not bring them back: a probe consumes the torque the env set, so it is set again for the
        episode's own step after the restore, and for each step of the shadow world.
        """
        if self._substep == 0 and self._torque is not None:
            args, kwargs = self._torque
            client.setJointMotorControlArray(arm, *args[1:], **kwargs)

    def _velocities(self, client) -> np.ndarray:
        return np.array([s[1] for s in client.getJointStates(self._arm, self._joints)])

    def _step(self, client, iterations: int) -> np.ndarray:
        client.setPhysicsEngineParameter(numSolverIterations=iterations)
        client.stepSimulation()
        client.setPhysicsEngineParameter(numSolverIterations=self._iterations)
        return self._velocities(client)

    def stepSimulation(self):  # PyBullet's name
        from taskcomplexity.tasks import contact

        client = self._client
        states = client.getJointStates(self._arm, self._joints)
        q, v = np.array([s[0] for s in states]), np.array([s[1] for s in states])
        points, ends, _, _ = self._work
        overlap = contact.detect(self._zone, self._l1, q[0], q[1], points, ends)[0] > 0
        if overlap:
            saved = client.saveState()
            one_sweep = self._step(client, 1)  # with the torque the env set, when this step is the action's first
            client.restoreState(saved)
            client.removeState(saved)
            self._apply_torque(client, self._arm)
            shadow = self._shadow.client
            results = []
            for iterations in (1, self._iterations):
                for j, angle, velocity in zip(self._joints, q, v, strict=True):
                    shadow.resetJointState(self._arm, j, float(angle), float(velocity))
                self._apply_torque(shadow, self._arm)
                results.append(self._step(shadow, iterations))
            informative = float(np.abs(results[0] - results[1]).max()) > INFORMATIVE
        client.stepSimulation()
        self._substep += 1
        self.physics_steps += 1
        if overlap:
            plane = len(client.getContactPoints(self._arm, self._plane, linkIndexA=self._joints[-1])) > 0
            single = bool(np.array_equal(self._velocities(client), one_sweep))
            self._tally.add(not self.overlapped, informative, single, plane)
        self.overlapped = bool(overlap)


def _body(client, name: str) -> int:
    """The id of the body called ``name`` in a PyBullet world."""
    for i in range(client.getNumBodies()):
        if client.getBodyInfo(i)[1].decode() == name:
            return i
    raise LookupError(f"no body {name!r} in the world")


def _episodes(task, policies: int, episodes: int, seed: int):
    """(policy, joint angles, target) of every RWG episode: the default sampler (mlp32, normal prior)."""
    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
    from taskcomplexity.rwg import initial_states

    joint_angles, target = initial_states(task, seed, np.arange(policies), episodes)
    for n in range(policies):
        policy = sample_policies(NetworkSpec(), PriorSpec(), task.observation_size, task.arm.dof, seed, np.array([n]))
        for e in range(episodes):
            yield policy, joint_angles[n, e], target[n, e]


def _run(task, policies: int, episodes: int, seed: int, probe: bool, progress: bool):
    """Roll out the episodes on PyBullet (probing or not); (tally, physics steps, per-episode returns)."""
    from tqdm import tqdm

    from taskcomplexity.tasks.dynamics import contact_zone
    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    env, shadow = ReachingEnv(task=task), ReachingEnv(task=task)
    tally = _Tally()
    try:
        shadow.client.removeBody(_body(shadow.client, "plane"))
        client = _ProbingClient(env, shadow, tally, contact_zone(task, "model"))
        if probe:
            env._client = client  # the env's own step drives the physics steps through the probe
        returns = []
        bar = tqdm(_episodes(task, policies, episodes, seed), total=policies * episodes, desc="contact steps",
                   unit="ep", disable=not progress, leave=False)
        with torch.no_grad():
            for policy, joint_angles, target in bar:
                obs, _ = env.reset(options={"joint_angles": joint_angles, "target": target})
                client.overlapped = False
                total = 0.0
                for _ in range(task.max_steps):
                    action = policy.act(torch.from_numpy(obs).view(1, 1, -1))[0, 0].numpy()
                    obs, reward, terminated, _, _ = env.step(action)
                    total += reward
                    if terminated:
                        break
                returns.append(total)
    finally:
        env.close()
        shadow.close()
    return tally, client.physics_steps, np.array(returns)


def measure_single_sweep_rates(task=None, *, policies: int = 300, episodes: int = 5, seed: int = 0,
                               progress: bool = False) -> Calibration:
    """Measure the one-sweep rates of fresh and continuing block contacts on PyBullet (module docstring).

    Parameters
    ----------
    task : TaskSpec, optional
        A reaching task with an obstacle; default ``two_link_obstacle``, dense.
    policies, episodes : int
        Random policies (mlp32, normal prior: the study's sampler) × episodes each, as RWG draws them.
    seed : int
        RWG seed of the policies and initial states.
    progress : bool
        Show a progress bar.
    """
    from taskcomplexity.tasks.spec import make_task

    task = task if task is not None else make_task("two_link_obstacle", "dense")
    if task.arm.obstacle is None:
        raise ValueError(f"task must have an obstacle, got {task.task_id!r}")
    tally, physics_steps, _ = _run(task, policies, episodes, seed, probe=True, progress=progress)
    return Calibration(tally.rate("fresh"), tally.rate("continuing"), policies * episodes, physics_steps)


def probes_leave_episodes_unchanged(task=None, *, policies: int = 10, episodes: int = 2, seed: int = 0) -> bool:
    """Whether probing leaves every return bit for bit as an unprobed rollout's (the measurement's premise)."""
    from taskcomplexity.tasks.spec import make_task

    task = task if task is not None else make_task("two_link_obstacle", "dense")
    probed = _run(task, policies, episodes, seed, probe=True, progress=False)
    plain = _run(task, policies, episodes, seed, probe=False, progress=False)
    return probed[0].counts["fresh"][2] > 0 and bool(np.array_equal(probed[2], plain[2]))
