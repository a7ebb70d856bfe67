"""The ``envpool`` RWG backend: MuJoCo and DM Control tasks stepped many at a time by EnvPool's C++ thread pool.

EnvPool (``pip install -e '.[envpool]'``) reimplements gymnasium's MuJoCo tasks and DM Control's in C++ on its own
build of MuJoCo and steps a pool of them on every core, with no Python per environment step. A task runs on it when
its gymnasium id has an EnvPool counterpart (:func:`taskcomplexity.tasks.envpool_ids.envpool_id`): gymnasium's
MuJoCo ids under the same name (``HalfCheetah-v5``), DM Control's through Shimmy (``dm_control/cheetah-run-v0``) as
``CheetahRun-v1``, with no constructor arguments (EnvPool's configs do not take gymnasium's). Classic control is left
to the ``kernel`` backend, which reproduces gymnasium's episodes exactly.

**Episodes.** EnvPool fixes each environment's generator when the pool is made and draws every reset from it; a
reset cannot be given a seed. So policy n's M episodes run one after another in one environment of its own, seeded
``episode_reset_seeds(seed, n, RESET_STREAM)``: episode e starts from that generator's (e + 1)-th reset draw. The
returns depend only on (task, policy n, episode e, seed), as on the other backends, but the initial states are not
gymnasium's (another generator draws them from the same distribution), so the returns are another sample of the
same distribution; ``tests/rwg/test_envpool_backend.py`` tests that per id, and the RWG key holds the simulator
(:func:`simulator`). With common initial states every policy's environment gets policy 0's seed.

**Per step.** The batch's policies are split into :data:`POOLS` groups, each with a pool of its own, stepped in turn:
while one pool steps its environments on EnvPool's threads, the next group's policies compute their actions. Per
group and step, one forward pass over its policies whose episodes still run (a group stops computing the policies
that have run their M episodes once they are half of those it computes) and one ``step`` of exactly their
environments; an environment whose episode ended is sent with the next step and EnvPool resets it then (its
auto-reset: the episode's first observation comes back in that step's answer, with no call of its own). Each
environment is its policy's alone, so the returns do not depend on the groups (``tests/rwg/test_envpool_pools.py``).
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.cores import usable_cores
from taskcomplexity.errors import ConfigError, EnvError
from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.backends import BACKENDS, Plan, Runner, task_backends
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.envpool_ids import ENVPOOL_EXTRA, envpool_id, installed

POLICIES_PER_POOL = BACKENDS["envpool"].chunk_policies
"""Policies of one chunk, each with one environment in the pool (256): EnvPool keeps 2 cores busy stepping 256
environments in lock-step, ~1.1–1.4 with 64. A DM Control environment holds ~12 MB and takes ~60 ms to make, a
MuJoCo one ~0.7 MB and ~2 ms."""
RESET_STREAM = 2**31 - 1
"""The episode index whose reset seed (seed, n, ·) seeds policy n's environment: outside any run's episodes, so the
generator is not one a gym-backend episode of the same run is reset with."""
POOLS = 2
"""Pools a batch's policies are split into, stepped in turn: one pool steps its environments on EnvPool's threads
while the next group's policies compute their actions, so the threads do not wait for the forward pass (1: one
pool in lock-step). The returns do not depend on it (each environment is its policy's alone)."""


def simulator() -> str:
    """What simulates a task on this backend beyond the task's own identity, for the RWG key: EnvPool's version (its
    own MuJoCo build and reset generator)."""
    from importlib.metadata import version

    return f"envpool {version('envpool')}"


def environment_seeds(seed: int, indices: np.ndarray, common_initial_states: bool = False) -> np.ndarray:
    """(P,) int seeds of the policies' environments (every policy's is policy 0's under common initial states)."""
    rows = np.asarray(indices) * (not common_initial_states)
    return episode_reset_seeds(seed, rows, RESET_STREAM)


def _flat(observations, keys: tuple[str, ...] | None) -> np.ndarray:
    """A batch of observations as (K, obs) float64: a dict's arrays side by side in ``keys``' order (the order
    gymnasium's ``FlattenObservation`` gives the same env through Shimmy)."""
    if keys is not None:
        observations = np.concatenate([np.asarray(observations[k]).reshape(len(observations[k]), -1)
                                       for k in keys], axis=1)
    observations = np.asarray(observations, dtype=np.float64)
    return observations.reshape(observations.shape[0], -1)


def make_pool(task, seeds: np.ndarray):
    """An EnvPool of ``len(seeds)`` environments of ``task``, environment i seeded ``seeds[i]``, with the task's
    episode limit, stepped on every usable core."""
    name = envpool_id(task)
    if name is None:
        raise ConfigError(f"backend=envpool cannot run task {task.task_id}: "
                          + ("EnvPool is not installed: " + ENVPOOL_EXTRA if not installed() else
                             "EnvPool simulates gymnasium's MuJoCo ids and DM Control's (through Shimmy) with no "
                             "task.kwargs") + " (allowed: auto, " + ", ".join(task_backends(task)) + ")")
    import envpool

    return envpool.make(name, env_type="gymnasium", num_envs=len(seeds), env_seed=[int(s) for s in seeds],
                        max_episode_steps=int(task.max_steps), num_threads=min(usable_cores(), len(seeds)))


def observation_keys(pool) -> tuple[str, ...] | None:
    """The keys of a pool's dict observations in its space's order (None for an array observation)."""
    space = pool.observation_space
    return tuple(space.spaces) if isinstance(space, spaces.Dict) else None


class _Group:
    """Some policies of a batch, each with one environment of a pool of their own, stepped in lock-step: the episode
    loop of :func:`run_envpool` for them, split where the pool steps (:meth:`send` starts a step after the forward
    pass, :meth:`receive` books its answer and resets the episodes that ended), so that another group's pool steps
    while these policies compute their actions. Returns and steps go into the batch's arrays, at the group's rows."""

    def __init__(self, task, policies: ActingBatch, members: np.ndarray, episodes: int, returns: np.ndarray,
                 steps: np.ndarray):
        self.task, self.policies, self.members, self.episodes = task, policies, members, episodes
        self.returns, self.steps = returns, steps
        self.box = isinstance(task.action_space, spaces.Box)
        self.pool, self.keys = None, None
        self.episode = np.zeros(len(members), dtype=np.int64)  # the episode each environment runs
        self.obs = np.zeros((len(members), task.observation_size))
        self.rows = np.arange(len(members))  # the environments whose policies still run, ascending
        self.restarting = np.zeros(len(members), dtype=bool)  # ended an episode: reset on its next send
        self.computed = self.rows  # the environments whose policies the forward pass runs (running or not), ascending
        self.acting = policies.select(members)  # their policies, in that order
        self.stepping = False

    def open(self, seeds: np.ndarray) -> None:
        """Make the group's pool (environment i seeded ``seeds[members[i]]``) and reset it."""
        self.pool = make_pool(self.task, seeds[self.members])
        self.keys = observation_keys(self.pool)
        first, _ = self.pool.reset()
        self.obs[:] = _flat(first, self.keys)

    def send(self) -> None:
        """The running policies' actions, sent to their environments (the pool steps them on its threads); an
        environment whose episode ended is sent too, and EnvPool resets it instead (its action is not used)."""
        if not self.rows.size:
            return
        outputs = self.acting.act(torch.from_numpy(self.obs[self.computed][:, None, :])).numpy()
        if len(self.computed) > len(self.rows):  # each policy's outputs are its own, whatever else is computed
            outputs = outputs[np.searchsorted(self.computed, self.rows)]
        actions = decode_actions(self.task.action_space, self.acting.unit_outputs(outputs, self.box)[:, 0, :])
        self.pool.send(actions, env_id=self.rows)
        self.stepping = True

    def receive(self) -> None:
        """Wait for the pool's step, book its rewards, mark the environments whose episode ended for a reset (drop the
        policies that ran their last)."""
        new, reward, terminated, truncated, info = self.pool.recv()
        self.stepping = False
        task, rows = self.task, self.rows
        at = np.argsort(np.asarray(info["env_id"]), kind="stable")  # EnvPool's answer in the rows' order
        self.obs[rows] = _flat(new, self.keys)[at]
        stepped = ~self.restarting[rows]  # the others answered with their next episode's first observation
        self.restarting[rows] = False
        rows = rows[stepped]
        positions, e = self.members[rows], self.episode[rows]
        reward = np.asarray(reward, dtype=np.float64)[at][stepped]
        if not np.all(np.isfinite(reward)):
            bad = int(np.flatnonzero(~np.isfinite(reward))[0])
            raise EnvError(f"task.env_id={task.env_id} on EnvPool returned reward {reward[bad]} for policy "
                           f"{int(self.policies.indices[positions[bad]])}, episode {int(e[bad])}, step "
                           f"{int(self.steps[positions[bad], e[bad]]) + 1}")
        self.returns[positions, e] += reward
        self.steps[positions, e] += 1
        ended = ((np.asarray(terminated) | np.asarray(truncated))[at][stepped]
                 | (self.steps[positions, e] >= task.max_steps))
        if ended.any():
            done = rows[ended]
            self.episode[done] += 1
            self.restarting[done] = True  # EnvPool resets an environment whose episode ended when it is sent next
            if np.any(self.episode[done] >= self.episodes):  # a policy ran its last episode
                self.rows = self.rows[self.episode[self.rows] < self.episodes]
                if 2 * len(self.rows) <= len(self.computed):  # the forward pass drops them once half have ended
                    self.computed, self.acting = self.rows, self.policies.select(self.members[self.rows])

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()


TORCH_THREADS = 1
"""Torch's threads while EnvPool steps: the forward pass is NumPy's, on this thread, and a torch operation (selecting
the running policies) would wake torch's OpenMP threads, which spin on the cores EnvPool's threads step on."""


def run_envpool(task, policies: ActingBatch, seed: int, episodes: int, common_initial_states: bool = False):
    """Every episode of every policy of the batch.

    Parameters
    ----------
    task : GymTask with an EnvPool id (:func:`taskcomplexity.tasks.envpool_ids.envpool_id`)
    policies : ActingBatch of P policies (indices n)
    seed : int
        Run seed (the environments' seeds, :func:`environment_seeds`).
    episodes : int
        M.
    common_initial_states : bool
        Every policy's environment draws the same initial states.

    Returns
    -------
    (returns, steps, success) : ndarrays (P, M) float64, int64, bool (success: always False: EnvPool's MuJoCo and
    DM Control tasks report none).
    """
    n_pol = len(policies)
    seeds = environment_seeds(seed, policies.indices, common_initial_states)
    returns = np.zeros((n_pol, episodes))
    steps = np.zeros((n_pol, episodes), dtype=np.int64)
    groups = [_Group(task, policies, rows, episodes, returns, steps)
              for rows in np.array_split(np.arange(n_pol), min(POOLS, n_pol))]
    threads = torch.get_num_threads()
    torch.set_num_threads(TORCH_THREADS)
    try:
        for group in groups:
            group.open(seeds)
        with torch.no_grad():
            for group in groups:  # each pool's first step starts while the next one's actions are computed
                group.send()
            while any(group.stepping for group in groups):
                for group in groups:
                    if group.stepping:
                        group.receive()
                        group.send()
    finally:
        torch.set_num_threads(threads)
        for group in groups:
            group.close()
    return returns, steps, np.zeros((n_pol, episodes), dtype=bool)


class EnvPoolRunner(Runner):
    """The ``envpool`` backend's runner: :func:`run_envpool` for each batch (a pool of its policies' environments)."""

    def run(self, policies: ActingBatch, plan: Plan) -> ReturnChunk:
        return ReturnChunk(policies.indices.copy(),
                           *run_envpool(self.task, policies, plan.seed, plan.episodes, plan.common_initial_states))
