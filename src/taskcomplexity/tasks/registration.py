"""Gymnasium ids of the seven tasks, registered lazily (PyBullet is imported only by ``make``)."""

from __future__ import annotations

import gymnasium

from taskcomplexity.tasks.spec import STUDY_TASKS

ENTRY_POINT = "taskcomplexity.tasks.pybullet_env:ReachingEnv"
MAX_EPISODE_STEPS = 50

_ARM_IDS = {
    "one_link_1m0": "OneLink1m0",
    "one_link_1m65": "OneLink1m65",
    "two_link": "TwoLink",
    "two_link_obstacle": "TwoLinkObstacle",
}


def gym_id(arm: str, reward: str) -> str:
    """``('two_link', 'sparse')`` → ``'taskcomplexity/TwoLink-Sparse-v0'``."""
    return f"taskcomplexity/{_ARM_IDS[arm]}-{reward.capitalize()}-v0"


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
