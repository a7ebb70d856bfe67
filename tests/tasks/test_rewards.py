"""The reward kinds are declared once and computed by one scalar function, which every consumer uses."""

from __future__ import annotations

import re
from importlib.resources import files

import numpy as np
import pytest
import yaml

from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks import rewards
from taskcomplexity.tasks.spec import REWARDS, RewardSpec, make_task


def test_every_kind_has_a_config_and_a_preset_and_nothing_else_does():
    configs = {path.name.removesuffix(".yaml"): yaml.safe_load(path.read_text())
               for path in files("taskcomplexity.conf.reward").iterdir() if path.name.endswith(".yaml")}
    assert set(configs) == set(rewards.REWARD_KINDS) == set(REWARDS)
    for name, config in configs.items():
        assert config["kind"] == name
        RewardSpec(**config).validate()


def test_an_unknown_kind_is_refused_naming_the_kinds():
    with pytest.raises(ConfigError, match=rf"reward\.kind must be one of {re.escape(str(list(rewards.REWARD_KINDS)))}, got 'nope'"):
        rewards.reward_kind("nope")


def test_dense_reward_is_the_sum_of_its_signed_terms_in_order():
    rng = np.random.default_rng(0)
    distance, effort = rng.uniform(0, 3, 500), rng.uniform(0, 2, 500)
    hit, near = rng.random(500) < 0.3, rng.uniform(0, 2, 500)
    got = rewards.rewards("dense", distance, 0.05, effort, hit, near, 1000.0, 5.0)
    # the formula, summed left to right: the step kernel's and the reference's arithmetic, so exact
    expected = -(distance * distance) + -effort + -(1000.0 * hit) + -(5.0 * near)
    np.testing.assert_array_equal(got, expected)
    terms = rewards.shaped_terms(distance, effort, hit * 1.0, near, 1000.0, 5.0)
    np.testing.assert_array_equal(((terms[0] + terms[1]) + terms[2]) + terms[3], got)
    # without an obstacle (zeros) the obstacle terms add nothing, bit for bit
    np.testing.assert_array_equal(rewards.rewards("dense", distance, 0.05, effort), -(distance * distance) + -effort)


def test_sparse_reward_is_zero_inside_the_threshold_and_minus_one_outside():
    distance = np.array([[0.0, 0.049], [0.05, 1.0]])  # inside, inside, on the threshold (outside), far
    got = rewards.rewards("sparse", distance, 0.05, effort=np.full((2, 2), 0.7), hit_obstacle=True, near_obstacle=3.0)
    np.testing.assert_array_equal(got, [[0.0, 0.0], [-1.0, -1.0]])  # the action and obstacle do not count
    assert got.shape == (2, 2)


def test_scalar_reward_is_callable_from_python_and_agrees_with_the_array_form():
    for kind in rewards.KINDS.values():
        scalar = rewards.reward(kind.code, 0.3, 0.05, 0.5, False, 0.0, 0.0, 0.0)
        assert scalar == rewards.rewards(kind.name, 0.3, 0.05, 0.5)[()]


def test_goal_reward_kinds_do_not_depend_on_the_action_or_the_obstacle():
    """A kind declared ``goal_reward`` is a function of the goals only (HER relabels it from them alone)."""
    rng = np.random.default_rng(1)
    distance = rng.uniform(0, 0.2, 200)
    for kind in rewards.KINDS.values():
        plain = rewards.rewards(kind.name, distance, 0.05)
        loaded = rewards.rewards(kind.name, distance, 0.05, rng.uniform(0.1, 2, 200), True, 1.0, 1000.0, 5.0)
        assert np.array_equal(plain, loaded) == kind.goal_reward, kind.name


def test_only_kinds_defined_with_an_obstacle_are_allowed_on_the_obstacle_arm():
    for kind in rewards.KINDS.values():
        if kind.obstacle:
            make_task("two_link_obstacle", kind.name)
        else:
            with pytest.raises(ConfigError, match=rf"reward={kind.name} is not available for arm=two_link_obstacle"):
                make_task("two_link_obstacle", kind.name)
