"""The reference implementation: one reaching task in PyBullet, as a gymnasium environment."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.quiet import c_output_silenced
from taskcomplexity.tasks.spec import TaskSpec, make_task
from taskcomplexity.tasks.urdf import urdf_path

ARM_BASE_POSITION = (0.0, 0.0, 0.025)
BLOCK_ORIENTATION_RPY = (0.0, np.pi / 2, 0.0)  # long side vertical
CLOSEST_POINTS_RANGE = 100.0  # metres; far beyond any arm, so d₁ is always reported


class ReachingEnv(gym.Env):
    """Planar arm reaching a random target, simulated by PyBullet.

    ## Description
    A 1- or 2-link arm on a fixed pin rotates in the horizontal plane. Each episode draws fresh
    joint angles and a fresh target; the agent must bring the end effector within 0.05 m of the
    target. Mechanics follow ``docs/reference/tasks.md`` exactly: each action is applied with
    ``TORQUE_CONTROL`` and then the world is stepped ``substeps`` (51) times, so the torque acts for
    one physics step (an angular impulse τ·dt) and the arm coasts for the remaining 50 under
    PyBullet's link damping and the URDF joint damping.

    ## Action space
    ``Box(-1, 1, (dof,), float64)``; torque = clip(action, −1, 1) ⊙ torque_scale (N·m).

    ## Observation space
    | arm | size | layout |
    |---|---|---|
    | 1-link | 9 | w(q), l·cos w(q), l·sin w(q), w(θ), R·cos w(θ), R·sin w(θ), ex−gx, ey−gy, q̇ |
    | 2-link | 10 | cos q̂₁, cos(q̂₁+q̂₂), sin q̂₁, sin(q̂₁+q̂₂), gx, gy, ex, ey, ex−gx, ey−gy |

    Angles in rad (w rounds to 0.01 rad where the task rounds, then wraps to [0, 2π)), positions in
    m, q̇ in rad/s. The obstacle is not observed.

    ## Rewards
    By reward kind (declared, with the one function that computes them, in
    :mod:`taskcomplexity.tasks.rewards`):

    - dense: r = −(d² + Σ aᵢ²) ∈ [−(reach + R)² − dof, 0]
    - sparse: r = 0 if d < 0.05 else −1
    - obstacle (dense): r = −(d² + Σ aᵢ² + 1000·c + 5·(e^(−2.5·d₁) + e^(−2.5·d₂)))

    ## Starting state
    q ~ U[0, 2π)ⁿ, q̇ = 0, target angle ~ U[0, 2π), target radius ~ U[low, high] (1-link: fixed R).
    ``reset(options={"joint_angles": [...], "target": [radius, angle]})`` sets an exact state
    (``"joint_velocities"`` too, default 0).

    ## Episode end
    Terminated when d < 0.05 or on an obstacle collision; truncated after 50 steps (by the
    ``TimeLimit`` added at registration).

    ## Arguments
    ``arm`` (str, default ``"one_link_1m0"``), ``reward`` (str, default ``"dense"``), or ``task``
    (a :class:`TaskSpec`, overrides both).

    ## Version history
    v0: initial release.
    """

    metadata = {"render_modes": []}

    def __init__(self, arm: str = "one_link_1m0", reward: str = "dense", task: TaskSpec | None = None):
        super().__init__()
        self.task = task.validate() if task is not None else make_task(arm, reward)
        dof = self.task.arm.dof
        self.action_space = spaces.Box(-1.0, 1.0, (dof,), dtype=np.float64)
        self.observation_space = spaces.Box(-np.inf, np.inf, (self.task.observation_size,), dtype=np.float64)
        self._client = None
        self._arm_id = self._block_id = None
        self._joints = list(range(dof))
        self._target = np.zeros(2)

    # -- world ---------------------------------------------------------------------------------
    def _connect(self) -> None:
        with c_output_silenced(1, 2):  # PyBullet's build-time banner (stderr, at import)
            import pybullet
            import pybullet_data
            from pybullet_utils.bullet_client import BulletClient
        with c_output_silenced(1):  # its "argv[0]=" on every connection (stdout)
            client = BulletClient(connection_mode=pybullet.DIRECT)
        client.setAdditionalSearchPath(pybullet_data.getDataPath())
        client.setGravity(0, 0, -10)
        client.setRealTimeSimulation(0)
        client.setTimeStep(self.task.arm.time_step)
        client.loadURDF("plane.urdf")
        self._arm_id = client.loadURDF(str(urdf_path(self.task.arm)), ARM_BASE_POSITION, useFixedBase=True)
        for j in self._joints:
            client.setJointMotorControl2(self._arm_id, j, pybullet.VELOCITY_CONTROL, force=0)
        obstacle = self.task.arm.obstacle
        if obstacle is not None:
            ox, oy = obstacle.position
            self._block_id = client.loadURDF(
                "block.urdf",
                (ox, oy, obstacle.height),
                client.getQuaternionFromEuler(BLOCK_ORIENTATION_RPY),
                useFixedBase=True,
                globalScaling=obstacle.scale,
            )
        self._client = client
        self._torque_control = pybullet.TORQUE_CONTROL

    @property
    def client(self):
        """The PyBullet client (the world is built on first use and kept across episodes)."""
        if self._client is None:
            self._connect()
        return self._client

    @property
    def arm_id(self) -> int:
        self.client  # noqa: B018 - build the world
        return self._arm_id

    # -- state ---------------------------------------------------------------------------------
    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Raw joint angles (rad, unbounded) and velocities (rad/s)."""
        states = self.client.getJointStates(self._arm_id, self._joints)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def upper_arm_clearance(self) -> float:
        """d₁: PyBullet's closest distance between link 1 and the obstacle, metres, clipped at 0."""
        points = self.client.getClosestPoints(
            self._arm_id, self._block_id, CLOSEST_POINTS_RANGE, linkIndexA=0
        )
        return max(0.0, min(p[8] for p in points))

    def _observe(self):
        q, qd = self.joint_state()
        return mechanics.observe(self.task, q, qd, self._target)

    # -- gymnasium API -------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        if "joint_angles" in options or "target" in options:
            q = np.asarray(options["joint_angles"], dtype=np.float64).reshape(self.task.arm.dof)
            target = np.asarray(options["target"], dtype=np.float64).reshape(2)
            qd = np.asarray(options.get("joint_velocities", np.zeros_like(q)), dtype=np.float64).reshape(q.shape)
        else:
            q, target = mechanics.initial_state(self.task.arm, self.np_random.random(4))
            qd = np.zeros_like(q)
        self._target = target
        for j, angle, velocity in zip(self._joints, q, qd, strict=True):
            self.client.resetJointState(self._arm_id, j, float(angle), float(velocity))
        observation, distance, _, _ = self._observe()
        return observation, {"distance": float(distance)}

    def step(self, action):
        action = np.clip(np.asarray(action, dtype=np.float64).reshape(self.task.arm.dof), -1.0, 1.0)
        obstacle = self.task.arm.obstacle
        upper = self.upper_arm_clearance() if obstacle is not None else None
        client = self.client
        client.setJointMotorControlArray(
            self._arm_id, self._joints, self._torque_control, forces=list(action * self.task.arm.torque_scale)
        )
        simulate = client.stepSimulation  # one attribute lookup: a BulletClient builds a new callable at each
        for _ in range(self.task.arm.substeps):
            simulate()
        observation, distance, elbow, effector = self._observe()
        forearm = mechanics.forearm_clearance(self.task, elbow, effector) if obstacle is not None else None
        reward, terms, collision = mechanics.reward_terms(self.task, action, distance, upper, forearm)
        terminated = bool(terms["success"]) or bool(collision)
        info = {"distance": float(distance), "collision": bool(collision), "success": bool(terms["success"])}
        info.update({f"reward_{k}": float(v) for k, v in terms.items() if k != "success"})
        if obstacle is not None:
            info.update(upper_clearance=float(upper), forearm_clearance=float(forearm))
        return observation, float(reward), terminated, False, info

    def close(self):
        if self._client is not None:
            self._client.disconnect()
            self._client = None
        super().close()
