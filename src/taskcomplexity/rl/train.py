"""Train SAC (+HER) on a task (a reaching arm or any gymnasium id with Box actions); return its learning curve.

A run (``_Run.train``) reads as a sequence of ``make_<thing>`` calls (see
:mod:`taskcomplexity.rl.factories`), then the loop: collect ``collect_steps`` steps per seed, store
them, make ``collect_steps × updates_per_step`` gradient updates (none during the warm-up), evaluate
every ``eval_every`` steps, checkpoint every ``checkpoint_every`` steps.

Seeds
-----
:func:`train_sac_seeds` trains several seeds in one vectorised run (one environment and one
parameter set per seed, one batched update for all); :func:`train_sac` is the one-seed case. Network
initialisation, the training environments' episodes and the evaluation episodes of seed s are
drawn from streams derived from s alone. The other random draws of a run (warm-up actions, the
policy's action noise, minibatch indices, HER goals) come from one torch generator seeded from the
tuple of seeds; so a run is a deterministic function of (task, settings, seeds): the same call gives
the same curve, while seed 3 trained alone and seed 3 trained with seeds 0–4 are different (equally
valid) samples.

Resume guarantee
----------------
Every ``checkpoint_every`` steps (and at the end) the run saves the networks, target networks,
optimisers, replay buffers, the generator states (torch, NumPy, Python) and the curve so far,
atomically. The training environments are reset at the same boundaries, from seeds derived from
(seed, segment index), so the state of a run at a boundary is entirely in its checkpoint (PyBullet's
state after a reset does not depend on the world's history, which ``tests/rl/test_resume.py`` relies
on: its resumed runs start from fresh PyBullet worlds). Hence: a run interrupted at any
point and restarted with the same arguments produces **exactly the same curve** as an uninterrupted
run — every column bit for bit except ``time/seconds`` (wall-clock) — provided it runs on the same
machine with the same torch build and thread count (floating-point reductions may differ across
thread counts or CPUs). Work since the last checkpoint is redone. A checkpoint carries the SHA-256 of
its bytes (:mod:`taskcomplexity.rl.checkpoint`): a damaged one is discarded with a warning and its
run starts afresh, which gives the same curve again. The forced reset truncates the
episode in progress at each boundary (one episode per ``checkpoint_every`` steps and seed); that
transition is stored as truncated (not terminated), so the critic's targets are unaffected, and it
bounds the episode for HER.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import random
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import torch
from tensordict import TensorDictBase
from torchrl.data import TensorDictReplayBuffer
from torchrl.envs import EnvBase
from torchrl.modules import ProbabilisticActor
from torchrl.objectives import SACLoss, SoftUpdate
from tqdm.auto import tqdm

from taskcomplexity.errors import ArtefactError, ConfigError
from taskcomplexity.rl.checkpoint import load_checkpoint, save_checkpoint
from taskcomplexity.rl.collectors import Collector
from taskcomplexity.rl.curves import CURVE_COLUMNS
from taskcomplexity.rl.evaluation import evaluate
from taskcomplexity.rl.factories import (
    make_actor_critic,
    make_collector,
    make_env,
    make_loss,
    make_objective,
    make_optimisers,
    make_replay_buffers,
    make_target_updater,
    success_info_key,
)
from taskcomplexity.rl.objective import SACObjective
from taskcomplexity.rl.settings import (
    OWN_ENV,
    SACSettings,
    backend_identity,
    device_identity,
    env_backend,
    resolve_device,
    sac_skip_reason,
)
from taskcomplexity.rl.snapshots import ActorSnapshots, actor_layers
from taskcomplexity.seeding import derive_seed
from taskcomplexity.tasks.base import Task
from taskcomplexity.tasks.goal_env import goal_layout
from taskcomplexity.tasks.spec import TaskSpec

log = logging.getLogger(__name__)

CHECKPOINT_FORMAT = 1


def train_sac(
    task: Task,
    settings: SACSettings,
    *,
    seed: int,
    checkpoint_dir: Path | None = None,
    progress: bool = False,
    stop_after: int | None = None,
    solved_return: float | None = None,
) -> pd.DataFrame:
    """Train one seed of SAC (``settings.her``: SAC + HER) on ``task``; return its learning curve.

    Parameters
    ----------
    task : Task
        A reaching arm (:class:`~taskcomplexity.tasks.spec.TaskSpec`) or any task with a Box action
        space (e.g. ``GymTask("Pendulum-v1")``); a Discrete action space raises :class:`ConfigError`.
    settings : SACSettings
        The budget is ``settings.total_steps`` environment steps (resolve a study's budget first with
        :func:`~taskcomplexity.rl.settings.with_budget`).
    seed : int
        Everything random in the run derives from it (see the module notes).
    checkpoint_dir : Path, optional
        Save a checkpoint there every ``settings.checkpoint_every`` steps, and resume from it if one
        exists (a finished run's curve is returned without training).
    progress : bool
        Show a tqdm bar with the latest mean evaluation return.
    stop_after : int, optional
        Stop at the first checkpoint boundary at or after this many steps (after writing the
        checkpoint) and return the partial curve: for time-sliced jobs and tests of resumption.
    solved_return : float, optional
        For a task whose env reports no success in its info: the return that counts an evaluation
        episode as solved (the study entry's ``solved_return``).

    Returns
    -------
    pandas.DataFrame
        One row per evaluation (step 0, every ``eval_every`` steps, and the last step), columns
        :data:`CURVE_COLUMNS`: ``task`` (task id), ``variant`` ("sac" or "sac+her"), ``seed``,
        ``env_step`` (environment steps of this seed so far), ``eval/return_mean`` and
        ``eval/return_std`` (over ``eval_episodes`` deterministic episodes), ``eval/success_rate``
        (fraction of those episodes that were solved: the arms' target reached, the env's
        ``info["is_success"]``/``info["success"]``, or the return reaching ``solved_return``; NaN
        when none of these applies), ``train/episode_return`` (return of
        the latest finished training episode; NaN before the first), ``time/seconds`` (wall-clock
        seconds of training so far, summed over resumptions).
    """
    return train_sac_seeds(
        task, settings, seeds=(seed,), checkpoint_dir=checkpoint_dir, progress=progress, stop_after=stop_after,
        solved_return=solved_return,
    )


def train_sac_seeds(task: Task, settings: SACSettings, **options: Any) -> pd.DataFrame:
    """Train ``seeds`` (default ``settings.seeds``) on ``task``; their curves stacked (see :func:`train_sac`).

    With ``settings.train_seeds_together`` the seeds train in one vectorised run; otherwise one
    after the other, each as :func:`train_sac` (checkpoints in ``checkpoint_dir/seed-<s>``). The
    keyword options are :func:`train_sac_run`'s.
    """
    return train_sac_run(task, settings, **options)[0]


def train_sac_run(
    task: Task,
    settings: SACSettings,
    *,
    seeds: Sequence[int] | None = None,
    checkpoint_dir: Path | None = None,
    progress: bool = False,
    stop_after: int | None = None,
    solved_return: float | None = None,
    bar_position: int | None = None,
) -> tuple[pd.DataFrame, ActorSnapshots | None]:
    """As :func:`train_sac_seeds`, with the actors' snapshots: at step 0 and at every checkpoint boundary
    (every ``checkpoint_every`` steps and the last step), for every seed. ``bar_position``: the progress bar's
    line (tqdm's ``position``) when several runs train at once, each in its own process."""
    seeds = tuple(int(s) for s in (settings.seeds if seeds is None else seeds))
    settings = dataclasses.replace(settings, seeds=seeds).validate()
    task = task.validate()
    refuse_untrainable(task, settings)
    if settings.total_steps is None:
        raise ConfigError(f"no SAC budget for task {task.task_id}: set sac.total_steps (or the study's sac_steps)")
    if settings.train_seeds_together or len(seeds) == 1:
        run = _Run(task, settings, checkpoint_dir, progress, solved_return, bar_position)
        return run.train(stop_after), run.snapshots
    curves, snapshots = [], []
    for seed in seeds:
        directory = None if checkpoint_dir is None else Path(checkpoint_dir) / f"seed-{seed}"
        run = _Run(task, dataclasses.replace(settings, seeds=(seed,)), directory, progress, solved_return,
                   bar_position)
        curves.append(run.train(stop_after))
        snapshots.append(run.snapshots)
    return pd.concat(curves, ignore_index=True), ActorSnapshots.join_seeds(snapshots)


def refuse_untrainable(task: Task, settings: SACSettings) -> None:
    """Raise :class:`ConfigError` for a task SAC cannot train: discrete actions, or HER without a
    goal-conditioned view."""
    reason = sac_skip_reason(task)
    if reason is not None:
        raise ConfigError(f"SAC cannot run on task {task.task_id}: {reason} ({task.action_space}; SAC needs a Box)")
    if settings.her:
        if not isinstance(task, TaskSpec):
            raise ConfigError(f"sac.her=true needs a goal-conditioned view, and task {task.task_id} has none "
                              "(allowed: the reaching arms without an obstacle)")
        goal_layout(task)  # raises ConfigError for an arm without a goal-conditioned view


@dataclass
class _Progress:
    """What a run has done so far (saved in checkpoints)."""

    step: int = 0
    rows: list[dict[str, Any]] = field(default_factory=list)
    latest_return: list[float] = field(default_factory=list)
    elapsed: float = 0.0
    actors: list[dict[str, Any]] = field(default_factory=list)  # snapshots: {step, weights, biases}


@dataclass
class _Parts:
    """The built components of a run."""

    env: EnvBase
    eval_env: EnvBase
    actor: ProbabilisticActor
    loss: SACLoss
    objective: SACObjective
    updater: SoftUpdate
    optimisers: tuple[torch.optim.Optimizer, ...]
    buffers: list[TensorDictReplayBuffer]
    collector: Collector


class _Run:
    """One (vectorised) training run; :meth:`train` builds everything, resumes, loops, cleans up."""

    def __init__(
        self,
        task: Task,
        settings: SACSettings,
        checkpoint_dir: Path | None,
        progress: bool,
        solved_return: float | None = None,
        bar_position: int | None = None,
    ):
        self.task, self.settings = task, settings
        self.seeds = settings.seeds
        self.checkpoint_dir = None if checkpoint_dir is None else Path(checkpoint_dir)
        self.progress = progress
        self.bar_position = bar_position
        self.total = settings.total_steps
        self.goal_conditioned = settings.her
        self.solved_return = solved_return
        self.success_key = success_info_key(task)
        self.snapshots: ActorSnapshots | None = None
        self.device = resolve_device(settings.device)

    # -- the run -------------------------------------------------------------------------------
    def train(self, stop_after: int | None) -> pd.DataFrame:
        s = self.settings
        num_seeds = len(self.seeds)
        with _torch_threads(s.num_threads), _owned_global_rng():
            env = eval_env = collector = None
            try:
                backend = env_backend(self.task, s)
                if s.backend != OWN_ENV and backend is None:
                    log.info("sac.backend=%s: %s keeps its own environments", s.backend, self.task.task_id)
                env = make_env(self.task, num_seeds, goal_conditioned=self.goal_conditioned, backend=backend)
                eval_env = make_env(
                    self.task,
                    num_seeds * s.eval_episodes,
                    goal_conditioned=self.goal_conditioned,
                    success_key=self.success_key,
                    backend=backend,
                )
                actor, critics = make_actor_critic(
                    self.task, hidden_sizes=s.hidden_sizes, seeds=self.seeds, goal_conditioned=self.goal_conditioned,
                    device=self.device,
                )
                loss = make_loss(actor, critics, gamma=s.gamma, alpha=s.alpha, loss_function=s.loss_function)
                updater = make_target_updater(loss, tau=s.tau)
                optimisers = make_optimisers(loss, actor_lr=s.actor_lr, critic_lr=s.critic_lr)
                buffers = make_replay_buffers(
                    self.task,
                    num_buffers=num_seeds,
                    capacity=min(s.buffer_size, self.total),
                    her=s.her,
                    her_ratio=s.her_ratio,
                    her_strategy=s.her_strategy,
                    device=self.device,
                )
                state, rng = self._resume(loss, optimisers, buffers)
                self._snapshots(state)
                if state.step >= self.total:
                    return self._curve(state)
                collector = make_collector(
                    env,
                    actor,
                    frames_per_batch=num_seeds * s.collect_steps,
                    init_random_frames=num_seeds * max(0, s.warmup_steps - state.step),
                    device=self.device,
                )
                self._start_rng(rng)  # after every constructor, so a resumed run continues the same stream
                objective = make_objective(loss, actor, self.task, gamma=s.gamma, loss_function=s.loss_function,
                                           goal_conditioned=self.goal_conditioned)
                parts = _Parts(env, eval_env, actor, loss, objective, updater, optimisers, buffers, collector)
                self._loop(parts, state, stop_after)
                self._snapshots(state)
                return self._curve(state)
            finally:
                if collector is not None:
                    collector.shutdown(close_env=False)
                for e in (env, eval_env):
                    if e is not None and not e.is_closed:
                        e.close()

    def _loop(self, p: _Parts, state: _Progress, stop_after: int | None) -> None:
        s = self.settings
        stored_keys = self._stored_keys(p)
        clock = time.perf_counter() - state.elapsed
        bar = tqdm(
            total=self.total,
            initial=state.step,
            disable=not self.progress,
            desc=f"{self.task.task_id} {s.variant} seeds={list(self.seeds)}",
            unit="step",
            position=self.bar_position,
            leave=self.bar_position is None,
        )
        try:
            if not state.rows:
                self._evaluate(p, state, clock, bar)
                self._snapshot(p, state)
            batches = iter(p.collector)
            while state.step < self.total:
                segment = state.step // s.checkpoint_every
                boundary = min(self.total, (segment + 1) * s.checkpoint_every)
                p.collector.reset(seed=[derive_seed(seed, "train", segment) for seed in self.seeds])
                while state.step < boundary:
                    data = next(batches)
                    state.step += s.collect_steps
                    self._record_episodes(data, state)
                    if state.step == boundary:
                        _truncate_last_step(data)
                    for buffer, seed_data in zip(p.buffers, data.unbind(0), strict=True):
                        buffer.extend(seed_data.select(*stored_keys))
                    if state.step > s.warmup_steps:
                        self._update_round(p)
                    if state.step % s.eval_every == 0 or state.step == self.total:
                        self._evaluate(p, state, clock, bar)
                    bar.update(s.collect_steps)
                state.elapsed = time.perf_counter() - clock
                if state.step == boundary:
                    self._snapshot(p, state)
                if self.checkpoint_dir is not None:
                    save_checkpoint(self.checkpoint_dir, self._checkpoint(p, state))
                if stop_after is not None and state.step >= stop_after:
                    break
        finally:
            bar.close()

    # -- pieces of the loop --------------------------------------------------------------------
    def _stored_keys(self, p: _Parts) -> list:
        """What a transition keeps in the replay buffer: the loss's inputs, truncation, HER's goals."""
        keys = set(p.loss.in_keys) | {("next", "truncated")}
        if self.goal_conditioned:
            keys |= {("next", "achieved_goal"), ("next", "desired_goal")}
        return sorted(keys, key=str)

    def _update_round(self, p: _Parts) -> None:
        """``collect_steps × updates_per_step`` SAC updates, every seed on its own minibatches."""
        s = self.settings
        updates = s.collect_steps * s.updates_per_step
        minibatches = sample_minibatches(
            p.buffers, updates=updates, batch_size=s.batch_size, keys=p.loss.in_keys, shuffle=s.her
        )
        for i in range(updates):
            objective = p.objective(minibatches[:, i])  # S × the mean over seeds: each seed's gradient is its own
            for optimiser in p.optimisers:
                optimiser.zero_grad(set_to_none=True)
            objective.backward()
            for optimiser in p.optimisers:
                optimiser.step()
            p.updater.step()

    def _record_episodes(self, data: TensorDictBase, state: _Progress) -> None:
        done = data.get(("next", "done")).squeeze(-1)
        returns = data.get(("next", "episode_reward")).squeeze(-1)
        for index in range(len(self.seeds)):
            finished = done[index].nonzero().flatten()
            if finished.numel():
                state.latest_return[index] = float(returns[index, finished[-1]])

    def _evaluate(self, p: _Parts, state: _Progress, clock: float, bar: tqdm) -> None:
        s = self.settings
        returns, success = evaluate(
            p.eval_env,
            p.actor,
            self.task,
            seeds=self.seeds,
            episodes=s.eval_episodes,
            goal_conditioned=self.goal_conditioned,
            success_key=self.success_key,
            solved_return=self.solved_return,
            device=self.device,
        )
        seconds = time.perf_counter() - clock
        for index, seed in enumerate(self.seeds):
            state.rows.append(
                {
                    "task": self.task.task_id,
                    "variant": s.variant,
                    "seed": seed,
                    "env_step": state.step,
                    "eval/return_mean": float(returns[index].mean()),
                    "eval/return_std": float(returns[index].std()),
                    "eval/success_rate": float(success[index].mean()),
                    "train/episode_return": state.latest_return[index],
                    "time/seconds": seconds,
                }
            )
        bar.set_postfix({"eval/return_mean": f"{returns.mean():.2f}"}, refresh=False)

    def _snapshot(self, p: _Parts, state: _Progress) -> None:
        """Keep the actors' parameters at this step (saved with the checkpoint, so a resumed run has them)."""
        weights, biases = actor_layers(p.actor, self.task.action_size)
        state.actors.append({"step": state.step, "weights": weights, "biases": biases})

    def _snapshots(self, state: _Progress) -> None:
        if state.actors:
            self.snapshots = ActorSnapshots.stack([a["step"] for a in state.actors], self.seeds,
                                                  [(a["weights"], a["biases"]) for a in state.actors])

    def _curve(self, state: _Progress) -> pd.DataFrame:
        curve = pd.DataFrame(state.rows, columns=list(CURVE_COLUMNS))
        return curve.astype({"seed": "int64", "env_step": "int64"})

    # -- checkpoints ---------------------------------------------------------------------------
    def _identity(self) -> dict[str, Any]:
        settings = dataclasses.asdict(self.settings)
        for name in ("num_threads", "enabled", "workers", "device", "backend"):  # how fast (or whether), not what;
            # device and backend: below
            settings.pop(name)
        identity = {"format": CHECKPOINT_FORMAT, "task": repr(self.task), "settings": repr(settings),
                    **device_identity(self.settings), **backend_identity(self.task, self.settings)}
        if self.solved_return is not None:  # changes eval/success_rate
            identity["solved_return"] = self.solved_return
        return identity

    def _checkpoint(self, p: _Parts, state: _Progress) -> dict[str, Any]:
        return {
            "identity": self._identity(),
            "progress": dataclasses.asdict(state),
            "loss": p.loss.state_dict(),
            "optimisers": [o.state_dict() for o in p.optimisers],
            "buffers": [b.state_dict() for b in p.buffers],
            "rng": {
                "torch": torch.get_rng_state(),
                "numpy": np.random.get_state(),  # noqa: NPY002 - the legacy global state, owned by the run
                "python": random.getstate(),
            },
        }

    def _resume(self, loss, optimisers, buffers) -> tuple[_Progress, dict[str, Any] | None]:
        """Restore a checkpoint if there is one. Returns the progress and the saved generator states."""
        checkpoint = None if self.checkpoint_dir is None else load_checkpoint(self.checkpoint_dir)
        if checkpoint is None:
            return _Progress(latest_return=[math.nan] * len(self.seeds)), None
        if checkpoint.get("identity") != self._identity():
            raise ArtefactError(
                f"the checkpoint in {self.checkpoint_dir} belongs to a different run "
                f"(task or settings differ); remove it or use another checkpoint_dir"
            )
        loss.load_state_dict(checkpoint["loss"])
        for optimiser, saved in zip(optimisers, checkpoint["optimisers"], strict=True):
            optimiser.load_state_dict(saved)
        for buffer, saved in zip(buffers, checkpoint["buffers"], strict=True):
            buffer.load_state_dict(saved)
        state = _Progress(**checkpoint["progress"])
        if state.step < self.total:
            log.info("resuming %s from its checkpoint at step %d of %d", self._label(), state.step, self.total)
        else:
            log.info("%s: its checkpoint holds the finished run (step %d of %d)", self._label(), state.step, self.total)
        return state, checkpoint["rng"]

    def _label(self) -> str:
        """The run in log lines: task, variant and seeds ("one_link_1m0-dense sac seeds 0, 1")."""
        seeds = f"seed {self.seeds[0]}" if len(self.seeds) == 1 else f"seeds {', '.join(map(str, self.seeds))}"
        return f"{self.task.task_id} {self.settings.variant} {seeds}"

    def _start_rng(self, rng: dict[str, Any] | None) -> None:
        """Seed the global generators from the seeds (fresh run) or restore their saved states."""
        if rng is None:
            torch.manual_seed(derive_seed("torch", *self.seeds))
            np.random.seed(derive_seed("numpy", *self.seeds))  # noqa: NPY002 - for library code that uses it
            random.seed(derive_seed("python", *self.seeds))
        else:
            torch.set_rng_state(rng["torch"])
            np.random.set_state(rng["numpy"])  # noqa: NPY002
            random.setstate(rng["python"])


def sample_minibatches(
    buffers: Sequence[TensorDictReplayBuffer],
    *,
    updates: int,
    batch_size: int,
    keys: Sequence,
    shuffle: bool,
) -> TensorDictBase:
    """Draw ``updates`` minibatches of ``batch_size`` transitions from each seed's buffer, at once.

    The buffers do not change between the updates of a round, so one draw of ``updates × batch_size``
    rows per buffer is distributed exactly like ``updates`` separate draws of ``batch_size``.

    Parameters
    ----------
    buffers : sequence of S replay buffers
    keys : keys to keep (the loss's inputs)
    shuffle : bool
        Permute each draw before splitting it. Needed with HER, which relabels the *leading* rows of a
        draw: shuffled, each minibatch holds a hypergeometric number of relabelled rows, mean
        ``her_ratio × batch_size``.

    Returns
    -------
    TensorDict (S, updates, batch_size)
    """
    samples = []
    for buffer in buffers:
        sample = buffer.sample(updates * batch_size).select(*keys)
        if shuffle:
            sample = sample[torch.randperm(sample.shape[0])]
        samples.append(sample)
    return torch.stack(samples).reshape(len(buffers), updates, batch_size)


def _truncate_last_step(data: TensorDictBase) -> None:
    """Mark the last step of every seed in ``data`` (S, T) as truncated: the environments are reset next."""
    for key in (("next", "truncated"), ("next", "done")):
        data.get(key)[:, -1] = True


@contextlib.contextmanager
def _torch_threads(num_threads: int) -> Iterator[None]:
    """Use ``num_threads`` torch intra-op threads inside the block (0: unchanged), then restore."""
    previous = torch.get_num_threads()
    if num_threads > 0:
        torch.set_num_threads(num_threads)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


@contextlib.contextmanager
def _owned_global_rng() -> Iterator[None]:
    """Let the run seed torch's, NumPy's and Python's global generators; restore the caller's afterwards."""
    numpy_state, python_state = np.random.get_state(), random.getstate()  # noqa: NPY002
    try:
        with torch.random.fork_rng(devices=[]):
            yield
    finally:
        np.random.set_state(numpy_state)  # noqa: NPY002
        random.setstate(python_state)
