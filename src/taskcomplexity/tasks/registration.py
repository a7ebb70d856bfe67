"""Gymnasium ids of this package, registered lazily (PyBullet is imported only by ``make``).

Every reaching task of the arm presets (``taskcomplexity/<Arm>-<Reward>-v0``; the arms of
``conf/arm/``, each with the rewards it allows: :func:`~taskcomplexity.tasks.spec.preset_tasks`) and
the noisy CartPole of ``study=cartpole_noise`` (``taskcomplexity/NoisyCartPole-v0``) and Meta-World's manipulation
tasks seeded per episode (``taskcomplexity/MetaWorld-v3``, :mod:`taskcomplexity.tasks.manipulation`; metaworld is
imported only by ``make``).
"""

from __future__ import annotations

import gymnasium

from taskcomplexity.tasks.spec import ENTRY_POINT, gym_id, preset_tasks

MAX_EPISODE_STEPS = 50


def gym_ids() -> dict[tuple[str, str], str]:
    """The gymnasium id of every preset task, by ``(arm, reward)``."""
    return {(arm, reward): gym_id(arm, reward) for arm, reward in preset_tasks()}


NOISY_CARTPOLE_ID = "taskcomplexity/NoisyCartPole-v0"
"""CartPole-v0 with reset and dynamics noise (``tasks/classic/noisy_cartpole.py``)."""
METAWORLD_ID = "taskcomplexity/MetaWorld-v3"
"""One of Meta-World's 50 tasks (``task_name=…``, ``reward=dense|sparse``), each episode a function of its seed."""


def register_tasks() -> None:
    """Register every task of the package with gymnasium (idempotent)."""
    for (arm, reward), env_id in gym_ids().items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point=ENTRY_POINT,
                max_episode_steps=MAX_EPISODE_STEPS,
                kwargs={"arm": arm, "reward": reward},
            )
    if NOISY_CARTPOLE_ID not in gymnasium.registry:
        gymnasium.register(
            id=NOISY_CARTPOLE_ID,
            entry_point="taskcomplexity.tasks.classic.noisy_cartpole:NoisyCartPoleEnv",
            max_episode_steps=200,  # CartPole-v0's limit and reward threshold
            reward_threshold=195.0,
        )
    if METAWORLD_ID not in gymnasium.registry:
        from taskcomplexity.tasks.manipulation import EPISODE_STEPS

        gymnasium.register(id=METAWORLD_ID, entry_point="taskcomplexity.tasks.manipulation:MetaWorldEnv",
                           max_episode_steps=EPISODE_STEPS)
