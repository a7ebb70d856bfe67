"""The pieces of a SAC run, one ``make_<thing>`` per piece, each from explicit arguments.

Everything is a TorchRL component: any task's gymnasium env (``task.make_env()``; the reaching arms'
goal-conditioned view for HER) behind :class:`~torchrl.envs.GymWrapper`, a
tanh-Normal :class:`~torchrl.modules.ProbabilisticActor`, :class:`~torchrl.modules.ValueOperator`
critics on :class:`~torchrl.modules.MLP`, :class:`~torchrl.objectives.SACLoss` with
:class:`~torchrl.objectives.SoftUpdate`, the synchronous :class:`~torchrl.collectors.Collector`
(torchrl 0.14's name for ``SyncDataCollector``) and ``TensorDictReplayBuffer`` /
``HERReplayBuffer`` on ``LazyTensorStorage``.

Several seeds train together: every network holds one parameter set per seed
(:class:`~taskcomplexity.rl.layers.SeedBatchedLinear` as the MLP's ``layer_class``) and the
environment is a vector of one task instance per seed, so data carry a leading seed dimension S:
environment tensordicts are ``(S,)``, minibatches ``(S, batch_size)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import gymnasium
import numpy as np
import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule, TensorDictSequential
from torch import nn
from torchrl.data import Bounded, Categorical, LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs import Compose, DoubleToFloat, EnvBase, GymWrapper, RewardSum, TransformedEnv
from torchrl.envs.libs.gym import default_info_dict_reader
from torchrl.modules import MLP, ProbabilisticActor, TanhNormal, ValueOperator
from torchrl.objectives import SACLoss, SoftUpdate, ValueEstimators

from taskcomplexity.rl.collectors import Collector
from taskcomplexity.rl.her import make_her_replay_buffer
from taskcomplexity.rl.layers import SeedBatchedLinear, reset_seed_parameters
from taskcomplexity.rl.objective import SACObjective
from taskcomplexity.seeding import derive_seed
from taskcomplexity.tasks.base import Task, encode_observations
from taskcomplexity.tasks.goal_env import GoalReachingEnv, join_observation
from taskcomplexity.tasks.spec import TaskSpec

if TYPE_CHECKING:
    from taskcomplexity.rwg.backends import Backend

POLICY_INPUT_KEY = "policy_input"
ACTION_SCALE_LOWER_BOUND = 1e-4  # smallest standard deviation of the Gaussian before tanh
SUCCESS_INFO_KEYS = ("is_success", "success")  # info keys read as "the episode is solved", first found


class _PolicyObservation(gymnasium.ObservationWrapper):
    """A task's observation as the flat float vector the networks read (Discrete: one-hot)."""

    def __init__(self, env: gymnasium.Env):
        super().__init__(env)
        self._source = env.observation_space
        size = int(self._source.n) if isinstance(self._source, gymnasium.spaces.Discrete) else None
        size = size or int(np.prod(self._source.shape, dtype=np.int64))
        self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (size,), dtype=np.float32)

    def observation(self, observation):
        return encode_observations(self._source, np.asarray(observation)[None])[0].astype(np.float32)


def one_env(task: Task, *, goal_conditioned: bool) -> gymnasium.Env:
    """One instance of ``task`` as SAC sees it (time limit included).

    A reaching arm is its PyBullet env, or its goal-conditioned view with ``goal_conditioned``
    (HER). Any other task is ``task.make_env()``; an observation that is not already a flat Box
    (a multi-dimensional Box, a Discrete value) is flattened or one-hot encoded.
    """
    if isinstance(task, TaskSpec):
        from taskcomplexity.tasks.pybullet_env import ReachingEnv

        env: gymnasium.Env = ReachingEnv(task=task)
        if goal_conditioned:
            env = GoalReachingEnv(env)
        return gymnasium.wrappers.TimeLimit(env, max_episode_steps=task.max_steps)
    env = task.make_env()
    space = env.observation_space
    if not (isinstance(space, gymnasium.spaces.Box) and len(space.shape) == 1):
        env = _PolicyObservation(env)
    return env


def success_info_key(task: Task) -> str | None:
    """The info key in which ``task``'s env reports success (:data:`SUCCESS_INFO_KEYS`), or None.

    Probed on one fresh instance: the keys of the reset's info and of one step's info (a sampled
    action). The reaching arms report none (their success is measured from the observation).
    """
    if isinstance(task, TaskSpec):
        return None
    env = task.make_env()
    try:
        _, info = env.reset(seed=0)
        keys = set(info)
        env.action_space.seed(0)
        keys |= set(env.step(env.action_space.sample())[-1])
    finally:
        env.close()
    return next((key for key in SUCCESS_INFO_KEYS if key in keys), None)


def make_env(
    task: Task, num_envs: int, *, goal_conditioned: bool, success_key: str | None = None, backend: Backend | None = None
) -> TransformedEnv:
    """``num_envs`` independent instances of ``task`` stepped together, as one TorchRL environment.

    A gymnasium vector env with auto-reset disabled (TorchRL resets finished instances itself) wrapped by
    :class:`~torchrl.envs.GymWrapper`, with ``DoubleToFloat`` (float32 observations) and ``RewardSum``
    (``episode_reward``: the return so far). Batch size ``(num_envs,)``. The vector is a ``SyncVectorEnv`` of
    :func:`one_env`, or, with a ``backend`` (:func:`taskcomplexity.rl.settings.env_backend`), its
    :attr:`~taskcomplexity.rwg.backends.Backend.sac_env` (``batched``:
    :class:`~taskcomplexity.tasks.batched_vector.BatchedReachingVector`: the same draws, steps and episode ends,
    computed by one kernel call). With ``success_key``, the env's ``info[success_key]`` is read into the
    tensordicts under that key.

    Seed it through its reset: ``env.reset(seed=[...])`` (one seed per instance).
    """

    def one() -> gymnasium.Env:
        return one_env(task, goal_conditioned=goal_conditioned)

    if backend is not None:
        from pkgutil import resolve_name

        vector = resolve_name(backend.sac_env)(task, num_envs, goal_conditioned=goal_conditioned)
    else:
        vector = gymnasium.vector.SyncVectorEnv(
            [one] * num_envs, autoreset_mode=gymnasium.vector.AutoresetMode.DISABLED
        )
    base = GymWrapper(vector)
    if success_key is not None:
        flag = Categorical(2, shape=(num_envs, 1), dtype=torch.bool)
        base.set_info_dict_reader(default_info_dict_reader([success_key], spec={success_key: flag}))
    return TransformedEnv(base, Compose(DoubleToFloat(), RewardSum()))


def action_bounds(task: Task) -> tuple[float | torch.Tensor, float | torch.Tensor]:
    """Low and high bounds of ``task``'s Box action space, float32 tensors (n_act,).

    Plain floats when every dimension shares them (the arms' [−1, 1]), which keeps TorchRL's
    ``TanhNormal`` on its scalar path.
    """
    space = task.action_space
    low = np.asarray(space.low, dtype=np.float32).reshape(-1)
    high = np.asarray(space.high, dtype=np.float32).reshape(-1)
    if np.all(low == low[0]) and np.all(high == high[0]):
        return float(low[0]), float(high[0])
    return torch.as_tensor(low), torch.as_tensor(high)


class _TaskObservation(nn.Module):
    """(goal-free observation, desired goal) → the task's observation vector (see ``goal_env``)."""

    def __init__(self, task: TaskSpec):
        super().__init__()
        self.task = task

    def forward(self, observation: torch.Tensor, desired_goal: torch.Tensor) -> torch.Tensor:
        return join_observation(self.task, observation, desired_goal)


def _input_modules(task: TaskSpec, goal_conditioned: bool) -> tuple[list[TensorDictModule], str]:
    """Modules preparing the network input, and its key: the task observation (rebuilt for the goal with HER)."""
    if goal_conditioned:
        module = TensorDictModule(
            _TaskObservation(task), in_keys=["observation", "desired_goal"], out_keys=[POLICY_INPUT_KEY]
        )
        return [module], POLICY_INPUT_KEY
    return [], "observation"


def make_actor_critic(
    task: Task,
    *,
    hidden_sizes: Sequence[int],
    seeds: Sequence[int],
    goal_conditioned: bool,
    device: torch.device | str = "cpu",
) -> tuple[ProbabilisticActor, list[TensorDictSequential]]:
    """A tanh-Normal actor and two Q-networks, each holding one parameter set per seed.

    Parameters
    ----------
    task : Task
        Input size (``task.observation_size``: 9 or 10 values for the arms) and action size, and the
        action bounds (the tanh output is scaled affinely into the Box's [low, high]).
    hidden_sizes : sequence of int
        Hidden widths of every MLP (ReLU).
    seeds : sequence of int
        One parameter set per seed, initialised like ``nn.Linear`` from that seed alone.
    goal_conditioned : bool
        Read ``observation`` and ``desired_goal`` (HER) instead of the task ``observation``; the task
        observation is rebuilt from them, so both variants see the same inputs.
    device : torch.device or str, default 'cpu'
        Where the networks live; they are initialised on the CPU first, so every device starts a seed from the
        same parameters.

    Returns
    -------
    actor : ProbabilisticActor
        Writes ``action`` (S, ..., n_act) in the Box's [low, high] (TorchRL's ``TanhNormal`` with
        ``low``/``high``: low + (tanh(u) + 1)·(high − low)/2 of a Gaussian sample u, or of its mean
        under ``ExplorationType.DETERMINISTIC``); [−1, 1] for the arms.
    critics : list of two TensorDictSequential
        Write ``state_action_value`` (S, ..., 1).
    """
    layer = {"layer_class": SeedBatchedLinear, "layer_kwargs": {"seeds": len(seeds)}}
    n_obs, n_act = task.observation_size, task.action_size
    body = nn.Sequential(
        MLP(in_features=n_obs, out_features=2 * n_act, num_cells=list(hidden_sizes), activation_class=nn.ReLU, **layer),
        NormalParamExtractor(scale_mapping="biased_softplus_1.0", scale_lb=ACTION_SCALE_LOWER_BOUND),
    )
    reset_seed_parameters(body, [derive_seed(seed, "actor") for seed in seeds])
    inputs, input_key = _input_modules(task, goal_conditioned)
    low, high = action_bounds(task)
    actor = ProbabilisticActor(
        TensorDictSequential(*inputs, TensorDictModule(body, in_keys=[input_key], out_keys=["loc", "scale"])),
        in_keys=["loc", "scale"],
        spec=Bounded(low, high, (n_act,)),
        distribution_class=TanhNormal,
        distribution_kwargs={"low": low, "high": high},
    )
    critics = []
    for index in range(2):
        mlp = MLP(
            in_features=n_obs + n_act, out_features=1, num_cells=list(hidden_sizes), activation_class=nn.ReLU, **layer
        )
        reset_seed_parameters(mlp, [derive_seed(seed, "critic", index) for seed in seeds])
        inputs, input_key = _input_modules(task, goal_conditioned)
        critics.append(TensorDictSequential(*inputs, ValueOperator(mlp, in_keys=[input_key, "action"])))
    if torch.device(device).type != "cpu":
        actor, critics = actor.to(device), [critic.to(device) for critic in critics]
    return actor, critics


def make_loss(
    actor: ProbabilisticActor,
    critics: list[TensorDictSequential],
    *,
    gamma: float,
    alpha: float,
    loss_function: str,
) -> SACLoss:
    """TorchRL's SAC loss (v2: no state-value network) with twin Q-networks and a fixed α.

    The critic target is the one-step TD target r + γ·(1 − terminated)·(min_i Q'_i(s', a') − α log π(a'|s')),
    a' ~ π(·|s'), Q'_i the target networks.
    """
    loss = SACLoss(
        actor,
        critics,
        num_qvalue_nets=len(critics),
        loss_function=loss_function,
        alpha_init=alpha,
        fixed_alpha=True,
        target_entropy=-float(actor.spec["action"].shape[-1]),
    )
    loss.make_value_estimator(ValueEstimators.TD0, gamma=gamma)
    return loss


def make_objective(loss: SACLoss, actor: ProbabilisticActor, task: Task, *, gamma: float, loss_function: str,
                   goal_conditioned: bool) -> SACObjective:
    """``loss``'s objective evaluated directly on its parameters (:class:`~taskcomplexity.rl.objective.SACObjective`:
    the same numbers, less overhead per update); make it after a checkpoint's parameters are loaded."""
    policy_input = _TaskObservation(task) if goal_conditioned else None
    return SACObjective(loss, actor, gamma=gamma, loss_function=loss_function, policy_input=policy_input)


def make_target_updater(loss: SACLoss, *, tau: float) -> SoftUpdate:
    """Polyak averaging of the target critics, θ' ← (1 − τ)θ' + τθ, on every ``step()``."""
    return SoftUpdate(loss, tau=tau)


def make_optimisers(loss: SACLoss, *, actor_lr: float, critic_lr: float) -> tuple[torch.optim.Adam, torch.optim.Adam]:
    """Adam for the actor and Adam for both critics (element-wise, so the seeds stay independent)."""
    actor_params = list(loss.actor_network_params.flatten_keys().values())
    critic_params = list(loss.qvalue_network_params.flatten_keys().values())
    return (
        torch.optim.Adam(actor_params, lr=actor_lr, fused=True),
        torch.optim.Adam(critic_params, lr=critic_lr, fused=True),
    )


def make_collector(
    env: EnvBase,
    policy: ProbabilisticActor,
    *,
    frames_per_batch: int,
    init_random_frames: int,
    device: torch.device | str = "cpu",
) -> Collector:
    """TorchRL's synchronous collector: ``frames_per_batch`` frames (all seeds) per batch, endless.

    The first ``init_random_frames`` frames use uniformly random actions (the warm-up); finished
    episodes are reset automatically. Batches are shaped ``(S, frames_per_batch // S)``. Off the CPU
    (``device``), the environments still step on the CPU; the policy acts on ``device`` and the batches are
    stored there, beside the replay buffers.
    """
    devices = {}
    if torch.device(device).type != "cpu":
        devices = {"env_device": "cpu", "policy_device": device, "storing_device": device}
    return Collector(
        env,
        policy,
        frames_per_batch=frames_per_batch,
        total_frames=-1,
        init_random_frames=init_random_frames,
        split_trajs=False,
        # The policy is not recurrent: it needs no InitTracker/primer transforms on the env.
        auto_register_policy_transforms=False,
        **devices,
    )


def make_replay_buffers(
    task: Task,
    *,
    num_buffers: int,
    capacity: int,
    her: bool,
    her_ratio: float,
    her_strategy: str,
    device: torch.device | str = "cpu",
) -> list[TensorDictReplayBuffer]:
    """One replay buffer per seed: uniform sampling with replacement from a ``LazyTensorStorage`` (on ``device``).

    With ``her`` the buffers are :class:`~torchrl.data.HERReplayBuffer` (see ``taskcomplexity.rl.her``).
    """
    if her:
        return [
            make_her_replay_buffer(task, capacity, her_ratio=her_ratio, strategy=her_strategy,
                                   storage=_storage(capacity, device))
            for _ in range(num_buffers)
        ]
    return [TensorDictReplayBuffer(storage=_storage(capacity, device)) for _ in range(num_buffers)]


def _storage(capacity: int, device: torch.device | str) -> LazyTensorStorage:
    """A ``LazyTensorStorage`` of ``capacity`` transitions, on ``device`` when it is not the CPU."""
    if torch.device(device).type == "cpu":
        return LazyTensorStorage(capacity)
    return LazyTensorStorage(capacity, device=device)
