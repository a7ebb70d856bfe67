"""Gymnasium ids of the seven tasks, registered lazily (PyBullet is imported only by ``make``)."""

from __future__ import annotations

import gymnasium

from taskcomplexity.tasks.spec import STUDY_TASKS

ENTRY_POINT = "taskcomplexity.tasks.pybullet_env:ReachingEnv"
MAX_EPISODE_STEPS = 50

def gym_id(arm: str, reward: str) -> str:
    """``('two_link', 'sparse')`` → ``'taskcomplexity/TwoLink-Sparse-v0'`` (any arm name: CamelCase of its parts)."""
    camel = "".join(part[:1].upper() + part[1:] for part in arm.split("_"))
    return f"taskcomplexity/{camel}-{reward.capitalize()}-v0"


GYM_IDS: dict[tuple[str, str], str] = {(arm, reward): gym_id(arm, reward) for arm, reward in STUDY_TASKS}


def register_tasks() -> None:
    """Register every study task with gymnasium (idempotent)."""
    for (arm, reward), env_id in GYM_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point=ENTRY_POINT,
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs={"arm": arm, "reward": reward},
            )
