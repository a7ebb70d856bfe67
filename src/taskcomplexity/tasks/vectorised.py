"""Which gymnasium tasks register a vector env that the ``vector`` RWG backend can run
(:mod:`taskcomplexity.rwg.vector_backend`): a ``vector_entry_point`` whose ``reset(seed=[…])`` seeds each of its
environments from its own seed."""

from __future__ import annotations

import functools

import gymnasium
import numpy as np


def make_vector(task, num_envs: int):
    """The task's vector env of ``num_envs`` environments, with its arguments and episode limit."""
    return gymnasium.make_vec(task.spec.id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                              max_episode_steps=task.max_steps, **dict(task.kwargs))


@functools.cache
def _seeds_each(env_id: str, kwargs: tuple, max_steps: int) -> bool:
    from types import SimpleNamespace

    task = SimpleNamespace(spec=gymnasium.spec(env_id), kwargs=dict(kwargs), max_steps=max_steps)
    try:
        env = make_vector(task, 2)
    except Exception:  # noqa: BLE001 — a vector env that cannot be made here is not offered (the gym backend is)
        return False
    try:
        a, _ = env.reset(seed=[11, 12])
        b, _ = env.reset(seed=[12, 11])
        c, _ = env.reset(seed=[11, 13])
        first, swapped, other = (np.asarray(x, dtype=np.float64).reshape(2, -1) for x in (a, b, c))
        return bool(np.array_equal(first[0], swapped[1]) and np.array_equal(first[1], swapped[0])
                    and np.array_equal(first[0], other[0]))
    except Exception:  # noqa: BLE001 — e.g. a reset that takes one int seed for all its environments
        return False
    finally:
        env.close()


def seeds_each(task) -> bool:
    """Whether ``task`` (a :class:`~taskcomplexity.tasks.gym_task.GymTask`) registers a vector env whose
    ``reset(seed=[…])`` seeds each environment from its own seed: probed once per task (two environments reset with
    swapped seeds swap their observations, and one keeps its own when the other's seed changes)."""
    spec = getattr(task, "spec", None)
    if spec is None or spec.vector_entry_point is None:
        return False
    kwargs = tuple(sorted(dict(task.kwargs).items()))
    try:
        hash(kwargs)
    except TypeError:  # an argument that is a list or a dict: probed each time
        return _seeds_each.__wrapped__(spec.id, kwargs, int(task.max_steps))
    return _seeds_each(spec.id, kwargs, int(task.max_steps))
