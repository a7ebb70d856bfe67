"""The ``sac`` config group builds valid SACSettings; bad values fail with one line naming the key."""

from __future__ import annotations

import pytest
import torch

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.config import build, plain
from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import SACSettings, protocol_variants, with_budget
from taskcomplexity.rl.settings import resolve_device
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task, preset_tasks

SAC_OPTIONS = sorted(p.stem for p in (CONF_DIR / "sac").glob("*.yaml"))
# shared/spec/sac.md § Protocol: environment steps per seed.
SPEC_BUDGETS = {
    "one_link_1m0-dense": 50_000,
    "one_link_1m0-sparse": 50_000,
    "one_link_1m65-dense": 50_000,
    "one_link_1m65-sparse": 50_000,
    "two_link-dense": 100_000,
    "two_link-sparse": 200_000,
    "two_link_obstacle-dense": 200_000,
}


@pytest.mark.parametrize("option", SAC_OPTIONS)
def test_every_sac_option_composes_into_valid_settings_with_a_budget_for_every_study_task(compose_config, option):
    cfg = compose_config(f"sac={option}")
    settings = build(SACSettings, cfg.sac, "sac")
    study = study_from_config(plain(cfg.study))
    for entry in study.tasks:
        steps = with_budget(settings, entry.sac_steps, task_id=entry.id).total_steps
        assert steps > settings.warmup_steps, "updates must happen within every budget"
        assert steps % settings.collect_steps == 0


def test_the_paper_study_holds_the_reference_budgets_and_the_sac_options_none(compose_config):
    study = study_from_config(plain(compose_config("study=seven_tasks").study))
    assert {entry.id: entry.sac_steps for entry in study.tasks} == SPEC_BUDGETS
    for option in SAC_OPTIONS:
        assert "budgets" not in compose_config(f"sac={option}").sac, option


def test_a_run_budget_is_total_steps_when_set_else_the_study_entry():
    assert with_budget(SACSettings(), 200_000, task_id="two_link-sparse").total_steps == 200_000
    assert with_budget(SACSettings(total_steps=300), 200_000, task_id="two_link-sparse").total_steps == 300
    assert with_budget(SACSettings(total_steps=300), None, task_id="pend").total_steps == 300


def test_a_budget_fraction_scales_every_study_budget_to_a_multiple_of_collect_steps():
    fifth = SACSettings(budget_fraction=0.2)
    resolved = {steps: with_budget(fifth, steps, task_id="t") for steps in (50_000, 100_000, 200_000)}
    assert {steps: s.total_steps for steps, s in resolved.items()} == {50_000: 10_000, 100_000: 20_000,
                                                                        200_000: 40_000}
    for settings in resolved.values():  # resolved settings are complete: they validate and scale no further
        assert settings.budget_fraction == 1.0
        assert settings.validate() == settings
    odd = SACSettings(budget_fraction=0.333)
    assert with_budget(odd, 50_000, task_id="t").total_steps == 16_650  # 0.333 × 50 000 = 16 650, 1 665 rounds
    assert with_budget(SACSettings(budget_fraction=1e-6), 50_000, task_id="t").total_steps == 10  # one round
    # the resolved run is the run with that total_steps: same settings, so the same SAC key
    assert with_budget(fifth, 50_000, task_id="t") == SACSettings(total_steps=10_000)


def test_a_budget_fraction_beside_total_steps_or_out_of_range_is_refused_in_one_line():
    with pytest.raises(ConfigError) as err:
        SACSettings(total_steps=3000, budget_fraction=0.5).validate()
    message = str(err.value)
    assert "sac.budget_fraction=0.5" in message and "sac.total_steps=3000" in message and "\n" not in message
    for bad in (0, -0.2, float("nan"), float("inf"), True):
        with pytest.raises(ConfigError, match=r"sac\.budget_fraction must be a finite number > 0"):
            SACSettings(budget_fraction=bad).validate()


def test_experiment_beyond_is_the_published_study_with_a_fifth_of_the_sac_budgets(compose_config):
    beyond, published = compose_config("experiment=beyond"), compose_config("experiment=published")
    for group in ("rwg", "metrics", "primitives", "occupancy", "learning_path"):
        assert beyond[group] == published[group], group
    settings = build(SACSettings, beyond.sac, "sac").validate()
    assert settings.enabled and settings.seeds == (0, 1) and settings.checkpoint_every == 2000
    budgets = {entry.id: with_budget(settings, entry.sac_steps, task_id=entry.id).total_steps
               for entry in study_from_config(plain(beyond.study)).tasks}
    assert budgets == {task: steps // 5 for task, steps in SPEC_BUDGETS.items()}
    assert beyond.tag == "beyond"


def test_a_task_without_a_budget_is_refused_naming_sac_total_steps():
    with pytest.raises(ConfigError, match=r"no SAC budget for task pend: set sac\.total_steps") as err:
        with_budget(SACSettings(), None, task_id="pend")
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match=r"study\.tasks\[pend\]\.sac_steps must be a multiple of sac\.collect_steps"):
        with_budget(SACSettings(), 1234, task_id="pend")


def test_default_and_paper_options_are_the_published_protocol(compose_config):
    for option in ("default", "published"):
        settings = build(SACSettings, compose_config(f"sac={option}").sac, "sac")
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
        ("sac.total_steps=-5", r"sac\.total_steps must be an integer >= 1, got -5"),
        ("sac.total_steps=1234", r"sac\.total_steps must be a multiple of sac\.collect_steps=10, got 1234"),
        ("sac.hidden_sizes=[256,0]", r"sac\.hidden_sizes must be a non-empty list of integers >= 1"),
        ("+sac.learning_rate=0.1", r"sac\.learning_rate is not a known key \(allowed: "),
        ("sac.device=gpu", r"sac\.device must be one of \['auto', 'cpu', 'cuda'\], got 'gpu'"),
    ],
)
def test_invalid_values_fail_with_one_line_naming_the_key(compose_config, override, message):
    cfg = compose_config(override)
    with pytest.raises(ConfigError, match=message) as err:
        build(SACSettings, cfg.sac, "sac")
    assert "\n" not in str(err.value)


def test_variant_names_the_her_run():
    assert SACSettings().variant == "sac"
    assert SACSettings(her=True).variant == "sac+her"


def test_the_protocol_adds_her_to_the_sparse_tasks_only():
    settings = SACSettings()
    variants = {
        (arm, reward): [v.variant for v in protocol_variants(make_task(arm, reward), settings)]
        for arm, reward in preset_tasks()
    }
    assert variants[("two_link", "sparse")] == ["sac", "sac+her"]
    assert variants[("two_link_obstacle", "dense")] == ["sac"]
    # every preset task once, and HER once more on each sparse one
    assert sum(len(v) for v in variants.values()) == sum(1 + (reward == "sparse") for _, reward in variants)


def test_a_gym_task_gets_sac_only_and_no_reward_is_read():
    # GymTask has no ``reward`` attribute: touching it would raise AttributeError
    assert not hasattr(GymTask("Pendulum-v1"), "reward")
    assert [v.variant for v in protocol_variants(GymTask("Pendulum-v1"), SACSettings(her=True))] == ["sac"]


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a CUDA device")
def test_cuda_where_torch_sees_no_device_is_refused_in_one_line_and_auto_is_the_cpu(compose_config):
    with pytest.raises(ConfigError, match=r"sac\.device=cuda, but torch .* sees no CUDA device .*allowed here: auto, "
                                          r"cpu") as err:
        build(SACSettings, compose_config("sac.device=cuda").sac, "sac")
    assert "\n" not in str(err.value)
    assert resolve_device(build(SACSettings, compose_config().sac, "sac").device).type == "cpu"


def test_a_cpu_build_of_torch_gives_auto_the_cpu_identity_without_importing_torch():
    import subprocess
    import sys

    # a cached run's key is looked up by every study, SAC on or off: under the pinned CPU wheel (2.13.0+cpu) its
    # device adds nothing to the identity, as the device torch resolves does, and torch stays unimported
    assert torch.__version__.endswith("+cpu") and resolve_device("auto").type == "cpu"
    probe = ("import sys; from taskcomplexity.rl.settings import SACSettings, cpu_build_of_torch, device_identity; "
             "print(cpu_build_of_torch(), device_identity(SACSettings(device='auto')), "
             "device_identity(SACSettings(device='cpu')), 'torch' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "{}", "{}", "False"]
