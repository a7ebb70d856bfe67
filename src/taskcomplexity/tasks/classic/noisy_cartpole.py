"""CartPole with noise in its initial state and in its dynamics (``taskcomplexity/NoisyCartPole-v0``)."""

from __future__ import annotations

import math
from numbers import Real

import numpy as np
from gymnasium.envs.classic_control.cartpole import CartPoleEnv

from taskcomplexity.errors import ConfigError


def check_noise(name: str, value: object) -> float:
    """A noise half-width as a float; ConfigError naming ``name`` unless it is a finite number >= 0."""
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise ConfigError(f"{name} must be a finite number >= 0, got {value!r}")
    if value < 0:
        raise ConfigError(f"{name} must be >= 0, got {value!r}")
    return float(value)


class NoisyCartPoleEnv(CartPoleEnv):
    """Gymnasium's CartPole with a wider reset and a random kick to the pole each step.

    ## Description

    CartPole-v0 (Barto, Sutton and Anderson's cart-pole, as gymnasium 1.2.3 implements it) made harder
    in two ways, each set by one argument: the initial state is drawn from a wider interval
    (``reset_noise``), and after every step the pole's angular velocity receives a uniform random kick
    (``dynamics_noise``). With the defaults (0.05, 0) it is CartPole-v0 exactly: same draws, same
    states, same returns.

    ## Action Space

    ``Discrete(2)``, as CartPole:

    | Num | Action                  |
    |-----|-------------------------|
    | 0   | push the cart left (−10 N) |
    | 1   | push the cart right (+10 N) |

    ## Observation Space

    ``Box(4,)`` float32, as CartPole (the state, rounded to float32):

    | Num | Observation           | Unit  | Min     | Max    |
    |-----|-----------------------|-------|---------|--------|
    | 0   | cart position         | m     | −4.8    | 4.8    |
    | 1   | cart velocity         | m/s   | −Inf    | Inf    |
    | 2   | pole angle            | rad   | −0.419  | 0.419  |
    | 3   | pole angular velocity | rad/s | −Inf    | Inf    |

    ## Transition

    One ``step(action)``, in this order:

    1. CartPole's step: the forces and accelerations from the current state, then one explicit Euler
       step of τ = 0.02 s (gymnasium's arithmetic, float64);
    2. if ``dynamics_noise`` = u > 0: θ̇ ← θ̇ + ξ with ξ ~ U(−u, u), one ``self.np_random.uniform(−u, u)``
       draw (so the noise is seeded by ``reset(seed=…)`` and continues the generator after the reset's
       four draws); with u = 0 nothing is drawn;
    3. the termination check on x and θ. The kick changes θ̇ only, so it moves θ from the next step
       on: checking before or after step 2 gives the same flag.

    The batched kernel (``taskcomplexity.tasks.classic``, code ``NOISY_CARTPOLE``) makes the same
    draws in the same order; ``tests/tasks/test_noisy_cartpole.py`` holds the two together.

    ## Rewards

    As CartPole: +1 for every step, the terminating one included (with ``sutton_barto_reward``: 0 per
    step and −1 at termination). The return lies in [1, 200].

    ## Starting State

    Each of x, ẋ, θ, θ̇ uniform in [−u₀, u₀) with u₀ = ``reset_noise``: CartPole's reset with the
    options ``low=−u₀, high=u₀`` (``reset(options=…)`` still overrides them).

    ## Episode End

    1. Termination: |θ| > 12° (0.2094 rad);
    2. Termination: |x| > 2.4 m;
    3. Truncation: 200 steps (the time limit of the registered id, as CartPole-v0).

    ## Arguments

    | Parameter             | Type  | Default | Description                                               |
    |-----------------------|-------|---------|-----------------------------------------------------------|
    | `reset_noise`         | float | 0.05    | u₀ ≥ 0: half-width of the initial state's uniform draw    |
    | `dynamics_noise`      | float | 0.0     | u ≥ 0: half-width of the per-step kick to θ̇, rad/s       |
    | `sutton_barto_reward` | bool  | False   | CartPole's Sutton–Barto reward                            |
    | `render_mode`         | str   | None    | CartPole's render modes                                   |

    A negative (or non-finite) noise raises :class:`~taskcomplexity.errors.ConfigError` naming the
    argument and the value.

    ## Version History

    * v0: CartPole-v0 (gymnasium 1.2.3) with ``reset_noise`` and ``dynamics_noise``.
    """

    def __init__(
        self,
        reset_noise: float = 0.05,
        dynamics_noise: float = 0.0,
        sutton_barto_reward: bool = False,
        render_mode: str | None = None,
    ):
        self.reset_noise = check_noise("reset_noise", reset_noise)
        self.dynamics_noise = check_noise("dynamics_noise", dynamics_noise)
        super().__init__(sutton_barto_reward=sutton_barto_reward, render_mode=render_mode)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        bounds = {"low": -self.reset_noise, "high": self.reset_noise, **(options or {})}
        return super().reset(seed=seed, options=bounds)

    def step(self, action):
        obs, reward, terminated, truncated, info = super().step(action)
        if self.dynamics_noise > 0.0:
            self.state[3] += self.np_random.uniform(-self.dynamics_noise, self.dynamics_noise)
            obs = np.array(self.state, dtype=np.float32)
        return obs, reward, terminated, truncated, info
