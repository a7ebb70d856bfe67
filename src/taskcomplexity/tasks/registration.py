"""Gymnasium ids of the seven tasks, registered lazily (PyBullet is imported only by ``make``)."""

from __future__ import annotations

import gymnasium

from taskcomplexity.tasks.spec import ENTRY_POINT, STUDY_TASKS, gym_id

MAX_EPISODE_STEPS = 50

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
