"""What the RWG stage checks of an environment before (and while) it caches returns from it.

A cached return matrix is a promise that the same (task, policy n, episode e, seed) gives the same
returns again, and that the returns are numbers. A researcher's own env can break that promise in ways
the RWG loop would otherwise turn into silent garbage or a traceback deep in NumPy: a ``reset`` or a
``step`` that draws random numbers its seed does not fix (a rerun gives other returns), observations that
do not match the declared observation space, rewards that are not one finite number. Each is refused with
:class:`EnvContractError`, whose message names the env id and what it did.

An exception the env itself raises in ``reset`` or ``step`` becomes an :class:`~taskcomplexity.errors.EnvError`
naming where it raised (policy, episode, step) and the env's own message; the env's traceback goes to the
run log.
"""

from __future__ import annotations

import logging
import math

import gymnasium
import numpy as np
from gymnasium import spaces

from taskcomplexity.errors import EnvError, TaskComplexityError
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, decode_actions, encode_observations

log = logging.getLogger(__name__)

CHECK_EPISODES = 2
"""Episodes the check of steps replays, each whole (to its end or the task's step limit) and twice with the same
actions: policy 0's first ones, reset with the run's seeds. The check samples these 2 of the N × M episodes: an
unseeded draw that every episode makes, at any step, is found; one that only rare episodes make may not be."""
SCALAR_KINDS = "biuf"
"""NumPy dtype kinds of a reward: bool, signed and unsigned integer, float."""


class EnvContractError(TaskComplexityError):
    """An environment breaks what a cached return matrix relies on (seeded resets and steps, observations in
    the declared space, rewards that are one finite number); the message names the env id and what it returned."""


def run_log() -> str:
    """Where a traceback logged at DEBUG is kept, for messages: ``the run log <path>`` (the root logger's file,
    which an entry point's job logging sets up), or ``the run log`` when no file is configured."""
    for handler in logging.getLogger().handlers:
        if isinstance(handler, logging.FileHandler):
            return f"the run log {handler.baseFilename}"
    return "the run log"


def env_raised(task: Task, error: Exception, where: str) -> EnvError:
    """The :class:`EnvError` of an exception the env raised at ``where``; its traceback goes to the run log (DEBUG:
    the file, not the console). Raise the result ``from error`` so the traceback stays attached."""
    log.debug("task.env_id=%s raised in %s", task.env_id, where, exc_info=error)
    text = " ".join(str(error).split())  # one line, whatever the env's message looks like
    own = f"{type(error).__name__}: {text}" if text else type(error).__name__
    return EnvError(f"task.env_id={task.env_id} raised in {where}: {own} (the traceback is in {run_log()})")


def _place(call: str, policy: int | None, episode: int | None) -> str:
    """``call`` located in the run (``of episode e of policy n``) or in the check before it (no policy)."""
    if policy is None:
        return f"{call} of the env check before RWG"
    return f"{call} of episode {episode} of policy {policy}"


def reset_env(task: Task, env: gymnasium.Env, seed: int, *, policy: int | None = None,
              episode: int | None = None) -> np.ndarray:
    """The observation of ``env.reset(seed=seed)``, checked against the declared space (:func:`check_observation`).

    ``policy`` and ``episode`` say which episode starts, for messages (None: the check before RWG).
    """
    try:
        observation = env.reset(seed=seed)[0]
    except TaskComplexityError:
        raise
    except Exception as error:
        raise env_raised(task, error, _place(f"reset(seed={seed})", policy, episode)) from error
    return check_observation(task, observation, seed=seed, policy=policy, episode=episode)


def step_env(task: Task, env: gymnasium.Env, action, step: int, *, policy: int | None = None,
             episode: int | None = None, seed: int | None = None) -> tuple:
    """``env.step(action)``, as the env returns it; an exception the env raises becomes an :class:`EnvError`.

    ``step`` counts from 1; ``policy`` and ``episode`` (in the run) or ``seed`` (the reset seed, in the check
    before RWG) say where, for messages.
    """
    try:
        return env.step(action)
    except TaskComplexityError:
        raise
    except Exception as error:
        raise step_raised(task, error, step, policy=policy, episode=episode, seed=seed) from error


def step_raised(task: Task, error: Exception, step: int, *, policy: int | None = None, episode: int | None = None,
                seed: int | None = None) -> EnvError:
    """The :class:`EnvError` of an exception ``env.step`` raised at ``step`` (where, as :func:`step_env` says it):
    for a loop that calls ``env.step`` itself, once per environment step."""
    call = f"step {step}" if policy is not None else f"step {step} after reset(seed={seed})"
    return env_raised(task, error, _place(call, policy, episode))


def check_observation(task: Task, observation, *, seed: int | None = None, policy: int | None = None,
                      episode: int | None = None, step: int | None = None) -> np.ndarray:
    """The observation as an array, after checking it against ``task.observation_space``.

    Box: the space's shape; Discrete: one integer in ``[start, start + n)``. The keywords say where it
    came from, for the message: ``reset(seed=seed)``, or step ``step`` (from 1) of ``policy``'s ``episode``.
    """
    space = task.observation_space
    value = np.asarray(observation)
    if value.shape == space.shape and isinstance(space, spaces.Box):  # the common case first (once per step)
        return value
    if isinstance(space, spaces.Discrete):
        if value.shape == () and np.issubdtype(value.dtype, np.integer) \
                and int(space.start) <= int(value) < int(space.start + space.n):
            return value
        seen = f"value {value.tolist()!r}" if value.size <= 4 else f"shape {value.shape}"
    elif value.shape == tuple(space.shape):
        return value
    else:
        seen = f"shape {value.shape}"
    call = f"reset(seed={seed})" if step is None else f"step {step}"
    at = f" of policy {policy}, episode {episode}" if policy is not None else ""
    raise EnvContractError(f"task.env_id={task.env_id}: {call}{at} returned an observation of {seen}, which does "
                           f"not match the declared observation space {space}")


def reward_value(task: Task, reward, where: str) -> float:
    """The reward as a float: a number, or the one value of an array holding one number (``np.array([r])``
    gives the same float as ``r``); anything else is refused, naming ``where`` it was returned."""
    if isinstance(reward, (float, int, np.floating, np.integer)):  # bool is an int
        return float(reward)
    value = np.asarray(reward)
    if value.size == 1 and value.dtype.kind in SCALAR_KINDS:
        return float(value.reshape(()))
    seen = f"type {type(reward).__name__}"
    if value.ndim:
        seen += f", shape {value.shape}"
    if value.dtype.kind not in SCALAR_KINDS:
        seen += f", dtype {value.dtype}"
    raise EnvContractError(f"task.env_id={task.env_id} returned a reward of {seen} at {where}; a reward must be "
                           f"one number (a float, an int, or an array holding one number)")


def check_reward(task: Task, reward, policy: int, episode: int, step: int) -> float:
    """The reward as a float (:func:`reward_value`), refused when it is NaN or infinite (``step`` counts from 1)."""
    if isinstance(reward, (float, int, np.floating, np.integer)):  # a number (where it was returned is not needed)
        value = float(reward)
    else:
        value = reward_value(task, reward, f"policy {policy}, episode {episode}, step {step}")
    if not math.isfinite(value):
        raise EnvContractError(f"task.env_id={task.env_id} returned a non-finite reward ({value}) at policy "
                               f"{policy}, episode {episode}, step {step}; returns must be finite to be cached")
    return value


def check_env(task: Task, seed: int) -> None:
    """Before any return is computed: the env's resets and steps are seeded (:func:`check_resets`,
    :func:`check_steps`), else the cache could not serve its returns again."""
    env = task.make_env()
    try:
        check_resets(task, env, seed)
        check_steps(task, env, seed)
    finally:
        env.close()


def check_resets(task: Task, env: gymnasium.Env, seed: int) -> None:
    """The reset observation is in the declared space, and two resets with the same seed give the same one."""
    reset_seed = int(episode_reset_seeds(seed, np.array([0]), np.array([0]))[0])
    first = reset_env(task, env, reset_seed)
    again = reset_env(task, env, reset_seed)
    space = task.observation_space
    if not np.array_equal(encode_observations(space, first[None]), encode_observations(space, again[None]),
                          equal_nan=True):
        raise EnvContractError(f"task.env_id={task.env_id} is not reproducible: two resets with seed {reset_seed} "
                               f"gave different observations (the env's reset ignores its seed), so the cache "
                               f"cannot serve its returns")


def check_steps(task: Task, env: gymnasium.Env, seed: int) -> None:
    """Two replays of the same whole episodes (same reset seeds, same actions) give exactly the same
    observations, rewards and end flags: else the env's steps draw random numbers its seed does not fix."""
    refuse_differences(task, replay(task, env, seed), replay(task, env, seed), "",
                       "does the env draw random numbers outside its seeded generator self.np_random, or keep state "
                       "its reset does not restore?")


def refuse_differences(task: Task, first: list, again: list, on: str, cause: str) -> None:
    """Refuse, naming the episode, the step and what differs, two replays of the check episodes (``first`` and
    ``again``, as :func:`replay` gives them) that differ; ``on``: where they ran (" on backend=…" or ""), ``cause``:
    the question the message asks of the env."""
    for (reset_seed, one), (_, other) in zip(first, again, strict=True):
        difference = first_difference(one, other)
        if difference is not None:
            step, what = difference
            at = "at reset" if step == 0 else f"at step {step}"
            raise EnvContractError(
                f"task.env_id={task.env_id} is not reproducible{on}: two replays of the episode reset with seed "
                f"{reset_seed}, with the same actions, gave a different {what} {at} ({cause}), so the cache cannot "
                f"serve its returns")


def replay(task: Task, env: gymnasium.Env, seed: int) -> list[tuple[int, list[dict]]]:
    """The check episodes under fixed actions: per episode its reset seed and one record per step (step 0:
    the reset observation; step k: the observation, reward and end flags ``env.step`` returned)."""
    reset_seeds = episode_reset_seeds(seed, np.zeros(CHECK_EPISODES, dtype=np.int64), np.arange(CHECK_EPISODES))
    outputs = check_outputs(task, seed)
    episodes = []
    for reset_seed, episode_outputs in zip(reset_seeds.tolist(), outputs, strict=True):
        records = [{"observation": np.array(reset_env(task, env, reset_seed))}]
        for step, action in enumerate(decode_actions(task.action_space, episode_outputs), start=1):
            observation, reward, terminated, truncated, _ = step_env(task, env, action, step, seed=reset_seed)
            where = f"step {step} after reset(seed={reset_seed}) of the env check before RWG"
            records.append({"observation": np.array(observation), "reward": reward_value(task, reward, where),
                            "terminated flag": bool(terminated), "truncated flag": bool(truncated)})
            if terminated or truncated:
                break
        episodes.append((reset_seed, records))
    return episodes


def check_outputs(task: Task, seed: int) -> np.ndarray:
    """The fixed policy outputs of the check episodes, (CHECK_EPISODES, task.max_steps, action size) in [-1, 1]."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (CHECK_EPISODES, task.max_steps, task.action_size))


def check_vector_env(task: Task, seed: int) -> None:
    """The ``vector`` backend's check of a researcher's vector env, before any return is computed: the check
    episodes (:data:`CHECK_EPISODES`, whole) replayed twice, side by side in one vector env, give exactly the same
    observations, rewards and end flags (:func:`replay_vector`); else its steps draw random numbers its seeds do
    not fix."""
    from taskcomplexity.tasks.vectorised import make_vector

    env = make_vector(task, CHECK_EPISODES)
    try:
        first, again = replay_vector(task, env, seed), replay_vector(task, env, seed)
    finally:
        env.close()
    refuse_differences(task, first, again, " on backend=vector",
                       "does the vector env draw random numbers outside the generators its reset(seed=[…]) seeds?")


def replay_vector(task: Task, env, seed: int) -> list[tuple[int, list[dict]]]:
    """:func:`replay` on a vector env of :data:`CHECK_EPISODES` environments, one check episode each, stepped
    together; an environment's records end with its episode."""
    reset_seeds = episode_reset_seeds(seed, np.zeros(CHECK_EPISODES, dtype=np.int64), np.arange(CHECK_EPISODES))
    outputs = check_outputs(task, seed)
    observations, _ = env.reset(seed=[int(s) for s in reset_seeds])
    records = [[{"observation": np.array(o)}] for o in observations]
    running = np.ones(CHECK_EPISODES, dtype=bool)
    for step in range(1, task.max_steps + 1):
        actions = decode_actions(task.action_space, outputs[:, step - 1])
        observations, rewards, terminated, truncated, _ = env.step(actions)
        for i in np.flatnonzero(running):
            where = f"step {step} after reset(seed={int(reset_seeds[i])}) of the env check before RWG"
            records[i].append({"observation": np.array(observations[i]),
                               "reward": reward_value(task, np.asarray(rewards)[i], where),
                               "terminated flag": bool(np.asarray(terminated)[i]),
                               "truncated flag": bool(np.asarray(truncated)[i])})
        running &= ~(np.asarray(terminated, dtype=bool) | np.asarray(truncated, dtype=bool))
        if not running.any():
            break
    return list(zip(reset_seeds.tolist(), records, strict=True))


def first_difference(one: list[dict], other: list[dict]) -> tuple[int, str] | None:
    """(step, what) of the first record entry that differs between two replays of an episode, or None."""
    for step, (a, b) in enumerate(zip(one, other, strict=False)):
        for what in a:
            if not same(a[what], b[what]):
                return step, what
    if len(one) != len(other):
        return min(len(one), len(other)), "episode length"
    return None


def same(a, b) -> bool:
    """Exactly equal values: same shape, same dtype, same elements (NaN equals NaN)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))


