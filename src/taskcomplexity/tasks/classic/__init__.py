"""Batched numba kernels of gymnasium's classic-control environments (the RWG ``kernel`` backend).

:data:`KERNELS` maps each supported gymnasium id to a :class:`ClassicKernel`: its kernel code in
:mod:`taskcomplexity.tasks.classic.kernels`, the constructor arguments it supports, and the reset
draw. A reset reproduces ``env.reset(seed=s)`` exactly: gymnasium seeds ``np_random`` from ``s``
(:func:`gymnasium.utils.seeding.np_random`) and draws the initial state from it; here
:mod:`~taskcomplexity.tasks.classic.resets` makes that generator and its first draws for all the
episodes at once, and the state is made from them as ``Generator.uniform`` makes it. A kernel whose
step draws too (``draws_in_step``: the noisy CartPole) keeps each episode's generator after the reset's
draws and continues it in the step.

Equivalence with gymnasium: ``tests/tasks/test_classic_kernels.py``.

Modules
-------
kernels
    Batched numba steps of gymnasium's classic-control environments.
noisy_cartpole
    CartPole with noise in its initial state and its dynamics (``taskcomplexity/NoisyCartPole-v0``).
resets
    ``gymnasium.utils.seeding.np_random(seed)`` for many seeds at once: its state and its draws.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskcomplexity.tasks.classic import kernels
from taskcomplexity.tasks.classic.resets import draw_uniforms, seed_generators
from taskcomplexity.tasks.registration import NOISY_CARTPOLE_ID


def _uniform(low, high, u: np.ndarray) -> np.ndarray:
    """``Generator.uniform(low, high)`` from its U[0, 1) draws ``u``."""
    return low + (high - low) * u


def _cartpole_reset(u: np.ndarray, params: kernels.ClassicParams) -> np.ndarray:
    return _uniform(-0.05, 0.05, u)


def _noisy_cartpole_reset(u: np.ndarray, params: kernels.ClassicParams) -> np.ndarray:
    return _uniform(-params.reset_noise, params.reset_noise, u)  # CartPole's reset options low, high


def _pendulum_reset(u: np.ndarray, params: kernels.ClassicParams) -> np.ndarray:
    high = np.array([np.pi, 1.0])
    return _uniform(-high, high, u)


def _mountain_car_reset(u: np.ndarray, params: kernels.ClassicParams) -> np.ndarray:
    state = np.zeros((u.shape[0], 3))
    state[:, 0] = _uniform(-0.6, -0.4, u[:, 0])
    return state


def _acrobot_reset(u: np.ndarray, params: kernels.ClassicParams) -> np.ndarray:
    return _uniform(-0.1, 0.1, u).astype(np.float32).astype(np.float64)


@dataclass(frozen=True)
class ClassicKernel:
    """One classic-control environment's kernel.

    Attributes
    ----------
    code : int
        Its branch in :func:`~taskcomplexity.tasks.classic.kernels.step_all`.
    state_size : int
        Width of the kernel's state vector.
    reset : callable
        ``reset(u, params) -> ndarray (K, state_size)``: initial states from the first uniforms ``u``
        (K, reset_draws) of each episode's generator, drawn as the env's ``reset`` draws them.
    reset_draws : int
        Uniforms the env's ``reset`` draws (exactly: a step that draws continues after them).
    arguments : mapping
        Supported constructor arguments and their defaults (fields of
        :class:`~taskcomplexity.tasks.classic.kernels.ClassicParams`, except Pendulum's ``g``).
    draws_in_step : bool
        The env's ``step`` draws from its ``np_random``: the kernel continues each episode's generator.
    """

    code: int
    state_size: int
    reset: Callable[[np.ndarray, kernels.ClassicParams], np.ndarray]
    reset_draws: int
    arguments: Mapping[str, float] = field(default_factory=dict)
    draws_in_step: bool = False

    def supports(self, kwargs: Mapping[str, Any]) -> bool:
        """Whether every constructor argument is one the kernel models (with a plain number value)."""
        return all(k in self.arguments and isinstance(v, (bool, int, float)) for k, v in kwargs.items())

    def params(self, kwargs: Mapping[str, Any]) -> kernels.ClassicParams:
        """The kernel's :class:`~taskcomplexity.tasks.classic.kernels.ClassicParams` for these constructor arguments."""
        values = {**self.arguments, **kwargs}
        if self.code == kernels.PENDULUM:
            return kernels.ClassicParams(gravity_gain=float(3 * values["g"] / (2 * 1.0)))
        return kernels.ClassicParams(**{k: float(v) for k, v in values.items()})

    def start(self, reset_seeds: np.ndarray, kwargs: Mapping[str, Any] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Initial states of episodes reset with ``reset_seeds``, and their generators after the reset.

        Parameters
        ----------
        reset_seeds : int ndarray, shape S
        kwargs : mapping, optional
            The env's constructor arguments (the noisy CartPole's ``reset_noise``).

        Returns
        -------
        states : ndarray, shape S + (state_size,), float64
        generators : ndarray, shape S + (4,) uint64 when ``draws_in_step`` (each episode's PCG64 state
            after the reset's draws), else S + (0,).
        """
        seeds = np.asarray(reset_seeds, dtype=np.int64)
        if seeds.size and not (seeds.min() >= 0 and seeds.max() < 2**32):
            raise ValueError(f"reset seeds must be in [0, 2**32), got {seeds.min()} … {seeds.max()}")
        generators = seed_generators(seeds.reshape(-1))
        states = self.reset(draw_uniforms(generators, self.reset_draws), self.params(kwargs or {}))
        if not self.draws_in_step:
            generators = generators[:, :0]
        return (states.reshape((*seeds.shape, self.state_size)),
                generators.reshape((*seeds.shape, generators.shape[1])))

    def initial_states(self, reset_seeds: np.ndarray, kwargs: Mapping[str, Any] | None = None) -> np.ndarray:
        """Initial states of episodes reset with ``reset_seeds`` (:meth:`start`'s states), shape S + (state_size,)."""
        return self.start(reset_seeds, kwargs)[0]


KERNELS: dict[str, ClassicKernel] = {
    "CartPole-v0": ClassicKernel(kernels.CARTPOLE, 4, _cartpole_reset, 4, {"sutton_barto_reward": False}),
    "CartPole-v1": ClassicKernel(kernels.CARTPOLE, 4, _cartpole_reset, 4, {"sutton_barto_reward": False}),
    "Pendulum-v1": ClassicKernel(kernels.PENDULUM, 2, _pendulum_reset, 2, {"g": 10.0}),
    "MountainCar-v0": ClassicKernel(kernels.MOUNTAIN_CAR, 3, _mountain_car_reset, 1, {"goal_velocity": 0}),
    "MountainCarContinuous-v0": ClassicKernel(kernels.MOUNTAIN_CAR_CONTINUOUS, 3, _mountain_car_reset, 1,
                                              {"goal_velocity": 0}),
    "Acrobot-v1": ClassicKernel(kernels.ACROBOT, 4, _acrobot_reset, 4),
    NOISY_CARTPOLE_ID: ClassicKernel(kernels.NOISY_CARTPOLE, 4, _noisy_cartpole_reset, 4,
                                     {"reset_noise": 0.05, "dynamics_noise": 0.0, "sutton_barto_reward": False},
                                     draws_in_step=True),
}
"""Gymnasium ids with a kernel (gymnasium 1.2.3's classic-control defaults, and this package's noisy CartPole)."""


def kernel_for(env_id: str, kwargs: Mapping[str, Any] | None = None) -> ClassicKernel | None:
    """The kernel of ``env_id`` built with ``kwargs``, or None when there is none."""
    kernel = KERNELS.get(env_id)
    if kernel is None or not kernel.supports(kwargs or {}):
        return None
    return kernel


__all__ = ["KERNELS", "ClassicKernel", "kernel_for"]
