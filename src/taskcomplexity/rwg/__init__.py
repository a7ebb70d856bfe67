"""Random Weight Guessing (Algorithm 1): N random policies × M episodes → the return matrix S.

S[n, e] is the undiscounted return of policy θₙ in episode e. Policy n's weights and episode e's
initial state come from streams keyed by (seed, n) and (seed, n, e) (:mod:`taskcomplexity.seeding`),
so S is a pure function of (task, network, prior, N, M, seed): the same for any chunking, sharding
or backend (up to the backends' documented tolerance).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from threadpoolctl import threadpool_limits

from taskcomplexity.config import setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.families import sample_family
from taskcomplexity.policies.mlp import NetworkSpec, PolicyBatch, PriorSpec
from taskcomplexity.policies.primitives import PrimitiveBatch, PrimitiveSpec
from taskcomplexity.progress import Progress, progress_bar
from taskcomplexity.rwg.gym_backend import ENVIRONMENTS_IN_FLIGHT, GymRollout
from taskcomplexity.seeding import episode_uniforms
from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.base import Task
from taskcomplexity.tasks.dynamics import CONTACT_MODES
from taskcomplexity.tasks.rollout_kernel import PRECISIONS
from taskcomplexity.tasks.spec import TaskSpec

BACKENDS = ("batched", "pybullet", "gym", "kernel")
"""Every RWG backend; a task lists those it supports in ``task.backends`` (fastest exact one first)."""
AUTO = "auto"
"""``backend=auto``: the task's first backend."""


PRIMITIVE_BACKENDS = ("batched", "pybullet")
"""The backends that run the movement-primitive family (``network=dmp``): the reaching arms' own."""


def resolve_backend(task: Task, backend: str, network: NetworkSpec | PrimitiveSpec | None = None) -> str:
    """``auto`` → the task's fastest exact backend (for ``network``'s family); refuse one it does not have."""
    allowed = task.backends
    if isinstance(network, PrimitiveSpec):
        allowed = tuple(b for b in allowed if b in PRIMITIVE_BACKENDS)
        if not allowed:
            raise ConfigError(f"network.family={network.family} is not available for task {task.task_id}: it "
                              f"plans joint-space movements of a reaching arm (allowed: an arm=… task, or an "
                              f"MLP network)")
    if backend == AUTO:
        return allowed[0]
    if backend not in allowed:
        raise ConfigError(f"backend={backend} is not available for task {task.task_id}"
                          + (f" with network.family={network.family}" if isinstance(network, PrimitiveSpec) else "")
                          + f" (allowed: {', '.join([AUTO, *allowed])})")
    return backend
CONTACTS = tuple(CONTACT_MODES)


@dataclass(frozen=True)
class RWGSettings:
    """Settings of one RWG run.

    Attributes
    ----------
    policies, episodes : int
        N and M (both >= 2).
    seed : int
        Run seed (>= 0).
    chunk_policies : int
        Policies simulated together; 0 chooses from ``chunk_memory_mb``.
    chunk_memory_mb : int
        Working-memory budget of one chunk on the batched backend, MB.
    shard, shards : int
        This job simulates policy range ``shard`` of ``shards`` equal ranges.
    contacts : {'pybullet', 'model'}
        The obstacle task's forearm–block contacts on the batched backend: ``pybullet`` finishes each
        episode that reaches the block on the PyBullet reference (exact, PyBullet's speed);
        ``model`` integrates them with the batched contact model (:mod:`taskcomplexity.tasks.contact`:
        PyBullet's distribution of outcomes, at the batched backend's speed).
    common_initial_states : bool
        Episode e of every policy starts from the same state (reset by (seed, e) only: the original
        PIC/POIC protocol's common random numbers); false: by (seed, n, e).
    precision : {'float64', 'float32'}
        The arithmetic of the policies' forward pass on the batched backend (MLP families; the physics is always
        float64). ``float32`` runs it about 1.5× faster, and the returns move by the rounding of the actions
        (:func:`taskcomplexity.tasks.rollout_kernel.rollout`); it has its own keys. The obstacle task keeps
        float64 (its contacts are chaotic: :class:`taskcomplexity.stages.rwg_stage.RWGRequest`).
    """

    policies: int = 1000
    episodes: int = 100
    seed: int = 0
    chunk_policies: int = setting(0, result=False)  # how the work is split never changes the returns
    chunk_memory_mb: int = setting(512, result=False)
    shard: int = setting(0, result=False)
    shards: int = setting(1, result=False)
    contacts: str = "pybullet"
    common_initial_states: bool = False
    precision: str = "float64"

    def validate(self) -> None:
        if self.policies < 2:
            raise ConfigError(f"rwg.policies must be an integer >= 2 (N), got {self.policies}")
        if self.episodes < 2:
            raise ConfigError(f"rwg.episodes must be an integer >= 2 (M), got {self.episodes}")
        if self.seed < 0:
            raise ConfigError(f"rwg.seed must be a non-negative integer, got {self.seed}")
        if self.chunk_policies < 0:
            raise ConfigError(f"rwg.chunk_policies must be >= 0 (0 = automatic), got {self.chunk_policies}")
        if self.chunk_memory_mb < 1:
            raise ConfigError(f"rwg.chunk_memory_mb must be >= 1, got {self.chunk_memory_mb}")
        if self.contacts not in CONTACTS:
            raise ConfigError(f"rwg.contacts must be one of {list(CONTACTS)}, got {self.contacts!r}")
        if self.precision not in PRECISIONS:
            raise ConfigError(f"rwg.precision must be one of {list(PRECISIONS)}, got {self.precision!r}")
        if not 1 <= self.shards <= self.policies:
            raise ConfigError(f"rwg.shards must be in [1, rwg.policies={self.policies}], got {self.shards}")
        if not 0 <= self.shard < self.shards:
            raise ConfigError(
                f"rwg.shard must be in [0, {self.shards - 1}] (rwg.shards={self.shards}), got {self.shard}"
            )

    def shard_range(self, shard: int | None = None) -> tuple[int, int]:
        """Policy index range [start, stop) of a shard (this one by default)."""
        shard = self.shard if shard is None else shard
        bounds = np.linspace(0, self.policies, self.shards + 1).round().astype(int)
        return int(bounds[shard]), int(bounds[shard + 1])


@dataclass
class ReturnChunk:
    """Results of a range of policies.

    Attributes
    ----------
    policy : ndarray (P,) int
        Policy indices n.
    returns : ndarray (P, M) float64
        Undiscounted episode returns.
    steps : ndarray (P, M) int
        Episode lengths (environment steps).
    success : ndarray (P, M) bool
        Whether the episode reached d < threshold.
    handoffs : int
        Episodes finished on the PyBullet reference after reaching the block (batched backend,
        ``contacts='pybullet'``).
    contacts : int
        Episodes in which the modelled block acted on the arm (batched backend, ``contacts='model'``).
    """

    policy: np.ndarray
    returns: np.ndarray
    steps: np.ndarray
    success: np.ndarray
    handoffs: int = 0
    contacts: int = 0

    @staticmethod
    def concatenate(chunks: list[ReturnChunk]) -> ReturnChunk:
        chunks = sorted(chunks, key=lambda c: int(c.policy[0]))
        return ReturnChunk(
            policy=np.concatenate([c.policy for c in chunks]),
            returns=np.concatenate([c.returns for c in chunks]),
            steps=np.concatenate([c.steps for c in chunks]),
            success=np.concatenate([c.success for c in chunks]),
            handoffs=sum(c.handoffs for c in chunks),
            contacts=sum(c.contacts for c in chunks),
        )


def initial_states(task: TaskSpec, seed: int, policies: np.ndarray, episodes: int, common: bool = False):
    """Reset states of every (policy, episode) pair (``common``: policy 0's for every policy).

    Returns
    -------
    joint_angles : ndarray (P, M, dof)
    target : ndarray (P, M, 2)
    """
    n = np.asarray(policies)[:, None] * (not common)
    e = np.arange(episodes)[None, :]
    return mechanics.initial_state(task.arm, episode_uniforms(seed, n, e))


def chunk_size(task: Task, network: NetworkSpec | PrimitiveSpec, settings: RWGSettings, backend: str) -> int:
    """Policies per chunk."""
    if settings.chunk_policies:
        return settings.chunk_policies
    if backend == "pybullet":
        return 16
    if backend == "gym":
        return max(1, ENVIRONMENTS_IN_FLIGHT // min(settings.episodes, ENVIRONMENTS_IN_FLIGHT))
    per_env = 8 * network.working_floats(task.observation_size, task.action_size, task.max_steps)  # float64
    envs = settings.chunk_memory_mb * 2**20 // per_env
    return max(1, min(envs // settings.episodes, 2048))


def chunks(task: Task, network: NetworkSpec | PrimitiveSpec, settings: RWGSettings,
           backend: str) -> list[tuple[int, int]]:
    """The [start, stop) policy ranges of this shard's chunks."""
    start, stop = settings.shard_range()
    size = chunk_size(task, network, settings, backend)
    return [(a, min(a + size, stop)) for a in range(start, stop, size)]


def simulate_chunk(
    task: Task,
    network: NetworkSpec | PrimitiveSpec,
    prior: PriorSpec,
    settings: RWGSettings,
    start: int,
    stop: int,
    backend: str = "batched",
    *,
    progress: bool = False,
    rollout: GymRollout | None = None,
) -> ReturnChunk:
    """Run every episode of policies ``start … stop−1`` (``progress``: a bar over obstacle hand-overs).

    ``rollout`` is the environment pool of the ``gym`` backend (made here, and closed, when None).
    """
    backend = resolve_backend(task, backend, network)
    indices = np.arange(start, stop)
    policies = sample_family(task, network, prior, settings.seed, indices)
    if backend == "kernel":  # issue 14: classic-control kernels (rwg/kernel_backend.py)
        from taskcomplexity.rwg.kernel_backend import run_kernel

        return ReturnChunk(policies.indices.copy(), *run_kernel(task, policies, settings.seed, settings.episodes,
                                                                settings.common_initial_states))
    if backend == "gym":
        if rollout is not None:
            return ReturnChunk(policies.indices.copy(), *rollout.run(policies, settings.seed, settings.episodes,
                                                                     settings.common_initial_states))
        with GymRollout(task) as own:
            return ReturnChunk(policies.indices.copy(), *own.run(policies, settings.seed, settings.episodes,
                                                                 settings.common_initial_states))
    joint_angles, target = initial_states(task, settings.seed, indices, settings.episodes,
                                          settings.common_initial_states)
    if backend == "batched":
        return _simulate_batched(task, policies, joint_angles, target, settings.contacts, progress,
                                 precision=settings.precision)
    return _simulate_pybullet(task, policies, joint_angles, target)


def _simulate_batched(
    task, policies: PolicyBatch | PrimitiveBatch, joint_angles, target, contacts: str = "pybullet",
    progress: bool = False, *, fused: bool = True, precision: str = "float64",
) -> ReturnChunk:
    """Every episode of the chunk on the batched backend.

    ``fused`` (MLPs only): each policy's episodes run to their end in one kernel (forward pass and step
    per environment, :meth:`BatchedReaching.rollout`); otherwise step by step, one batched
    :meth:`respond` of the policies and one :meth:`BatchedReaching.step` per environment step — the
    reference the fused rollout is tested and benchmarked against, and the movement primitives' path.
    ``precision``: the fused forward pass's arithmetic (``float32`` needs the fused MLP path).
    """
    from taskcomplexity.tasks.batched import BatchedReaching

    n_pol, n_ep = joint_angles.shape[:2]
    env = BatchedReaching(task, n_pol * n_ep, contacts)
    obs = env.reset(torch.from_numpy(joint_angles.reshape(n_pol * n_ep, -1)), torch.from_numpy(target.reshape(-1, 2)))
    planned: dict[int, object] = {}  # flat environment → the policy's state where it was handed over
    if precision != "float64" and not (fused and isinstance(policies, PolicyBatch)):
        raise ValueError(f"precision={precision} runs on the fused rollout of an MLP family only")
    if fused and isinstance(policies, PolicyBatch):
        env.rollout(*policies.packed(), activation=policies.activation, output=policies.output,
                    bias=policies.biases is not None, input_bias=policies.input_bias, precision=precision)
    else:
        with torch.no_grad(), policies:  # closing the batch ends its forward-pass threads
            state = policies.begin(obs.view(n_pol, n_ep, -1))
            for _ in range(task.max_steps):
                if not env.active.numpy().any():  # NumPy: no torch thread pool woken per step
                    break
                before, handed = state, env.handoff.numpy().copy()
                action, state = policies.respond(obs.view(n_pol, n_ep, -1), state)
                obs, _, _ = env.step(action.reshape(n_pol * n_ep, -1))
                if before is not None:
                    for flat in np.flatnonzero(env.handoff.numpy() & ~handed):
                        planned[int(flat)] = before.row(*divmod(int(flat), n_ep))
    returns = env.returns.numpy().reshape(n_pol, n_ep).copy()
    steps = env.steps.numpy().reshape(n_pol, n_ep).copy()
    success = env.success.numpy().reshape(n_pol, n_ep).copy()
    handoff = env.handoff.numpy().reshape(n_pol, n_ep)
    if handoff.any():
        _finish_on_pybullet(task, policies, env, handoff, returns, steps, success, progress, planned)
    return ReturnChunk(
        policies.indices.copy(), returns, steps, success, int(handoff.sum()), int(env.contact.numpy().sum())
    )


def _finish_on_pybullet(task, policies, env, handoff, returns, steps, success, progress: bool = False,
                        planned: dict | None = None) -> None:
    """Continue handed-over episodes on the PyBullet reference, from the state where they stopped
    (``planned``: flat environment → the policy's own state there, for families that keep one)."""
    n_ep = handoff.shape[1]
    planned = planned or {}
    jobs = []
    for p, e in zip(*np.nonzero(handoff), strict=True):
        flat = p * n_ep + e
        one = policies.select(int(p))
        jobs.append(
            (
                int(p),
                int(e),
                one,
                env.joint_angles[flat].numpy().copy(),
                env.joint_velocities[flat].numpy().copy(),
                env.target[flat].numpy().copy(),
                task.max_steps - int(steps[p, e]),
                planned.get(int(flat)),
            )
        )
    from tqdm.auto import tqdm

    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    reference = ReachingEnv(task=task)
    try:
        bar = tqdm(jobs, desc="obstacle contacts on pybullet", unit="ep", disable=not progress, leave=False)
        outcomes = [_continue_episode(reference, job) for job in bar]
    finally:
        reference.close()
    for (p, e, *_), (ret, n, ok) in zip(jobs, outcomes, strict=True):
        returns[p, e] += ret
        steps[p, e] += n
        success[p, e] |= ok


def _continue_episode(env, job) -> tuple[float, int, bool]:
    """Finish one handed-over episode on the reference ``env`` from the state where it stopped."""
    _, _, policy, joint_angles, joint_velocities, target, max_steps, state = job  # the whole policy
    obs, _ = env.reset(options={"joint_angles": joint_angles, "joint_velocities": joint_velocities, "target": target})
    return _rollout(env, policy, obs, max_steps, state)


def _rollout(env, policy: PolicyBatch | PrimitiveBatch, obs, max_steps: int, state=None) -> tuple[float, int, bool]:
    """One episode of a policy of one from ``obs`` (``state``: the policy's own, mid-episode; None: a new one)."""
    total, n, ok = 0.0, 0, False
    with torch.no_grad():
        if state is None:
            state = policy.begin(torch.from_numpy(obs).view(1, 1, -1))
        for _ in range(max_steps):
            action, state = policy.respond(torch.from_numpy(obs).view(1, 1, -1), state)
            action = action[0, 0].numpy()
            obs, reward, terminated, _, info = env.step(action)
            total += reward
            n += 1
            if terminated:
                ok = info["success"]
                break
    return total, n, ok


def _simulate_pybullet(task, policies: PolicyBatch | PrimitiveBatch, joint_angles, target) -> ReturnChunk:
    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    n_pol, n_ep = joint_angles.shape[:2]
    returns = np.zeros((n_pol, n_ep))
    steps = np.zeros((n_pol, n_ep), dtype=np.int64)
    success = np.zeros((n_pol, n_ep), dtype=bool)
    env = ReachingEnv(task=task)
    try:
        for p in range(n_pol):
            policy = policies.select(p)
            for e in range(n_ep):
                obs, _ = env.reset(options={"joint_angles": joint_angles[p, e], "target": target[p, e]})
                returns[p, e], steps[p, e], success[p, e] = _rollout(env, policy, obs, task.max_steps)
    finally:
        env.close()
    return ReturnChunk(policies.indices.copy(), returns, steps, success)


def run_rwg(
    task: Task,
    network: NetworkSpec | PrimitiveSpec,
    prior: PriorSpec,
    settings: RWGSettings,
    backend: str = "batched",
    *,
    completed: dict[tuple[int, int], ReturnChunk] | None = None,
    on_chunk: Callable[[tuple[int, int], ReturnChunk], None] | None = None,
    progress: Progress = False,
) -> ReturnChunk:
    """Algorithm 1 over this shard's policies.

    Parameters
    ----------
    completed : dict, optional
        Chunks already computed (by an interrupted run), keyed by (start, stop); they are reused.
    on_chunk : callable, optional
        Called with each newly computed chunk (e.g. to save it for resumption).
    progress : bool or tqdm
        Show a bar over environment episodes, or advance a study stage's bar
        (:mod:`taskcomplexity.progress`).
    """
    settings.validate()
    backend = resolve_backend(task, backend, network)
    completed = dict(completed or {})
    ranges = chunks(task, network, settings, backend)
    total = sum(b - a for a, b in ranges) * settings.episodes
    bar = progress_bar(progress, total=total, unit="ep", desc=f"rwg {task.task_id} [{backend}]", smoothing=0.1)
    rollout = GymRollout(task) if backend == "gym" else None
    # The policy forward pass already runs one thread per core (PolicyBatch.act): BLAS threads inside those
    # workers would only spin against them. One BLAS thread per worker computes the same products.
    blas = threadpool_limits(limits=1, user_api="blas")
    try:
        for key in ranges:
            if key not in completed:
                completed[key] = simulate_chunk(
                    task, network, prior, settings, *key, backend=backend, progress=progress is True,
                    rollout=rollout
                )
                if on_chunk is not None:
                    on_chunk(key, completed[key])
            bar.update((key[1] - key[0]) * settings.episodes)
    finally:
        blas.restore_original_limits()
        bar.close()
        if rollout is not None:
            rollout.close()
    return ReturnChunk.concatenate([completed[k] for k in ranges])
