"""Every hyper-parameter of the SAC (+HER) stage, as one frozen dataclass (``taskcomplexity/conf/sac/*.yaml``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from taskcomplexity.config import setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.rwg.backends import sac_backends, sac_env
from taskcomplexity.tasks.reward_kinds import reward_kind
from taskcomplexity.tasks.spec import TaskSpec

HER_STRATEGIES = ("future", "final", "episode", "random")
DEVICES = ("auto", "cpu", "cuda")
"""Values of ``sac.device``: ``auto`` is CUDA where torch sees a CUDA device, else the CPU."""
LOSS_FUNCTIONS = ("l2", "l1", "smooth_l1")
OWN_ENV = "pybullet"
"""``sac.backend``'s default: every task steps its own env (a reaching arm's is the PyBullet reference)."""


@dataclass(frozen=True)
class SACSettings:
    """Soft Actor-Critic with twin Q-networks, a fixed entropy coefficient, and optional HER.

    Attributes
    ----------
    enabled : bool
        Whether the study runs the SAC stage at all (read by the pipeline; ``train_sac`` ignores it).
    hidden_sizes : tuple of int
        Hidden layer widths of the actor and of each critic (ReLU).
    actor_lr, critic_lr : float
        Adam learning rates.
    gamma : float
        Discount γ.
    alpha : float
        Fixed entropy coefficient α (no automatic tuning).
    tau : float
        Target-network smoothing: θ' ← (1 − τ)·θ' + τ·θ after every update.
    loss_function : {'l2', 'l1', 'smooth_l1'}
        Critic regression loss (SAC uses the squared error, ``l2``).
    batch_size : int
        Minibatch size of every gradient update, per seed.
    buffer_size : int
        Replay capacity, transitions per seed (a run never stores more than its budget).
    updates_per_step : int
        Gradient updates per environment step (1 in the protocol).
    collect_steps : int
        Environment steps per seed collected between two rounds of updates; each round then makes
        ``collect_steps × updates_per_step`` updates, so the ratio is exact at every round boundary.
        1 alternates step and update strictly; larger values amortise the collector's overhead.
    warmup_steps : int
        Initial environment steps with uniform random actions and no updates.
    eval_every : int
        Environment steps between two deterministic evaluations (also run at step 0 and at the end).
    eval_episodes : int
        Episodes per evaluation and seed (mean action; the same start states at every evaluation).
    total_steps : int or None
        The run's budget, environment steps per seed. None: each study task's ``sac_steps`` (the study
        file holds the budgets; :func:`with_budget` resolves them); a run needs one or the other.
    budget_fraction : float
        Scales the study's budgets: a task's run is ``budget_fraction × sac_steps`` steps per seed,
        rounded to a multiple of ``collect_steps`` (e.g. 0.2 in ``experiment=beyond``). Not hashed
        itself: the resolved ``total_steps`` is. Refused together with ``total_steps``, which it would
        not change.
    seeds : tuple of int
        The seeds of the protocol.
    train_seeds_together : bool
        Train all of ``seeds`` in one vectorised run (stacked parameters, one environment per seed).
    her : bool
        Hindsight Experience Replay on goal-conditioned observations (variant ``sac+her``).
    her_ratio : float
        Fraction of each sampled minibatch whose goal is relabelled (0.8 ≡ k = 4 relabelled goals per
        original one, in the terms of Andrychowicz et al., 2017).
    her_strategy : {'future', 'final', 'episode', 'random'}
        Where relabelled goals come from (``future``: an achieved goal later in the same episode).
    checkpoint_every : int
        Environment steps between checkpoints (and between the forced environment resets that make
        a resumed run repeat the uninterrupted one exactly; see ``taskcomplexity.rl.train``).
    num_threads : int
        torch intra-op threads during training (restored afterwards); 0 keeps torch's setting.
    workers : int
        SAC runs a study trains at once, each in a process of its own with ``num_threads`` threads; 0: one per
        CPU (at most the runs left to train). Runs are independent, so the curves do not depend on it.
    device : {'auto', 'cpu', 'cuda'}
        Where the networks, their updates and the replay buffers live (the environments step on the CPU):
        ``auto`` is CUDA where torch sees a CUDA device, else the CPU. Not hashed itself: the resolved device
        enters the key (and a checkpoint's identity) only when it is not the CPU (:func:`resolve_device`), so
        every CPU curve keeps its key, and CUDA's curves (other kernels, other rounding) get their own.
    backend : {'pybullet', 'batched'}
        What steps a reaching arm's environments (training and evaluation): ``pybullet``, the reference, or
        ``batched``, the fused kernel of :mod:`taskcomplexity.tasks.batched_vector` (equal to PyBullet to 1e-6
        per step on the contact-free tasks). ``batched`` applies to the contact-free reaching arms only: the
        obstacle task (its contacts need PyBullet's solver) and gymnasium tasks keep their own environments
        and their keys. Not hashed itself: where it applies, ``{"backend": "batched"}`` enters the key
        (:func:`backend_identity`), so every PyBullet curve keeps its key.
    entry : str or None
        ``pipelines/sac.py`` only: the id of a study task whose every SAC run the study would make (its
        variants, at its budget) is trained, the task composed as the study composes it (one job of
        ``make paper-jobs``). Not part of any result: the study finds these runs under its own keys.
    """

    enabled: bool = setting(True, result=False)
    hidden_sizes: tuple[int, ...] = (256, 256)
    actor_lr: float = 1e-3
    critic_lr: float = 1e-3
    gamma: float = 0.99
    alpha: float = 0.2
    tau: float = 0.005
    loss_function: str = "l2"
    batch_size: int = 64
    buffer_size: int = 1_000_000
    updates_per_step: int = 1
    collect_steps: int = 10
    warmup_steps: int = 1000
    eval_every: int = 1000
    eval_episodes: int = 10
    total_steps: int | None = None
    budget_fraction: float = setting(1.0, result=False)
    seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    train_seeds_together: bool = True
    her: bool = False
    her_ratio: float = 0.8
    her_strategy: str = "future"
    checkpoint_every: int = 10_000
    num_threads: int = 1
    workers: int = setting(0, result=False)
    device: str = setting("auto", result=False)
    backend: str = setting("pybullet", result=False)
    entry: str | None = setting(None, result=False)

    @property
    def variant(self) -> str:
        """``"sac+her"`` or ``"sac"``: the ``variant`` column of the learning curves."""
        return "sac+her" if self.her else "sac"

    def validate(self, where: str = "sac") -> SACSettings:
        """Check types and ranges; raise :class:`ConfigError` naming the key, value and what is allowed."""
        if not self.hidden_sizes or any(not isinstance(h, int) or h < 1 for h in self.hidden_sizes):
            raise ConfigError(
                f"{where}.hidden_sizes must be a non-empty list of integers >= 1, got {list(self.hidden_sizes)}"
            )
        for name in ("actor_lr", "critic_lr", "alpha"):
            _check(where, name, getattr(self, name), "a finite number > 0", lambda v: math.isfinite(v) and v > 0)
        _check(where, "gamma", self.gamma, "a number in [0, 1]", lambda v: 0 <= v <= 1)
        _check(where, "tau", self.tau, "a number in (0, 1]", lambda v: 0 < v <= 1)
        _check(where, "her_ratio", self.her_ratio, "a number in [0, 1]", lambda v: 0 <= v <= 1)
        if self.loss_function not in LOSS_FUNCTIONS:
            raise ConfigError(
                f"{where}.loss_function must be one of {list(LOSS_FUNCTIONS)}, got {self.loss_function!r}"
            )
        if self.her_strategy not in HER_STRATEGIES:
            raise ConfigError(f"{where}.her_strategy must be one of {list(HER_STRATEGIES)}, got {self.her_strategy!r}")
        for name in ("batch_size", "buffer_size", "updates_per_step", "collect_steps", "eval_every",
                     "eval_episodes", "checkpoint_every"):
            _check(where, name, getattr(self, name), "an integer >= 1", lambda v: isinstance(v, int) and v >= 1)
        _check(where, "warmup_steps", self.warmup_steps, "an integer >= 0", lambda v: isinstance(v, int) and v >= 0)
        _check(where, "num_threads", self.num_threads, "an integer >= 0", lambda v: isinstance(v, int) and v >= 0)
        _check(where, "workers", self.workers, "an integer >= 0 (0: one per CPU)",
               lambda v: isinstance(v, int) and v >= 0)
        if self.device not in DEVICES:
            raise ConfigError(f"{where}.device must be one of {list(DEVICES)}, got {self.device!r}")
        if self.device == "cuda":
            resolve_device(self.device, where)  # refused here, before any work, where torch sees no CUDA device
        if self.backend not in (OWN_ENV, *sac_backends()):
            raise ConfigError(f"{where}.backend must be one of {[OWN_ENV, *sac_backends()]}, got {self.backend!r}")
        if self.entry is not None and (not isinstance(self.entry, str) or not self.entry):
            raise ConfigError(f"{where}.entry must be a study task's id or null, got {self.entry!r}")
        if not self.seeds or len(set(self.seeds)) != len(self.seeds) or min(self.seeds) < 0:
            raise ConfigError(
                f"{where}.seeds must be a non-empty list of distinct integers >= 0, got {list(self.seeds)}"
            )
        for name in ("warmup_steps", "eval_every", "checkpoint_every"):
            value = getattr(self, name)
            if value % self.collect_steps:
                raise ConfigError(
                    f"{where}.{name} must be a multiple of {where}.collect_steps={self.collect_steps}, got {value}"
                )
        _check(where, "budget_fraction", self.budget_fraction, "a finite number > 0",
               lambda v: math.isfinite(v) and v > 0)
        if self.total_steps is not None:
            _check_budget(f"{where}.total_steps", self.total_steps, self.collect_steps, where)
            if self.budget_fraction != 1:
                raise ConfigError(
                    f"{where}.budget_fraction={self.budget_fraction} scales the study's budgets (sac_steps), but "
                    f"{where}.total_steps={self.total_steps} replaces them (allowed: one of the two, or "
                    f"{where}.budget_fraction=1)"
                )
        return self


def resolve_device(device: str, where: str = "sac"):
    """The :class:`torch.device` of a ``sac.device`` value: ``auto`` → CUDA when torch sees a device, else the CPU.

    Raises
    ------
    ConfigError
        For ``cuda`` where torch sees no CUDA device (a CPU build of torch, or no GPU).
    """
    import torch

    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if device == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"{where}.device=cuda, but torch {torch.__version__} sees no CUDA device "
                          f"(torch.cuda.is_available() is False; allowed here: auto, cpu)")
    return torch.device(device)


def device_identity(settings: SACSettings) -> dict:
    """What the device adds to a run's identity: nothing on the CPU, ``{"device": "cuda"}`` on a GPU.

    ``auto`` under a CPU build of torch (its version's local label ``+cpu``, read from the installed package's
    metadata) is the CPU without importing torch, so looking a cached run up costs no torch import."""
    if settings.device == "cpu" or (settings.device == "auto" and cpu_build_of_torch()):
        return {}
    device = resolve_device(settings.device)
    return {} if device.type == "cpu" else {"device": device.type}


def cpu_build_of_torch() -> bool:
    """Whether the installed torch is a CPU-only build (``2.13.0+cpu``), which never sees a CUDA device."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("torch").endswith("+cpu")
    except PackageNotFoundError:
        return False


def env_backend(task, settings: SACSettings):
    """The RWG backend (:data:`taskcomplexity.rwg.backends.BACKENDS`) whose vector env steps ``task``'s environments
    in a SAC run under ``settings.backend`` (``batched``: the contact-free reaching arms), or None where the task
    steps its own env (a reaching arm's PyBullet reference, any other task's gymnasium env)."""
    return sac_env(task, settings.backend)


def backend_identity(task, settings: SACSettings) -> dict:
    """What the environment backend adds to a run's identity: ``{"backend": <name>}`` where a backend's vector env
    steps the environments, nothing where the task steps its own (every such curve keeps its key)."""
    backend = env_backend(task, settings)
    return {} if backend is None else {"backend": backend.name}


def _check(where: str, name: str, value, allowed: str, ok) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not ok(value):
        raise ConfigError(f"{where}.{name} must be {allowed}, got {value!r}")


def _check_budget(key: str, steps, collect_steps: int, where: str) -> None:
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ConfigError(f"{key} must be an integer >= 1, got {steps!r}")
    if steps % collect_steps:
        raise ConfigError(f"{key} must be a multiple of {where}.collect_steps={collect_steps}, got {steps}")


def with_budget(settings: SACSettings, sac_steps: int | None, *, task_id: str, where: str = "sac") -> SACSettings:
    """``settings`` with the run's budget resolved: ``total_steps`` when set, else the study's ``sac_steps``
    scaled by ``budget_fraction`` (rounded to a multiple of ``collect_steps``, at least one round).

    Parameters
    ----------
    sac_steps : int or None
        The study entry's budget (environment steps per seed), if the task has an entry with one.
    task_id : str
        Named in the error.

    Raises
    ------
    ConfigError
        If neither is set, naming ``sac.total_steps``; or if ``sac_steps`` is not a positive multiple
        of ``sac.collect_steps``.
    """
    if settings.total_steps is not None:
        return settings
    if sac_steps is None:
        raise ConfigError(
            f"no SAC budget for task {task_id}: set {where}.total_steps or the study entry's sac_steps"
        )
    _check_budget(f"study.tasks[{task_id}].sac_steps", sac_steps, settings.collect_steps, where)
    rounds = max(1, round(sac_steps * settings.budget_fraction / settings.collect_steps))
    return replace(settings, total_steps=rounds * settings.collect_steps, budget_fraction=1.0)


def has_goal_view(task) -> bool:
    """Whether ``task`` has a goal-conditioned view (observation, achieved goal, desired goal) for HER.

    The reaching arms without an obstacle have one (``taskcomplexity.tasks.goal_env``); a generic
    gymnasium task has none.
    """
    return isinstance(task, TaskSpec) and task.arm.obstacle is None


def sac_skip_reason(task) -> str | None:
    """Why SAC does not run on ``task`` (None: it does).

    SAC here is the continuous-action algorithm of ``docs/explanation/sac-protocol.md`` (tanh-Gaussian
    actor scaled into the Box bounds); a Discrete action space is skipped with the reason
    ``"discrete actions"``.
    """
    from gymnasium import spaces

    if isinstance(task.action_space, spaces.Discrete):
        return "discrete actions"
    return None


def protocol_variants(task, settings: SACSettings) -> tuple[SACSettings, ...]:
    """The runs the SAC protocol asks for on ``task``: SAC, plus SAC + HER on a sparse task with a goal view.

    ``docs/explanation/sac-protocol.md`` states the protocol.

    Returns ``settings`` with ``her=False`` and, for a reaching task with a goal view whose whole
    reward is a function of the goals (:attr:`taskcomplexity.tasks.rewards.RewardKind.goal_reward`:
    the sparse reward), a copy with ``her=True`` (``variant`` "sac" and "sac+her"). A generic
    gymnasium task gets SAC only.
    """
    plain = replace(settings, her=False)
    if has_goal_view(task) and reward_kind(task.reward.kind).goal_reward:
        return plain, replace(settings, her=True)
    return (plain,)
