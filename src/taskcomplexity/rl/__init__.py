"""Soft Actor-Critic (+ Hindsight Experience Replay) with TorchRL: the empirical difficulty of a task.

Any :class:`~taskcomplexity.tasks.base.Task` with a Box action space: the reaching arms (with HER
on their goal-conditioned view) and any gymnasium id. ``train_sac(task, settings, seed=...)`` returns
a tidy learning curve (see :data:`~taskcomplexity.rl.curves.CURVE_COLUMNS`); ``train_sac_seeds``
trains several seeds together. Discrete action spaces are not trained (``sac_skip_reason``).
``docs/explanation/sac-protocol.md`` states the protocol.

Modules
-------
checkpoint
    Atomic, verified checkpoints of a SAC run: a SHA-256 header, then a ``torch.save`` payload.
collectors
    TorchRL's collector, imported with its import-time deprecation warning silenced.
curves
    The columns of a SAC learning curve, and which of them hold wall-clock time.
evaluation
    Deterministic evaluation of the seeds' policies, every seed's episodes side by side.
factories
    The pieces of a SAC run, one ``make_<thing>`` per piece, each from explicit arguments.
her
    Hindsight Experience Replay with TorchRL's HER replay buffer.
layers
    A linear layer holding one weight matrix per seed, so that several seeds train together.
objective
    SAC's objective evaluated directly on the parameters TorchRL's ``SACLoss`` holds.
settings
    Every hyper-parameter of the SAC (+HER) stage, as one frozen dataclass.
snapshots
    Snapshots of SAC actors along training, as policies of the RWG family.
train
    Train SAC (+HER) on a task and return its learning curve.
"""

from taskcomplexity.rl.curves import CURVE_COLUMNS, WALL_CLOCK
from taskcomplexity.rl.settings import (
    SACSettings,
    has_goal_view,
    protocol_variants,
    sac_skip_reason,
    with_budget,
)

_TRAINING = ("train_sac", "train_sac_run", "train_sac_seeds")


def __getattr__(name: str):
    """The training API, imported on first use: TorchRL takes over a second to import, and a study without
    SAC (``make run``) reads only the settings above."""
    if name in _TRAINING:
        from taskcomplexity.rl import train

        return getattr(train, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "CURVE_COLUMNS",
    "WALL_CLOCK",
    "SACSettings",
    "has_goal_view",
    "protocol_variants",
    "sac_skip_reason",
    "train_sac",
    "train_sac_run",
    "train_sac_seeds",
    "with_budget",
]
