"""Batched numba steps of gymnasium 1.2.3's classic-control environments.

One module on purpose: numba keys a cached kernel on its own source file, so the dynamics and the
driver that inlines them live together and a change to either recompiles both. The one outside piece is
:func:`~taskcomplexity.tasks.classic.resets.next_double` (NumPy's fixed PCG64 arithmetic, shared with
the resets rather than copied): after changing it, touch this file so that numba recompiles.

Each ``_<env>_step(state, outputs, params[, generator])`` does what the env's ``step`` does to one env,
operation for operation in the same floating-point types (gymnasium mixes float32 and float64: the
comments say where), and returns ``(reward, terminated)``; ``_<env>_observe(state, obs)`` writes the
float32 observation gymnasium returns, widened to float64 (what the policy reads). Policy outputs are
decoded in the kernel exactly as :func:`taskcomplexity.tasks.base.decode_actions` does: argmax for
Discrete (the first maximum, like ``np.argmax``), the affine map of (−1, 1) onto [low, high], cast to
the space's float32, for Box.

:func:`step_all` advances every running environment by one step, in parallel over environments,
with the episode bookkeeping (return, length, time limit) of the generic gym backend. An env whose step
draws from its ``np_random`` (the noisy CartPole) draws here from the episode's own PCG64 generator,
kept as four uint64 words per environment (:mod:`taskcomplexity.tasks.classic.resets`, continued after
the reset's draws), so it draws the numbers the env draws.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from taskcomplexity.tasks.classic.resets import next_double

CARTPOLE, PENDULUM, MOUNTAIN_CAR, MOUNTAIN_CAR_CONTINUOUS, ACROBOT, NOISY_CARTPOLE = range(6)


class ClassicParams(NamedTuple):
    """The kernels' record of an env's constructor arguments (floats; each env reads its own fields)."""

    sutton_barto_reward: float = 0.0
    """CartPole: 1 for the Sutton–Barto reward (0 per step, −1 at termination), else 0."""
    gravity_gain: float = 0.0
    """Pendulum: 3g/(2l), 1/s² (l = 1 m)."""
    goal_velocity: float = 0.0
    """MountainCar(Continuous): the velocity the car must reach at the goal."""
    reset_noise: float = 0.0
    """Noisy CartPole: half-width of the initial state's uniform draw (read by the reset, not the step)."""
    dynamics_noise: float = 0.0
    """Noisy CartPole: half-width u of the uniform kick U(−u, u) to θ̇ after each step, rad/s (0: no draw)."""

PI = np.pi


@numba.njit(cache=True)
def _argmax(outputs):
    best = 0
    for k in range(1, outputs.shape[0]):
        if outputs[k] > outputs[best]:
            best = k
    return best


@numba.njit(cache=True)
def _box_action(output, low, high):
    """decode_actions for a one-dimensional float32 Box: float64 arithmetic, then the float32 cast."""
    return np.float32(low + (output + 1.0) * 0.5 * (high - low))


# -- CartPole-v0/v1 (cartpole.py): state float64 [x, x_dot, theta, theta_dot]; params.sutton_barto_reward
@numba.njit(cache=True)
def _cartpole_move(s, outputs):
    """CartPole's forces and one Euler step, in place; the new (x, θ)."""
    gravity = 9.8
    masscart = 1.0
    masspole = 0.1
    total_mass = masspole + masscart
    length = 0.5
    polemass_length = masspole * length
    tau = 0.02
    force = 10.0 if _argmax(outputs) == 1 else -10.0
    x, x_dot, theta, theta_dot = s[0], s[1], s[2], s[3]
    costheta = math.cos(theta)
    sintheta = math.sin(theta)
    temp = (force + polemass_length * (theta_dot * theta_dot) * sintheta) / total_mass
    thetaacc = (gravity * sintheta - costheta * temp) / (
        length * (4.0 / 3.0 - masspole * (costheta * costheta) / total_mass)
    )
    xacc = temp - polemass_length * thetaacc * costheta / total_mass
    x = x + tau * x_dot  # Euler, gymnasium's default integrator
    x_dot = x_dot + tau * xacc
    theta = theta + tau * theta_dot
    theta_dot = theta_dot + tau * thetaacc
    s[0], s[1], s[2], s[3] = x, x_dot, theta, theta_dot
    return x, theta


@numba.njit(cache=True)
def _cartpole_outcome(x, theta, params):
    """(reward, terminated) of a step that reached cart position x and pole angle theta."""
    theta_threshold = 12 * 2 * math.pi / 360
    terminated = x < -2.4 or x > 2.4 or theta < -theta_threshold or theta > theta_threshold
    if params.sutton_barto_reward != 0.0:
        return (-1.0 if terminated else 0.0), terminated
    return 1.0, terminated


@numba.njit(cache=True)
def _cartpole_step(s, outputs, params):
    x, theta = _cartpole_move(s, outputs)
    return _cartpole_outcome(x, theta, params)


# -- taskcomplexity/NoisyCartPole-v0 (noisy_cartpole.py): CartPole's step, then θ̇ += U(−u, u) drawn from
#    the episode's generator (u = params.dynamics_noise; no draw when u = 0), then the termination check
@numba.njit(cache=True)
def _noisy_cartpole_step(s, outputs, params, generator):
    x, theta = _cartpole_move(s, outputs)
    if params.dynamics_noise > 0.0:
        low, high = -params.dynamics_noise, params.dynamics_noise
        s[3] = s[3] + (low + (high - low) * next_double(generator))  # Generator.uniform(low, high)
    return _cartpole_outcome(x, theta, params)  # x and θ as the Euler step left them: the kick moves θ̇ only


@numba.njit(cache=True)
def _cartpole_observe(s, obs):
    for k in range(4):
        obs[k] = np.float32(s[k])


# -- Pendulum-v1 (pendulum.py): state float64 [th, thdot]; params.gravity_gain = 3 g / (2 l)
@numba.njit(cache=True)
def _pendulum_step(s, outputs, params):
    th, thdot = s[0], s[1]
    u = _box_action(outputs[0], -2.0, 2.0)  # a float32 action; np.clip to ±2 is then a no-op
    normalized = ((th + PI) % (2 * PI)) - PI
    # u**2, 0.001*u**2 and 3.0*u are float32 products in NumPy 2 (a Python float times np.float32)
    u_cost = np.float32(0.001) * (u * u)
    costs = normalized * normalized + 0.1 * (thdot * thdot) + np.float64(u_cost)
    newthdot = thdot + (params.gravity_gain * math.sin(th) + np.float64(np.float32(3.0) * u)) * 0.05
    newthdot = min(max(newthdot, -8.0), 8.0)
    s[0] = th + newthdot * 0.05
    s[1] = newthdot
    return -costs, False


@numba.njit(cache=True)
def _pendulum_observe(s, obs):
    obs[0] = np.float32(math.cos(s[0]))
    obs[1] = np.float32(math.sin(s[0]))
    obs[2] = np.float32(s[1])


# -- MountainCar-v0 (mountain_car.py): state float64 [position, velocity]; params.goal_velocity
@numba.njit(cache=True)
def _mountain_car_step(s, outputs, params):
    position, velocity = s[0], s[1]
    velocity = velocity + ((_argmax(outputs) - 1) * 0.001 + math.cos(3 * position) * (-0.0025))
    velocity = min(max(velocity, -0.07), 0.07)
    position = position + velocity
    position = min(max(position, -1.2), 0.6)
    if position == -1.2 and velocity < 0:
        velocity = 0.0
    s[0], s[1] = position, velocity
    return -1.0, position >= 0.5 and velocity >= params.goal_velocity


@numba.njit(cache=True)
def _mountain_car_observe(s, obs):
    obs[0] = np.float32(s[0])
    obs[1] = np.float32(s[1])


# -- MountainCarContinuous-v0 (continuous_mountain_car.py): state [position, velocity, stepped];
#    params.goal_velocity. The env's state is float64 from reset and float32 after its first step;
#    NumPy 2 then computes in float32 wherever a float32 meets a Python float (NEP 50), comparisons
#    included, and so does this kernel.
@numba.njit(cache=True)
def _mountain_car_continuous_step(s, outputs, params):
    force = _box_action(outputs[0], -1.0, 1.0)  # within [−1, 1]: min/max return the float32 itself
    if s[2] == 0.0:  # float64 state
        position, velocity = s[0], s[1]
        push = force * np.float32(0.0015) - np.float32(0.0025 * math.cos(3 * position))
        velocity = velocity + np.float64(push)
        velocity = min(max(velocity, -0.07), 0.07)
        position = min(max(position + velocity, -1.2), 0.6)
        if position == -1.2 and velocity < 0:
            velocity = 0.0
        terminated = position >= 0.45 and velocity >= params.goal_velocity
    else:  # float32 state
        p32, v32 = np.float32(s[0]), np.float32(s[1])
        angle = np.float64(np.float32(3.0) * p32)
        push = force * np.float32(0.0015) - np.float32(0.0025 * math.cos(angle))
        v32 = v32 + push
        v32 = min(max(v32, np.float32(-0.07)), np.float32(0.07))
        p32 = min(max(p32 + v32, np.float32(-1.2)), np.float32(0.6))
        if p32 == np.float32(-1.2) and v32 < np.float32(0.0):
            v32 = np.float32(0.0)
        terminated = p32 >= np.float32(0.45) and v32 >= np.float32(params.goal_velocity)
        position, velocity = np.float64(p32), np.float64(v32)
    reward = 100.0 if terminated else 0.0
    reward -= math.pow(np.float64(force), 2) * 0.1
    s[0] = np.float32(position)
    s[1] = np.float32(velocity)
    s[2] = 1.0
    return reward, terminated


# -- Acrobot-v1 (acrobot.py, book dynamics, RK4 over dt = 0.2 in float64): state [θ1, θ2, θ̇1, θ̇2]
@numba.njit(cache=True)
def _acrobot_dsdt(theta1, theta2, dtheta1, dtheta2, a):
    m1 = 1.0
    m2 = 1.0
    l1 = 1.0
    lc1 = 0.5
    lc2 = 0.5
    I1 = 1.0  # noqa: N806 - gymnasium's names
    I2 = 1.0  # noqa: N806
    g = 9.8
    d1 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * math.cos(theta2)) + I1 + I2
    d2 = m2 * (lc2**2 + l1 * lc2 * math.cos(theta2)) + I2
    phi2 = m2 * lc2 * g * math.cos(theta1 + theta2 - PI / 2.0)
    phi1 = (
        -m2 * l1 * lc2 * dtheta2**2 * math.sin(theta2)
        - 2 * m2 * l1 * lc2 * dtheta2 * dtheta1 * math.sin(theta2)
        + (m1 * lc1 + m2 * l1) * g * math.cos(theta1 - PI / 2)
        + phi2
    )
    ddtheta2 = (a + d2 / d1 * phi1 - m2 * l1 * lc2 * dtheta1**2 * math.sin(theta2) - phi2) / (
        m2 * lc2**2 + I2 - d2**2 / d1
    )
    ddtheta1 = -(d2 * ddtheta2 + phi1) / d1
    return dtheta1, dtheta2, ddtheta1, ddtheta2


@numba.njit(cache=True)
def _wrap(x, m, big):
    diff = big - m
    while x > big:
        x = x - diff
    while x < m:
        x = x + diff
    return x


@numba.njit(cache=True)
def _acrobot_step(s, outputs, params):
    action = _argmax(outputs)
    torque = -1.0 if action == 0 else (0.0 if action == 1 else 1.0)
    dt = 0.2
    dt2 = dt / 2.0
    y0, y1, y2, y3 = s[0], s[1], s[2], s[3]
    a0, a1, a2, a3 = _acrobot_dsdt(y0, y1, y2, y3, torque)
    b0, b1, b2, b3 = _acrobot_dsdt(y0 + dt2 * a0, y1 + dt2 * a1, y2 + dt2 * a2, y3 + dt2 * a3, torque)
    c0, c1, c2, c3 = _acrobot_dsdt(y0 + dt2 * b0, y1 + dt2 * b1, y2 + dt2 * b2, y3 + dt2 * b3, torque)
    d0, d1, d2, d3 = _acrobot_dsdt(y0 + dt * c0, y1 + dt * c1, y2 + dt * c2, y3 + dt * c3, torque)
    h = dt / 6.0
    s[0] = _wrap(y0 + h * (a0 + 2 * b0 + 2 * c0 + d0), -PI, PI)
    s[1] = _wrap(y1 + h * (a1 + 2 * b1 + 2 * c1 + d1), -PI, PI)
    s[2] = min(max(y2 + h * (a2 + 2 * b2 + 2 * c2 + d2), -4 * PI), 4 * PI)
    s[3] = min(max(y3 + h * (a3 + 2 * b3 + 2 * c3 + d3), -9 * PI), 9 * PI)
    terminated = -math.cos(s[0]) - math.cos(s[1] + s[0]) > 1.0
    return (0.0 if terminated else -1.0), terminated


@numba.njit(cache=True)
def _acrobot_observe(s, obs):
    obs[0] = np.float32(math.cos(s[0]))
    obs[1] = np.float32(math.sin(s[0]))
    obs[2] = np.float32(math.cos(s[1]))
    obs[3] = np.float32(math.sin(s[1]))
    obs[4] = np.float32(s[2])
    obs[5] = np.float32(s[3])


@numba.njit(cache=True)
def _observe(code, s, obs):
    if code == CARTPOLE or code == NOISY_CARTPOLE:
        _cartpole_observe(s, obs)
    elif code == PENDULUM:
        _pendulum_observe(s, obs)
    elif code == ACROBOT:
        _acrobot_observe(s, obs)
    else:
        _mountain_car_observe(s, obs)


@numba.njit(cache=True)
def _step(code, s, outputs, params):
    if code == CARTPOLE:
        return _cartpole_step(s, outputs, params)
    if code == PENDULUM:
        return _pendulum_step(s, outputs, params)
    if code == MOUNTAIN_CAR:
        return _mountain_car_step(s, outputs, params)
    if code == MOUNTAIN_CAR_CONTINUOUS:
        return _mountain_car_continuous_step(s, outputs, params)
    return _acrobot_step(s, outputs, params)


@numba.njit(cache=True, parallel=True)
def observe_all(code, state, obs):
    """Observations of every environment.

    Parameters
    ----------
    code : int
        The env's kernel code (CARTPOLE, …).
    state : ndarray (K, S) float64
    obs : ndarray (K, O) float64, written
    """
    for i in numba.prange(state.shape[0]):
        _observe(code, state[i], obs[i])


@numba.njit(cache=True)
def _count(code, state, obs, running, returns, steps, max_steps, i, reward, terminated):
    """Book environment i's step (return, length, end); whether it still runs afterwards."""
    returns[i] += reward
    steps[i] += 1
    if terminated or steps[i] >= max_steps:
        running[i] = False
        return 0
    _observe(code, state[i], obs[i])
    return 1


@numba.njit(cache=True)
def _advance(code, params, state, outputs, obs, running, returns, steps, max_steps, i):
    """One step of environment i if it runs; whether it still runs afterwards."""
    if not running[i]:
        return 0
    reward, terminated = _step(code, state[i], outputs[i], params)
    return _count(code, state, obs, running, returns, steps, max_steps, i, reward, terminated)


@numba.njit(cache=True)
def _advance_drawing(code, params, state, generators, outputs, obs, running, returns, steps, max_steps, i):
    """:func:`_advance` for the env whose step draws (NOISY_CARTPOLE), from environment i's generator."""
    if not running[i]:
        return 0
    reward, terminated = _noisy_cartpole_step(state[i], outputs[i], params, generators[i])
    return _count(code, state, obs, running, returns, steps, max_steps, i, reward, terminated)


@numba.njit(cache=True, parallel=True)
def step_all(code, params, state, generators, outputs, obs, running, returns, steps, max_steps):
    """One step of every running environment, in parallel over environments.

    Parameters
    ----------
    code : int
    params : ClassicParams
        The env's constructor arguments.
    state : ndarray (K, S) float64, updated
    generators : ndarray (K, 4) uint64, updated
        Each environment's PCG64 generator (:func:`~taskcomplexity.tasks.classic.resets.seed_generators`)
        for an env whose step draws; (K, 0) for the others (never read).
    outputs : ndarray (K, A) float64
        The policies' outputs (in (−1, 1) for Box actions).
    obs : ndarray (K, O) float64, updated where the episode goes on
    running : ndarray (K,) bool, updated (False after termination or truncation at ``max_steps``)
    returns : ndarray (K,) float64, updated (undiscounted, summed in float64 like the gym backend)
    steps : ndarray (K,) int64, updated

    Returns
    -------
    int: environments still running.
    """
    # Two loops, chosen once: a draw's branch inside the loop every env runs costs the others ~10 %.
    alive = 0
    if code == NOISY_CARTPOLE:
        for i in numba.prange(state.shape[0]):
            alive += _advance_drawing(code, params, state, generators, outputs, obs, running, returns, steps,
                                      max_steps, i)
    else:
        for i in numba.prange(state.shape[0]):
            alive += _advance(code, params, state, outputs, obs, running, returns, steps, max_steps, i)
    return alive


@numba.njit(cache=True)
def step_serial(code, params, state, generators, outputs, obs, running, returns, steps, max_steps):
    """:func:`step_all` on one thread (for small batches, where starting the threads costs more)."""
    alive = 0
    if code == NOISY_CARTPOLE:
        for i in range(state.shape[0]):
            alive += _advance_drawing(code, params, state, generators, outputs, obs, running, returns, steps,
                                      max_steps, i)
    else:
        for i in range(state.shape[0]):
            alive += _advance(code, params, state, outputs, obs, running, returns, steps, max_steps, i)
    return alive
