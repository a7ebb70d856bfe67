"""Dynamic movement primitives: the spring without weights, and demonstrated trajectories reproduced."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.policies.movement_primitives import DMPSpec

DURATION, STEPS = 1.0, 50


def test_without_weights_it_is_the_critically_damped_spring():
    spec = DMPSpec(basis=8, substeps=200)
    start, goal = np.array([[0.3, -1.0]]), np.array([[2.0, 0.5]])
    y = spec.rollout(np.zeros((1, 2, 8)), start, goal, duration=DURATION, steps=STEPS)
    t = np.linspace(0.0, DURATION, STEPS + 1)[:, None]
    omega = spec.alpha_z / (2 * DURATION)  # τ²ÿ + α_zτẏ + α_zβ_z(y − g) = 0 with β_z = α_z/4
    expected = goal + (start - goal) * (1 + omega * t) * np.exp(-omega * t)
    np.testing.assert_allclose(y[0], expected, atol=2e-3 * np.abs(goal - start).max())


def _euler_per_primitive(spec, weights, start, goal, duration, steps, extra_steps):
    """The integration as the definition reads: each primitive's own phase and forcing at every sub-step."""
    y, z, x = start.copy(), np.zeros_like(start), np.ones(len(start))
    amplitude, dt = goal - start, duration / (steps * spec.substeps)
    out = [y]
    for _ in range(steps + extra_steps):
        for _ in range(spec.substeps):
            f = spec.forcing(x, weights) * amplitude
            dz = (spec.alpha_z * (spec.beta_z * (goal - y) - z) + f) / duration
            z, y = z + dt * dz, y + dt * (z / duration)
            x = x - dt * spec.alpha_x * x / duration
        out.append(y)
    return np.stack(out, axis=1)


def test_the_batch_shares_its_phase_and_gets_each_primitives_own_numbers_bit_for_bit():
    """rollout evaluates the basis once per sub-step for the whole batch: not one bit may move."""
    rng = np.random.default_rng(3)
    spec = DMPSpec(basis=10, substeps=10)
    weights = rng.normal(scale=50.0, size=(257, 2, 10))
    start, goal = rng.uniform(-np.pi, np.pi, (257, 2)), rng.uniform(-np.pi, np.pi, (257, 2))
    fast = spec.rollout(weights, start, goal, duration=0.4, steps=20, extra_steps=30)
    reference = _euler_per_primitive(spec, weights, start, goal, 0.4, 20, 30)
    assert fast.shape == (257, 51, 2)
    assert np.array_equal(fast, reference)


@pytest.mark.parametrize("bump", [0.0, 0.4])
def test_fitted_weights_reproduce_a_demonstrated_trajectory(bump):
    # minimum-jerk from y₀ to g, with a sideways bump that vanishes at both ends (a movement with overshoot)
    spec = DMPSpec(basis=30, substeps=50)
    s = np.linspace(0.0, 1.0, STEPS + 1)[:, None]
    start, goal = np.array([0.5, 2.0]), np.array([2.5, 1.0])
    demo = start + (goal - start) * (10 * s**3 - 15 * s**4 + 6 * s**5) + bump * np.sin(np.pi * s) * np.array([1, -1])
    weights = spec.fit(demo, duration=DURATION)
    assert weights.shape == (2, 30)
    y = spec.rollout(weights[None], start[None], goal[None], duration=DURATION, steps=STEPS)[0]
    amplitude = np.abs(goal - start).max()
    assert np.abs(y - demo).max() < 0.03 * amplitude
    # the weights matter: without them the spring takes another path
    spring = spec.rollout(np.zeros((1, 2, 30)), start[None], goal[None], duration=DURATION, steps=STEPS)[0]
    assert np.abs(spring - demo).max() > 0.1 * amplitude


def test_primitives_of_a_batch_are_independent_and_random_weights_head_for_the_goal():
    spec = DMPSpec()
    rng = np.random.default_rng(0)
    weights = rng.normal(0.0, 50.0, size=(4, 1, spec.basis))
    start, goal = rng.uniform(-3, 3, size=(4, 1)), rng.uniform(-3, 3, size=(4, 1))
    together = spec.rollout(weights, start, goal, duration=DURATION, steps=STEPS)
    alone = spec.rollout(weights[2:3], start[2:3], goal[2:3], duration=DURATION, steps=STEPS)
    np.testing.assert_array_equal(together[2], alone[0])
    assert len({tuple(np.round(r[:, 0], 6)) for r in together}) == 4  # different weights, different paths
    # the forcing fades with the phase (x(τ) = e^(−3)): at the end of the movement every primitive is near its goal
    np.testing.assert_allclose(together[:, -1], goal, atol=0.05 * np.abs(goal - start).max())


def test_a_bad_spec_is_refused():
    with pytest.raises(ValueError, match="basis and substeps must be >= 1"):
        DMPSpec(basis=0).validate()
    with pytest.raises(ValueError, match="alpha_z and alpha_x must be > 0"):
        DMPSpec(alpha_z=0.0).validate()
