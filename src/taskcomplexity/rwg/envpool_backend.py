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

**Per step.** One forward pass over the policies whose episodes still run (the batch drops a policy once it has run
its M episodes) and one ``step`` of exactly their environments; an environment whose episode ended is reset
explicitly before its next episode, so EnvPool's auto-reset never runs.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.cores import usable_cores
from taskcomplexity.errors import ConfigError, EnvError
from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.gym_backend import ENVIRONMENTS_IN_FLIGHT
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.envpool_ids import ENVPOOL_EXTRA, envpool_id, installed

POLICIES_PER_POOL = ENVIRONMENTS_IN_FLIGHT
"""Policies of one chunk, each with one environment in the pool (256): EnvPool keeps 2 cores busy stepping 256
environments in lock-step, ~1.1–1.4 with 64. A DM Control environment holds ~12 MB and takes ~60 ms to make, a
MuJoCo one ~0.7 MB and ~2 ms."""
RESET_STREAM = 2**31 - 1
"""The episode index whose reset seed (seed, n, ·) seeds policy n's environment: outside any run's episodes, so the
generator is not one a gym-backend episode of the same run is reset with."""


def simulator(task, backend: str) -> str | None:
    """What simulates ``task`` on ``backend`` beyond the task's own identity, for the RWG key: EnvPool's version
    on ``envpool`` (its own MuJoCo build and reset generator), None elsewhere."""
    if backend != "envpool":
        return None
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
                             "task.kwargs") + " (allowed: auto, " + ", ".join(task.backends) + ")")
    import envpool

    return envpool.make(name, env_type="gymnasium", num_envs=len(seeds), env_seed=[int(s) for s in seeds],
                        max_episode_steps=int(task.max_steps), num_threads=min(usable_cores(), len(seeds)))


def observation_keys(pool) -> tuple[str, ...] | None:
    """The keys of a pool's dict observations in its space's order (None for an array observation)."""
    space = pool.observation_space
    return tuple(space.spaces) if isinstance(space, spaces.Dict) else None


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
    pool = make_pool(task, environment_seeds(seed, policies.indices, common_initial_states))
    keys = observation_keys(pool)
    space_out = task.action_space
    box = isinstance(space_out, spaces.Box)
    returns = np.zeros((n_pol, episodes))
    steps = np.zeros((n_pol, episodes), dtype=np.int64)
    episode = np.zeros(n_pol, dtype=np.int64)  # the episode each policy's environment runs
    obs = np.zeros((n_pol, task.observation_size))
    try:
        first, _ = pool.reset()
        obs[:] = _flat(first, keys)
        rows = np.arange(n_pol)  # the policies whose episodes still run, ascending (the rows of ``acting``)
        acting = policies
        with torch.no_grad():
            while rows.size:
                outputs = acting.act(torch.from_numpy(obs[rows][:, None, :])).numpy()
                actions = decode_actions(space_out, acting.unit_outputs(outputs, box)[:, 0, :])
                new, reward, terminated, truncated, info = pool.step(actions, env_id=rows)
                at = np.argsort(np.asarray(info["env_id"]), kind="stable")  # EnvPool's answer in the rows' order
                e = episode[rows]
                reward = np.asarray(reward, dtype=np.float64)[at]
                if not np.all(np.isfinite(reward)):
                    bad = int(np.flatnonzero(~np.isfinite(reward))[0])
                    raise EnvError(f"task.env_id={task.env_id} on EnvPool returned reward {reward[bad]} for policy "
                                   f"{int(policies.indices[rows[bad]])}, episode {int(e[bad])}, step "
                                   f"{int(steps[rows[bad], e[bad]]) + 1}")
                returns[rows, e] += reward
                steps[rows, e] += 1
                obs[rows] = _flat(new, keys)[at]
                ended = (np.asarray(terminated) | np.asarray(truncated))[at] | (steps[rows, e] >= task.max_steps)
                if ended.any():
                    done = rows[ended]
                    episode[done] += 1
                    again = done[episode[done] < episodes]
                    if again.size:
                        restarted, info = pool.reset(again)
                        obs[again] = _flat(restarted, keys)[np.argsort(np.asarray(info["env_id"]), kind="stable")]
                    if again.size < done.size:  # a policy ran its last episode: the forward pass drops it
                        rows = rows[episode[rows] < episodes]
                        acting = policies.select(rows)
    finally:
        pool.close()
    return returns, steps, np.zeros((n_pol, episodes), dtype=bool)
