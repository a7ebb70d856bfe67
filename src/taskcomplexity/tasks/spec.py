"""Task specifications: the arm, the reward and (optionally) the obstacle of a reaching task.

Plain frozen dataclasses, usable without Hydra. The Hydra configs under ``taskcomplexity/conf/arm``
and ``taskcomplexity/conf/reward`` hold exactly these fields; ``tests/tasks/test_config.py`` keeps the
YAML files and the presets below equal. All lengths in metres, masses in kilograms, angles in radians, torques in
N·m, times in seconds (see ``docs/reference/tasks.md``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from taskcomplexity.config import canonical
from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks.reward_kinds import KINDS, REWARD_KINDS, reward_kind

ENTRY_POINT = "taskcomplexity.tasks.pybullet_env:ReachingEnv"
"""Where the reaching tasks' reference env lives (loaded by gymnasium only when an env is made)."""


def gym_id(arm: str, reward: str) -> str:
    """``('two_link', 'sparse')`` → ``'taskcomplexity/TwoLink-Sparse-v0'`` (any arm name: CamelCase of its parts)."""
    camel = "".join(part[:1].upper() + part[1:] for part in arm.split("_"))
    return f"taskcomplexity/{camel}-{reward.capitalize()}-v0"


# A link box overhangs its joint by this much behind the pivot, and is this thick (square section).
LINK_OVERHANG = 0.05
LINK_WIDTH = 0.05


@dataclass(frozen=True)
class LinkSpec:
    """One rigid link of a planar arm, rotating about the z axis of its proximal joint.

    Attributes
    ----------
    length : float
        Kinematic length from this joint to the next joint (or the end effector), metres. The
        collision box spans ``-LINK_OVERHANG ... length`` along the link's x axis.
    mass : float
        Link mass, kg.
    com : float
        Centre of mass along the link's x axis, measured from the joint, metres.
    joint_damping : float
        URDF joint damping of the proximal joint, N·m·s/rad.
    """

    length: float
    mass: float
    com: float
    joint_damping: float = 0.0

    @property
    def box_length(self) -> float:
        return self.length + LINK_OVERHANG

    @property
    def box_origin(self) -> float:
        return (self.length - LINK_OVERHANG) / 2.0

    def validate(self, where: str) -> None:
        _positive(f"{where}.length", self.length)
        _positive(f"{where}.mass", self.mass)
        _non_negative(f"{where}.joint_damping", self.joint_damping)
        if not -LINK_OVERHANG <= self.com <= self.length:
            raise ConfigError(
                f"{where}.com must lie on the link box [{-LINK_OVERHANG}, {self.length}], got {self.com}"
            )


@dataclass(frozen=True)
class ObstacleSpec:
    """A fixed block the forearm must avoid (pybullet_data ``block.urdf``, scaled, stood upright).

    Attributes
    ----------
    radius, angle_deg : float
        Polar position of the block centre in the arm's plane (metres, degrees).
    height : float
        z of the block centre, metres.
    scale : float
        ``globalScaling`` of ``block.urdf``.
    obstacle_radius, link_thickness : float
        Clearances r_o and t_o of the distance model, metres.
    collision_distance : float
        A clearance at or below this counts as a collision (c = 1), metres.
    collision_penalty, proximity_weight, proximity_decay : float
        Reward terms 1000·c and 5·exp(−2.5·d).
    segment_points : int
        The forearm is sampled at k = 0 … segment_points for d₂.
    """

    radius: float = 1.25
    angle_deg: float = 31.0
    height: float = 0.05
    scale: float = 0.9
    obstacle_radius: float = 0.02
    link_thickness: float = 0.05
    collision_distance: float = 0.005
    collision_penalty: float = 1000.0
    proximity_weight: float = 5.0
    proximity_decay: float = 2.5
    segment_points: int = 50

    @property
    def position(self) -> tuple[float, float]:
        a = math.radians(self.angle_deg)
        return (self.radius * math.cos(a), self.radius * math.sin(a))

    def validate(self, where: str) -> None:
        _positive(f"{where}.radius", self.radius)
        _positive(f"{where}.scale", self.scale)
        _non_negative(f"{where}.obstacle_radius", self.obstacle_radius)
        _non_negative(f"{where}.link_thickness", self.link_thickness)
        _non_negative(f"{where}.collision_distance", self.collision_distance)
        if self.segment_points < 1:
            raise ConfigError(f"{where}.segment_points must be >= 1, got {self.segment_points}")


@dataclass(frozen=True)
class ArmSpec:
    """A planar arm of one or two links on a fixed pin, and how its task is posed.

    Attributes
    ----------
    name : str
        Config name, e.g. ``one_link_1m0``.
    links : tuple of LinkSpec
        Shoulder first.
    torque_scale : tuple of float
        Torque per unit action for each joint, N·m.
    time_step : float
        Physics time step, s. One environment step is ``substeps`` physics steps.
    substeps : int
        ``stepSimulation`` calls per environment step (the torque acts in the first only).
    target_radius : tuple of float
        Target distance from the base is drawn from U[low, high], metres.
    round_angles : tuple of str
        Reward kinds whose observation rounds joint angles to ``angle_decimals`` decimals.
    angle_decimals : int
        Decimals of the rounding.
    obstacle : ObstacleSpec or None
        A fixed block to avoid (dense reward only).
    pin_mass : float
        Mass of the fixed root pin, kg (irrelevant to the dynamics; kept for a faithful URDF).
    """

    name: str
    links: tuple[LinkSpec, ...]
    torque_scale: tuple[float, ...]
    time_step: float
    target_radius: tuple[float, float]
    round_angles: tuple[str, ...] = ("dense",)
    angle_decimals: int = 2
    substeps: int = 51
    obstacle: ObstacleSpec | None = None
    pin_mass: float = 0.04256858

    @property
    def dof(self) -> int:
        return len(self.links)

    @property
    def reach(self) -> float:
        return sum(link.length for link in self.links)

    def validate(self) -> None:
        where = f"arm={self.name}"
        if self.dof not in (1, 2):
            raise ConfigError(f"{where}: links must hold 1 or 2 links, got {self.dof}")
        for i, link in enumerate(self.links):
            link.validate(f"arm.links[{i}]")
        if len(self.torque_scale) != self.dof:
            raise ConfigError(
                f"arm.torque_scale must have one entry per link ({self.dof}), got {list(self.torque_scale)}"
            )
        for i, scale in enumerate(self.torque_scale):
            _positive(f"arm.torque_scale[{i}]", scale)
        _positive("arm.time_step", self.time_step)
        if self.substeps < 1:
            raise ConfigError(f"arm.substeps must be an integer >= 1, got {self.substeps}")
        low, high = self.target_radius
        if not 0 <= low <= high:
            raise ConfigError(f"arm.target_radius must be [low, high] with 0 <= low <= high, got {[low, high]}")
        for kind in self.round_angles:
            if kind not in REWARD_KINDS:
                raise ConfigError(f"arm.round_angles entries must be in {list(REWARD_KINDS)}, got {kind!r}")
        if self.obstacle is not None:
            if self.dof != 2:
                raise ConfigError("arm.obstacle needs a 2-link arm (the forearm is checked against it)")
            self.obstacle.validate("arm.obstacle")


@dataclass(frozen=True)
class RewardSpec:
    """Per-step reward.

    Attributes
    ----------
    kind : str
        One of :data:`taskcomplexity.tasks.reward_kinds.REWARD_KINDS` (the formulas are in
        :mod:`taskcomplexity.tasks.rewards`): dense: r = −(d² + Σ aᵢ²) (+ obstacle terms); sparse: r = 0 if
        d < threshold else −1.
    threshold : float
        Success distance, metres; the episode terminates when d < threshold.
    """

    kind: str = "dense"
    threshold: float = 0.05

    def validate(self) -> None:
        reward_kind(self.kind)
        _positive("reward.threshold", self.threshold)


@dataclass(frozen=True)
class TaskSpec:
    """A reaching task: an arm, a reward, and the episode length."""

    arm: ArmSpec
    reward: RewardSpec
    max_steps: int = 50

    @property
    def task_id(self) -> str:
        """Short id used in tables and cache keys, e.g. ``two_link-sparse``."""
        return f"{self.arm.name}-{self.reward.kind}"

    @property
    def rounds_angles(self) -> bool:
        return self.reward.kind in self.arm.round_angles

    @property
    def observation_size(self) -> int:
        return 9 if self.arm.dof == 1 else 10

    @property
    def action_size(self) -> int:
        return self.arm.dof

    # -- the Task seam (taskcomplexity.tasks.base.Task) ------------------------------------------
    @property
    def env_id(self) -> str:
        """The gymnasium id of the preset this task is made from, e.g. ``taskcomplexity/TwoLink-Sparse-v0``."""
        return gym_id(self.arm.name, self.reward.kind)

    @property
    def observation_space(self):
        import numpy as np
        from gymnasium import spaces

        return spaces.Box(-np.inf, np.inf, (self.observation_size,), dtype=np.float64)

    @property
    def action_space(self):
        import numpy as np
        from gymnasium import spaces

        return spaces.Box(-1.0, 1.0, (self.action_size,), dtype=np.float64)

    def make_env(self, **kwargs):
        """The PyBullet reference env with a ``max_steps`` time limit (loaded from its entry point, lazily)."""
        import gymnasium
        from gymnasium.envs.registration import load_env_creator

        env = load_env_creator(ENTRY_POINT)(task=self, **kwargs)
        return gymnasium.wrappers.TimeLimit(env, max_episode_steps=self.max_steps)

    def identity(self) -> dict:
        """Every field of the arm, the reward and the episode length (the cache keys of the arms)."""
        return canonical(self)

    def validate(self) -> TaskSpec:
        self.arm.validate()
        self.reward.validate()
        if self.max_steps < 1:
            raise ConfigError(f"max_steps must be an integer >= 1, got {self.max_steps}")
        if self.arm.obstacle is not None and not reward_kind(self.reward.kind).obstacle:
            allowed = [kind.name for kind in KINDS.values() if kind.obstacle]
            raise ConfigError(
                f"reward={self.reward.kind} is not available for arm={self.arm.name} "
                f"(allowed: {', '.join(allowed)}: the reward kinds defined with an obstacle)"
            )
        return self


def _positive(key: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ConfigError(f"{key} must be a finite number > 0, got {value!r}")


def _non_negative(key: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ConfigError(f"{key} must be a finite number >= 0, got {value!r}")


# --- presets (the reference tasks of docs/reference/tasks.md) -------------------------------------------


def _preset_node(directory, name: str) -> dict:
    """``<directory>/<name>.yaml`` as a plain dict, its ``defaults`` list applied the way Hydra applies it
    to a config group option (the listed siblings first, then the file itself, ``_self_`` last)."""
    import yaml

    node = yaml.safe_load((directory / f"{name}.yaml").read_text(encoding="utf-8"))
    merged: dict = {}
    for base in node.pop("defaults", None) or []:
        if base != "_self_":
            merged.update(_preset_node(directory, base))
    merged.update(node)
    return merged


@functools.cache
def arm_presets() -> dict[str, ArmSpec]:
    """Every arm preset by name: the package's ``conf/arm/*.yaml``, the one declaration of each arm.

    The same files are what ``arm=<name>`` composes; a preset added there is a preset here. Read once
    per process (package data does not change under it); callers must not mutate the dict.
    """
    from importlib import resources

    from taskcomplexity.config import build

    directory = resources.files("taskcomplexity") / "conf" / "arm"
    names = sorted(entry.name[: -len(".yaml")] for entry in directory.iterdir() if entry.name.endswith(".yaml"))
    return {name: build(ArmSpec, _preset_node(directory, name), f"arm preset {name}") for name in names}


REWARDS: dict[str, RewardSpec] = {kind: RewardSpec(kind) for kind in REWARD_KINDS}

def preset_tasks() -> tuple[tuple[str, str], ...]:
    """``(arm, reward)`` of every arm preset with every reward kind it allows, by arm name then reward.

    The tasks a ``gymnasium.make`` id exists for (:mod:`taskcomplexity.tasks.registration`): an arm added
    as ``conf/arm/<name>.yaml`` gets its ids with no second list; an arm with an obstacle gets only the
    reward kinds defined with one (dense). A study's tasks are its own declaration (``conf/study/``).
    """
    presets = arm_presets()
    return tuple((name, kind) for name in presets for kind in sorted(REWARDS)
                 if presets[name].obstacle is None or reward_kind(kind).obstacle)


def make_task(arm: str | ArmSpec, reward: str | RewardSpec = "dense", max_steps: int = 50) -> TaskSpec:
    """Build and validate a task from preset names or specs.

    Raises
    ------
    ConfigError
        Unknown preset name or an invalid combination (e.g. a sparse obstacle task).
    """
    if isinstance(arm, str):
        presets = arm_presets()
        if arm not in presets:
            raise ConfigError(f"arm must be one of {sorted(presets)}, got {arm!r}")
        arm = presets[arm]
    if isinstance(reward, str):
        if reward not in REWARDS:
            raise ConfigError(f"reward must be one of {sorted(REWARDS)}, got {reward!r}")
        reward = REWARDS[reward]
    return TaskSpec(arm=arm, reward=reward, max_steps=max_steps).validate()


def task_from_id(task_id: str) -> TaskSpec:
    """``'two_link-sparse'`` → the preset task."""
    arm, sep, reward = task_id.rpartition("-")
    if not sep:
        raise ConfigError(f"task id must look like '<arm>-<reward>', got {task_id!r}")
    return make_task(arm, reward)


__all__ = [
    "arm_presets",
    "REWARDS",
    "preset_tasks",
    "ArmSpec",
    "LinkSpec",
    "ObstacleSpec",
    "RewardSpec",
    "TaskSpec",
    "make_task",
    "task_from_id",
    "LINK_WIDTH",
]
