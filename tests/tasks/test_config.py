"""Config groups compose into valid task specs, or fail with one line naming the key."""

from __future__ import annotations

import dataclasses
import importlib.util
import re

import pytest
import yaml

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.families import network_from_config
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.rwg.backends import task_backends
from taskcomplexity.tasks.from_config import task_from_config
from taskcomplexity.tasks.rewards import REWARD_KINDS, reward_kind
from taskcomplexity.tasks.spec import REWARDS, ArmSpec, RewardSpec, arm_presets, make_task

ARM_NAMES = sorted(p.stem for p in (CONF_DIR / "arm").glob("*.yaml"))
REWARD_NAMES = sorted(p.stem for p in (CONF_DIR / "reward").glob("*.yaml"))


@pytest.mark.parametrize("arm", ARM_NAMES)
@pytest.mark.parametrize("reward", REWARD_NAMES)
def test_every_arm_reward_composition_is_valid_or_refused_with_the_documented_message(compose_config, arm, reward):
    cfg = compose_config(f"arm={arm}", f"reward={reward}")
    if arm_presets()[arm].obstacle is not None and not reward_kind(reward).obstacle:
        with pytest.raises(ConfigError, match=rf"reward={reward} is not available for arm={arm} \(allowed: dense"):
            task_from_config(cfg)
        return
    task = task_from_config(cfg)
    assert task.task_id == f"{arm}-{reward}"
    # the YAML files and the library presets describe the same task
    assert task == make_task(arm, reward)


@pytest.mark.parametrize("arm", ARM_NAMES)
def test_the_presets_are_what_hydra_composes(compose_config, arm):
    # arm_presets() reads conf/arm/*.yaml itself (defaults list included): it must agree with Hydra
    cfg = compose_config(f"arm={arm}")
    assert build(ArmSpec, cfg.arm, "arm") == arm_presets()[arm]


@pytest.mark.parametrize("reward", REWARD_NAMES)
def test_yaml_rewards_equal_the_presets(reward):
    assert build(RewardSpec, yaml.safe_load((CONF_DIR / "reward" / f"{reward}.yaml").read_text()), "reward") == REWARDS[reward]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("arm.links.0.length=-1.0", r"arm\.links\[0\]\.length must be a finite number > 0, got -1\.0"),
        ("arm.torque_scale=[-30.0]", r"arm\.torque_scale\[0\] must be a finite number > 0, got -30\.0"),
        ("arm.time_step=0", r"arm\.time_step must be a finite number > 0, got 0"),
        ("arm.links.0.mass=heavy", r"arm\.links\[0\]\.mass must be a number, got 'heavy'"),
        ("arm.torque_scale=[1.0,2.0]", r"arm\.torque_scale must have one entry per link \(1\)"),
        ("reward.kind=shaped", rf"reward\.kind must be one of {re.escape(str(list(REWARD_KINDS)))}, got 'shaped'"),
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
    allowed = re.escape(str(ARM_NAMES))  # every conf/arm/*.yaml, sorted
    with pytest.raises(ConfigError, match=rf"arm must be one of {allowed}, got 'three_link'"):
        make_task("three_link")


def test_presets_are_frozen_dataclasses():
    arm = arm_presets()["two_link"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        arm.time_step = 1.0  # type: ignore[misc]


TASK_PRESETS = sorted(p.stem for p in (CONF_DIR / "task").glob("*.yaml") if p.stem not in ("gym", "reaching"))
STUDIES = sorted(p.stem for p in (CONF_DIR / "study").glob("*.yaml"))


EXTRA = re.compile(r"task\.env_id=\S+ needs (?P<module>MuJoCo|shimmy|metaworld), which is not installed: "
                   r"pip install -e '\.\[(?P<extra>mujoco|dmc|metaworld)\]'")


def refused_for_a_missing_extra(err: ConfigError) -> bool:
    """Whether ``err`` is the one line that names the extra a task needs, and that extra's module is missing."""
    found = EXTRA.fullmatch(str(err))
    return bool(found) and importlib.util.find_spec({"MuJoCo": "mujoco", "shimmy": "shimmy", "metaworld": "metaworld"}[found["module"]]) is None


@pytest.mark.parametrize("preset", TASK_PRESETS)
def test_every_task_preset_composes_into_a_gymnasium_task(compose_config, preset):
    from taskcomplexity.tasks.gym_task import GymTask

    cfg = compose_config(f"task={preset}")
    try:
        task = task_from_config(cfg)
    except ConfigError as err:  # a MuJoCo or DM Control preset without its extra: refused in one line naming it
        assert refused_for_a_missing_extra(err), err
        return
    assert isinstance(task, GymTask) and task.env_id == cfg.task.env_id
    assert task.max_steps >= 1 and task.observation_size >= 1 and task.action_size >= 1


def test_a_gym_task_needs_its_id_and_refuses_reaching_keys(compose_config):
    with pytest.raises(ConfigError, match=r"task\.env_id is required with task=gym"):
        task_from_config(compose_config("task=gym"))
    task = task_from_config(compose_config("task=gym", "task.env_id=Pendulum-v1", "task.max_steps=60"))
    assert (task.task_id, task.max_steps) == ("Pendulum-v1", 60)
    from taskcomplexity.study.plan import refuse_unread_overrides

    with pytest.raises(ConfigError, match=r"arm=two_link is not read by task Pendulum-v1"):
        refuse_unread_overrides(task, ["arm=two_link"])
    with pytest.raises(ConfigError, match=r"max_steps=20 is not read by task Pendulum-v1"):
        refuse_unread_overrides(task, ["max_steps=20"])
    refuse_unread_overrides(task, ["task.max_steps=20", "rwg.policies=5"])  # keys a gym task reads


@pytest.mark.parametrize("study", STUDIES)
def test_every_shipped_study_composes_into_requests_for_each_of_its_tasks(compose_config, study):
    from taskcomplexity.study.plan import study_from, study_requests

    cfg = compose_config(f"study={study}", "experiment=smoke")
    loaded = study_from(cfg)
    try:
        pairs = study_requests(cfg, loaded)
    except ConfigError as err:  # a study of MuJoCo or DM Control tasks without the extras
        assert refused_for_a_missing_extra(err), err
        return
    assert [entry.id for entry, _ in pairs] == list(loaded.ids)
    for entry, request in pairs:
        assert request.backend == task_backends(request.task)[0]  # backend=auto: the task's fastest
        for group, read in (("prior", lambda node: build(PriorSpec, node, "prior")), ("network", network_from_config)):
            chosen = entry.selection.get(group, getattr(loaded, group) or {"prior": "normal", "network": "mlp32"}[group])
            expected = read(yaml.safe_load((CONF_DIR / group / f"{chosen}.yaml").read_text()))
            assert getattr(request, group) == expected
    for relation in loaded.relations:
        assert {relation.easier, relation.harder} <= set(loaded.ids)
    assert len({request.key for _, request in pairs}) == len(pairs)  # every entry is a different computation


@pytest.mark.parametrize(
    ("study", "message"),
    [
        ({"name": "s", "tasks": [{"task": "cartpole"}], "relations": [{"easier": "cartpole", "harder": "pend"}]},
         r"study\.relations\[0\]\.harder=pend is not a task of the study \(its ids: cartpole\)"),
        ({"name": "s", "tasks": [{"task": "cartpole"}, {"task": "cartpole"}]},
         r"study\.tasks\[1\]\.id=cartpole is used twice"),
        ({"name": "s", "tasks": [{"label": "no task"}]}, r"study\.tasks\[0\] must choose a task"),
        ({"name": "s", "tasks": [{"task": "cartpole", "colour": "red"}]}, r"study\.tasks\[0\]\.colour is not a known key"),
        ({"name": "s", "tasks": [{"task": "cartpole"}], "reference": {"acrobot": 1.0}},
         r"study\.reference=acrobot is not a task of the study"),
        ({"name": "s", "tasks": [{"task": "cartpole"}], "orders": {"all": ["cartpole", "x"]}},
         r"study\.orders\.all=x is not a task of the study"),
        ({"name": "s", "tasks": [{"task": "cartpole"}], "published": {"policies": 100, "episodes": 10}},
         r"study\.published must be a mapping with policies, episodes, bins"),
        ({"name": "s", "tasks": [{"task": "cartpole"}], "published": {"policies": 100, "episodes": 1, "bins": 10}},
         r"study\.published\.episodes must be an integer >= 2, got 1"),
    ],
)
def test_bad_studies_are_refused_in_one_line_naming_the_key(study, message):
    from taskcomplexity.study_data import study_from_config

    with pytest.raises(ConfigError, match=message) as err:
        study_from_config(study)
    assert "\n" not in str(err.value)


def test_a_study_entry_that_chooses_its_own_arm_refuses_the_same_override_on_the_command_line():
    from taskcomplexity.study.compose import _entry_overrides
    from taskcomplexity.study_data import study_from_config

    entry = study_from_config({"name": "s", "tasks": [{"arm": "two_link", "reward": "dense"}]}).tasks[0]
    assert _entry_overrides(entry, ["arm.links.0.mass=7"], "study.tasks[0]") == [
        "arm.links.0.mass=7", "arm=two_link", "reward=dense"]
    with pytest.raises(ConfigError, match=r"arm=one_link_1m0 conflicts with study\.tasks\[0\] \(two_link-dense\)"):
        _entry_overrides(entry, ["arm=one_link_1m0"], "study.tasks[0]")


def test_experiment_published_runs_at_the_scale_the_study_declares(compose_config):
    from taskcomplexity.study.plan import study_from

    cfg = compose_config("experiment=published")
    published = study_from(cfg).published
    assert (cfg.rwg.policies, cfg.rwg.episodes, cfg.metrics.bins) == (published.policies, published.episodes,
                                                                      published.bins) == (10_000, 500, 100_000)
    assert cfg.sac.enabled is False and list(cfg.sac.seeds) == [0, 1, 2, 3, 4]  # SAC from the cache only
    # a study's own published scale moves the experiment with it
    cfg = compose_config("experiment=published", "study.published.policies=2000")
    assert cfg.rwg.policies == 2000


def test_experiment_published_without_a_published_scale_is_one_line(compose_config, capsys):
    from taskcomplexity.cli import one_line_errors

    cfg = compose_config("experiment=published", "study=ablation")
    with pytest.raises(SystemExit) as stop:
        one_line_errors(lambda c: c.rwg.policies)(cfg)
    assert stop.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("error: rwg.policies = ${study.published.policies}, but the config has no "
                           "study.published.policies (experiment=published runs at the scale")


def test_a_studys_policy_family_applies_unless_the_command_line_or_the_entry_chooses(compose_config):
    from taskcomplexity.config import plain
    from taskcomplexity.study.compose import _entry_overrides, entry_base, entry_config, study_family
    from taskcomplexity.study_data import study_from_config

    study = study_from_config({"name": "s", "network": "pic_h2_64", "prior": "normal",
                               "tasks": [{"task": "cartpole"}, {"task": "pendulum", "network": "pic_h1_4"}]})
    base = entry_base(plain(compose_config("study=classic_control")))
    family = study_family(study, [])
    assert family == {"network": "pic_h2_64", "prior": "normal"}
    node = entry_config(base, study.tasks[0], [], "study.tasks[0]", family)
    assert list(node.network.hidden) == [64, 64] and node.network.activation == "tanh"
    assert list(entry_config(base, study.tasks[1], [], "study.tasks[1]", family).network.hidden) == [4]
    # the command line's network= wins over the study's; a key override applies on top of the study's family
    assert study_family(study, ["network=pic_h1_32"]) == {"prior": "normal"}
    assert _entry_overrides(study.tasks[0], ["network.hidden=[8]"], "study.tasks[0]", family) == [
        "network.hidden=[8]", "network=pic_h2_64", "prior=normal", "task=cartpole"]
    node = entry_config(base, study.tasks[0], ["network.hidden=[8]"], "study.tasks[0]", family)
    assert list(node.network.hidden) == [8] and node.network.activation == "tanh"


def test_the_entries_of_a_study_that_choose_alike_compose_once_each_into_a_config_of_its_own(compose_config,
                                                                                           monkeypatch):
    from taskcomplexity.study import compose
    from taskcomplexity.study.plan import study_requests
    from taskcomplexity.study_data import study_from_config

    real, calls = compose._compose, []
    monkeypatch.setattr(compose, "_compose", lambda overrides, where: calls.append(list(overrides))
                        or real(overrides, where))
    study = study_from_config({"name": "s", "tasks": [{"env_id": "CartPole-v1"}, {"env_id": "Acrobot-v1"},
                                                      {"env_id": "Pendulum-v1", "max_steps": 50}]})
    pairs = study_requests(compose_config("experiment=smoke"), study)
    assert calls == [["task=gym"]]  # three gym ids: one composition
    assert [(r.task.env_id, r.task.max_steps) for _, r in pairs] == [("CartPole-v1", 500), ("Acrobot-v1", 500),
                                                                    ("Pendulum-v1", 50)]
    composer = compose.Composer()
    first, second = composer(["task=gym"], "study.tasks[0]"), composer(["task=gym"], "study.tasks[1]")
    first.task.env_id = "Pendulum-v1"  # each caller changes a config of its own
    assert second.task.env_id != "Pendulum-v1"


def test_an_unknown_study_network_is_one_line_naming_the_options(compose_config):
    from taskcomplexity.study.plan import study_requests

    cfg = compose_config("study=classic_control", "study.network=pic_h9_9")
    with pytest.raises(ConfigError, match=r"study\.network=pic_h9_9 is not a known network option \(allowed: "):
        study_requests(cfg)


def test_the_seven_task_study_declares_the_papers_scale(compose_config):
    from taskcomplexity.study.plan import study_from
    from taskcomplexity.study_data import PAPER_SCALE

    assert study_from(compose_config()).published == PAPER_SCALE


@pytest.mark.parametrize(("overrides", "bins"), [
    ((), 100_000),                                  # Furuta et al.'s B, pinned by the study at its N = M = 1000
    (("metrics.bins=5000",), 5000),                 # a typed B is honoured
    (("study.policies=100",), 100 * 1000 // 50),    # off the protocol's N, M: the paper's ratio
])
def test_metrics_bins_auto_resolves_per_study_protocol(compose_config, overrides, bins):
    from taskcomplexity.study.plan import metrics_settings_from_config, study_from

    cfg = compose_config("study=classic_control", *overrides)
    study = study_from(cfg)
    settings = metrics_settings_from_config(cfg, study)
    n = study.policies
    assert settings.at_scale(n, study.episodes).bins == bins


def test_metrics_bins_refuses_anything_but_an_integer_or_auto(compose_config):
    from taskcomplexity.study.plan import metrics_settings_from_config

    for value, shown in (("many", "'many'"), ("1", "1")):
        with pytest.raises(ConfigError, match=rf"metrics\.bins must be an integer >= 2 \(B\) or auto .*got {shown}"):
            metrics_settings_from_config(compose_config(f"metrics.bins={value}"))


def test_the_atlas_study_is_furutas_thirteen_tasks_with_a_score_each_declared_once(compose_config):
    from taskcomplexity.study.plan import study_from

    atlas = study_from(compose_config("study=furuta_benchmark"))
    classic = study_from(compose_config("study=classic_control"))
    assert len(atlas.ids) == 13 and set(classic.ids) < set(atlas.ids)
    assert set(atlas.algorithm_scores) == set(atlas.ids)  # Score(A) is defined for every task
    for task in classic.ids:  # the five classic-control scores come from classic_control's file alone
        assert atlas.algorithm_scores[task] == classic.algorithm_scores[task]
    assert "Ant" not in (CONF_DIR / "study" / "classic_control.yaml").read_text()
    assert (atlas.published.policies, atlas.published.episodes) == (1000, 1000)  # their protocol, as published
    atlas_budget = compose_config("experiment=atlas")
    assert atlas_budget.study.name == "furuta_benchmark" and not atlas_budget.sac.enabled


def test_each_cell_of_the_atlas_bag_reaches_every_task_of_the_study(compose_config, monkeypatch):
    """make atlas-bag's overrides (network, prior, network.input_bias) win over the study's own family, on every task
    (here the five classic-control ones, which need no extra)."""
    import subprocess

    from taskcomplexity.study.plan import study_requests

    recipe = subprocess.run(["make", "-n", "-o", ".venv/.installed", "atlas-bag"], capture_output=True, text=True,
                            cwd=CONF_DIR.parents[2], check=True).stdout
    sweep = re.search(r"experiment=atlas (network=\S+ prior=\S+ network\.input_bias=\S+)", recipe).group(1).split()
    choices = {key: value.split(",") for key, value in (o.split("=", 1) for o in sweep)}
    assert [len(v) for v in choices.values()] == [7, 4, 2]  # 56 cells
    typed = ["study=classic_control", "network=pic_h1_4", "prior=uniform", "network.input_bias=true"]
    monkeypatch.setattr("taskcomplexity.study.plan.user_overrides", lambda: typed)  # as typed on the command line
    cfg = compose_config(*typed)
    for _, request in study_requests(cfg):
        assert request.network.hidden == (4,) and request.network.input_bias and request.prior.kind == "uniform"
