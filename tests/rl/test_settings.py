"""The ``sac`` config group builds valid SACSettings; bad values fail with one line naming the key."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import PAPER_BUDGETS, SACSettings, protocol_variants
from taskcomplexity.tasks.spec import STUDY_TASKS, make_task

CONF = Path(__file__).resolve().parents[2] / "conf"
SAC_OPTIONS = sorted(p.stem for p in (CONF / "sac").glob("*.yaml"))


@pytest.mark.parametrize("option", SAC_OPTIONS)
def test_every_sac_option_composes_into_valid_settings_with_a_budget_for_every_study_task(compose_config, option):
    settings = build(SACSettings, compose_config(f"sac={option}").sac, "sac")
    for arm, reward in STUDY_TASKS:
        steps = settings.steps_for(make_task(arm, reward))
        assert steps > settings.warmup_steps, "updates must happen within every budget"
        assert steps % settings.collect_steps == 0


def test_default_and_paper_options_are_the_published_protocol(compose_config):
    for option in ("default", "paper"):
        settings = build(SACSettings, compose_config(f"sac={option}").sac, "sac")
        assert settings.budgets == PAPER_BUDGETS
        assert settings.total_steps is None
        assert settings.seeds == (0, 1, 2, 3, 4)
        assert (settings.eval_every, settings.eval_episodes) == (1000, 10)
        # sac.md's hyper-parameters
        assert settings.hidden_sizes == (256, 256)
        assert (settings.actor_lr, settings.critic_lr, settings.gamma) == (1e-3, 1e-3, 0.99)
        assert (settings.alpha, settings.tau, settings.batch_size) == (0.2, 0.005, 64)
        assert (settings.buffer_size, settings.updates_per_step) == (1_000_000, 1)
        assert (settings.her_ratio, settings.her_strategy) == (0.8, "future")


def test_the_yaml_defaults_equal_the_dataclass_defaults(compose_config):
    assert build(SACSettings, compose_config("sac=default").sac, "sac") == SACSettings()


def test_smoke_makes_gradient_updates_within_a_few_hundred_steps(compose_config):
    settings = build(SACSettings, compose_config("sac=smoke").sac, "sac")
    assert settings.total_steps <= 500
    assert settings.total_steps - settings.warmup_steps >= 100  # updates, one per step after warm-up


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("sac.gamma=1.5", r"sac\.gamma must be a number in \[0, 1\], got 1\.5"),
        ("sac.tau=0", r"sac\.tau must be a number in \(0, 1\], got 0"),
        ("sac.batch_size=0", r"sac\.batch_size must be an integer >= 1, got 0"),
        ("sac.batch_size=6.5", r"sac\.batch_size must be an integer, got 6\.5"),
        ("sac.alpha=-0.2", r"sac\.alpha must be a finite number > 0, got -0\.2"),
        ("sac.her_ratio=1.2", r"sac\.her_ratio must be a number in \[0, 1\], got 1\.2"),
        ("sac.her_strategy=past", r"sac\.her_strategy must be one of \['future', 'final', 'episode', 'random'\]"),
        ("sac.loss_function=huber", r"sac\.loss_function must be one of \['l2', 'l1', 'smooth_l1'\]"),
        ("sac.seeds=[0,0]", r"sac\.seeds must be a non-empty list of distinct integers >= 0, got \[0, 0\]"),
        ("sac.eval_every=1005", r"sac\.eval_every must be a multiple of sac\.collect_steps=10, got 1005"),
        ("sac.budgets.two_link-dense=-5", r"sac\.budgets\.two_link-dense must be an integer >= 1, got -5"),
        ("sac.total_steps=1234", r"sac\.total_steps must be a multiple of sac\.collect_steps=10, got 1234"),
        ("sac.hidden_sizes=[256,0]", r"sac\.hidden_sizes must be a non-empty list of integers >= 1"),
        ("+sac.learning_rate=0.1", r"sac\.learning_rate is not a known key \(allowed: "),
    ],
)
def test_invalid_values_fail_with_one_line_naming_the_key(compose_config, override, message):
    cfg = compose_config(override)
    with pytest.raises(ConfigError, match=message) as err:
        build(SACSettings, cfg.sac, "sac")
    assert "\n" not in str(err.value)


def test_a_task_without_a_budget_is_refused_naming_the_task():
    settings = dataclasses.replace(SACSettings(), budgets={"two_link-dense": 1000})
    with pytest.raises(ConfigError, match=r"sac\.budgets has no entry for task 'one_link_1m0-dense'"):
        settings.steps_for(make_task("one_link_1m0", "dense"))


def test_variant_names_the_her_run():
    assert SACSettings().variant == "sac"
    assert SACSettings(her=True).variant == "sac+her"


def test_the_protocol_adds_her_to_the_sparse_tasks_only():
    settings = SACSettings()
    variants = {
        (arm, reward): [v.variant for v in protocol_variants(make_task(arm, reward), settings)]
        for arm, reward in STUDY_TASKS
    }
    assert variants[("two_link", "sparse")] == ["sac", "sac+her"]
    assert variants[("two_link_obstacle", "dense")] == ["sac"]
    assert sum(len(v) for v in variants.values()) == 10  # 7 tasks + HER on the 3 sparse ones
