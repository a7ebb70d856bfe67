"""Config groups compose into valid task specs, or fail with one line naming the key."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from taskcomplexity.config import build, task_from_config
from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks.spec import ARMS, REWARDS, ArmSpec, RewardSpec, make_task

CONF = Path(__file__).resolve().parents[2] / "conf"
ARM_NAMES = sorted(p.stem for p in (CONF / "arm").glob("*.yaml"))
REWARD_NAMES = sorted(p.stem for p in (CONF / "reward").glob("*.yaml"))


@pytest.mark.parametrize("arm", ARM_NAMES)
@pytest.mark.parametrize("reward", REWARD_NAMES)
def test_every_arm_reward_composition_is_valid_or_refused_with_the_documented_message(compose_config, arm, reward):
    cfg = compose_config(f"arm={arm}", f"reward={reward}")
    if arm == "two_link_obstacle" and reward == "sparse":
        with pytest.raises(ConfigError, match=r"reward=sparse is not available for arm=two_link_obstacle \(allowed: dense"):
            task_from_config(cfg)
        return
    task = task_from_config(cfg)
    assert task.task_id == f"{arm}-{reward}"
    # the YAML files and the library presets describe the same task
    assert task == make_task(arm, reward)


@pytest.mark.parametrize("arm", ARM_NAMES)
def test_yaml_arms_equal_the_presets(compose_config, arm):
    cfg = compose_config(f"arm={arm}")
    assert build(ArmSpec, cfg.arm, "arm") == ARMS[arm]


@pytest.mark.parametrize("reward", REWARD_NAMES)
def test_yaml_rewards_equal_the_presets(reward):
    assert build(RewardSpec, yaml.safe_load((CONF / "reward" / f"{reward}.yaml").read_text()), "reward") == REWARDS[reward]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("arm.links.0.length=-1.0", r"arm\.links\[0\]\.length must be a finite number > 0, got -1\.0"),
        ("arm.torque_scale=[-30.0]", r"arm\.torque_scale\[0\] must be a finite number > 0, got -30\.0"),
        ("arm.time_step=0", r"arm\.time_step must be a finite number > 0, got 0"),
        ("arm.links.0.mass=heavy", r"arm\.links\[0\]\.mass must be a number, got 'heavy'"),
        ("arm.torque_scale=[1.0,2.0]", r"arm\.torque_scale must have one entry per link \(1\)"),
        ("reward.kind=shaped", r"reward\.kind must be one of \['dense', 'sparse'\], got 'shaped'"),
        ("reward.threshold=-0.05", r"reward\.threshold must be a finite number > 0"),
        ("+arm.colour=red", r"arm\.colour is not a known key \(allowed: "),
    ],
)
def test_invalid_values_fail_with_one_line_naming_key_and_allowed(compose_config, override, message):
    cfg = compose_config(override)
    with pytest.raises(ConfigError, match=message) as err:
        task_from_config(cfg)
    assert "\n" not in str(err.value)


def test_unknown_arm_preset_names_the_allowed_ones():
    with pytest.raises(ConfigError, match=r"arm must be one of \['one_link_1m0', 'one_link_1m65', 'two_link', 'two_link_obstacle'\], got 'three_link'"):
        make_task("three_link")


def test_presets_are_frozen_dataclasses():
    arm = ARMS["two_link"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        arm.time_step = 1.0  # type: ignore[misc]
