"""Every refusal is one line and exit status 2, before any work: the entry points run as a user runs them (a
subprocess of ``pipelines/<name>.py`` or the installed console script), each with a fresh ``paths.outputs``, and
nothing is computed into it."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import preloaded
from taskcomplexity.extras import install_command

ROOT = Path(__file__).resolve().parents[2]
PIPELINES = ROOT / "pipelines"


def run(script: str, args: list[str], cwd: Path, *, env: dict | None = None) -> subprocess.CompletedProcess:
    """``python pipelines/<script>.py args`` (or the console script ``taskcomplexity-<script>`` when ``script``
    starts with ``taskcomplexity-``) in ``cwd``, without ``HYDRA_FULL_ERROR``."""
    command = ([str(Path(sys.executable).parent / script)] if script.startswith("taskcomplexity-")
               else [sys.executable, str(PIPELINES / f"{script}.py")])
    environment = {k: v for k, v in os.environ.items() if k not in ("HYDRA_FULL_ERROR", "TASKCOMPLEXITY_OUTPUTS")}
    return preloaded.run([*command, *args], cwd=cwd, capture_output=True, text=True, timeout=600,
                         env=environment | (env or {}))


def refusal(done: subprocess.CompletedProcess) -> str:
    """The one line a refused command prints on standard error (after checking there is exactly one, and exit 2)."""
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr[-3000:]
    assert len(lines) == 1, done.stderr[-3000:]
    assert lines[0].startswith("error: ")
    return lines[0]


def artefacts(outputs: Path) -> list[Path]:
    """What a run computed under ``outputs``: every file of the cache (artefacts, partial work, locks), every
    ``.partial-*`` directory, every report."""
    cache = [p for p in (outputs / "cache").rglob("*") if p.is_file() or p.name.startswith(".partial-")]
    return cache + list(outputs.rglob("*.parquet")) + list(outputs.rglob("*.npz")) + list(outputs.glob("reports/*"))


# one bad value per entry point, each read late: accepted, it would let a stage compute before it is refused
LATE = {
    "rwg": ["rwg.policies=1000000", "rwg.chunk_policies=1000000"],
    "metrics": ["experiment=smoke", "metrics.bins=1e15"],
    "sac": ["task=pendulum", "sac.total_steps=1000", "sac.hidden_sizes=[1000000,1000000]"],
    "verdict": ["experiment=smoke", "sac.enabled=true", "sac.hidden_sizes=[1000000,1000000]"],
    "study": ["experiment=smoke", "tag=../../../x"],
    "cost": ["experiment=smoke", "rwg.policies=1e99"],
}


def test_every_pipeline_refuses_a_bad_value_in_one_line_before_it_computes_anything(tmp_path):
    assert sorted(LATE) == sorted(p.stem for p in PIPELINES.glob("*.py")), "a pipeline without its probe"
    for script, args in LATE.items():
        outputs = tmp_path / script / "outputs"
        done = run(script, [*args, f"paths.outputs={outputs}"], tmp_path)
        refusal(done)
        assert artefacts(outputs) == [], (script, artefacts(outputs))
    assert not (tmp_path / "x").exists()


def test_a_tag_that_is_not_a_plain_name_is_refused_so_no_report_leaves_the_outputs(tmp_path):
    outputs = tmp_path / "a" / "b" / "outputs"
    done = run("study", ["experiment=smoke", "tag=../../../x", f"paths.outputs={outputs}"], tmp_path)
    assert refusal(done) == ("error: tag must be a plain name of letters, digits, '_', '.', '-' that does not start "
                             "with '.' (it names a directory under paths.outputs), got '../../../x'")
    assert not list(tmp_path.rglob("*.parquet")) and not list(tmp_path.rglob("index.html"))


def test_an_unknown_config_name_is_one_line_naming_the_configs_allowed(tmp_path):
    for args, typed in ((["--config-name=nosuch"], "--config-name=nosuch"), (["-cn", "nosuch"], "-cn=nosuch")):
        done = run("study", [*args, f"paths.outputs={tmp_path / 'out'}"], tmp_path)
        assert refusal(done) == f"error: {typed} is not a config (allowed: config)"
    assert not (tmp_path / "out").exists()


def test_an_explicit_chunk_size_is_held_to_the_machines_memory_in_a_single_stage_and_in_a_study(tmp_path):
    size = r"[\d,.]+ (MB|GB|TB)"
    one = run("rwg", ["rwg.policies=1000000", "rwg.chunk_policies=1000000", f"paths.outputs={tmp_path / 'one'}"],
              tmp_path)
    assert re.fullmatch(rf"error: rwg\.chunk_policies=1000000 \(1,000,000 policies × 100 episodes stepped at once on "
                        rf"the batched backend\) needs about {size} of memory, this machine has [\d.]+ GB \(lower it, "
                        r"or 0: chunks sized from rwg\.chunk_memory_mb\)", refusal(one))
    # the study checks every task's chunk when it reads its plan, before the first task's returns
    study = run("study", ["experiment=smoke", "rwg.policies=100000", "rwg.episodes=1000", "rwg.chunk_policies=100000",
                          f"paths.outputs={tmp_path / 'study'}"], tmp_path)
    assert re.fullmatch(rf"error: rwg\.chunk_policies=100000 \(100,000 policies × 1,000 episodes stepped at once on "
                        rf"the batched backend\) needs about {size} of memory, .*", refusal(study))
    assert artefacts(tmp_path / "one" / "outputs") == artefacts(tmp_path / "study") == []


def test_sac_networks_beyond_the_machines_memory_are_refused_before_anything_is_allocated(tmp_path):
    outputs = tmp_path / "out"
    done = run("sac", ["task=pendulum", "sac.total_steps=1000", "sac.hidden_sizes=[1000000,1000000]",
                       f"paths.outputs={outputs}"], tmp_path)
    assert re.fullmatch(r"error: sac\.hidden_sizes=\[1000000, 1000000\] \(3,000,021,000,004 parameters per seed × 5 "
                        r"seeds on task Pendulum-v1\) needs about [\d,.]+ TB of memory, this machine has [\d.]+ GB "
                        r"\(lower it\)", refusal(done))
    assert not list(outputs.rglob(".partial-*")) and artefacts(outputs) == []


def test_sac_refuses_a_run_whose_checkpoints_do_not_fit_on_the_disk_before_training(tmp_path, tmpfs):
    with tmpfs(tmp_path / "disk", "3m") as disk:
        outputs = disk / "outputs"  # the checkpoints of 5 seeds of a (256, 256) SAC hold about 15 MB each
        done = run("sac", ["task=pendulum", "sac.total_steps=1000", f"paths.outputs={outputs}"], tmp_path)
        assert re.fullmatch(rf"error: sac\.hidden_sizes=\[256, 256\] \([\d,]+ parameters per seed × 5 seeds on task "
                            rf"Pendulum-v1\) needs about [\d.]+ MB of disk under {re.escape(str(outputs / 'cache'))}, "
                            r"[\d.]+ (KB|MB) are free", refusal(done))
        assert artefacts(outputs) == []


def test_metrics_settings_are_checked_before_the_returns_are_computed(tmp_path):
    outputs = tmp_path / "out"
    done = run("metrics", ["experiment=smoke", "metrics.bins=1e15", f"paths.outputs={outputs}"], tmp_path)
    assert re.fullmatch(r"error: metrics\.bins = 1,000,000,000,000,000 needs about [\d,.]+ TB of memory, this machine "
                        r"has [\d.]+ GB \(lower it; metrics\.bins=auto gives B = 2 at N = 10, M = 4\)", refusal(done))
    assert artefacts(outputs) == []


@pytest.mark.parametrize(("args", "where"), [
    (["task=pendulum"], "task Pendulum-v1 runs on kernel"),
    (["experiment=smoke", "sac.enabled=false"], "study seven_tasks runs on batched"),
])
def test_rwg_workers_where_no_backend_runs_workers_is_refused_before_any_work(tmp_path, args, where):
    """rwg.workers sets the processes of the backends that step Python environments: on a task or a study whose
    backends run in one process it would change nothing, so it is refused (every override reaches the computation
    or is refused)."""
    outputs = tmp_path / "out"
    script = "rwg" if args[0].startswith("task=") else "study"
    done = run(script, [*args, "rwg.workers=2", "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={outputs}"],
               tmp_path)
    assert re.fullmatch(rf"error: rwg\.workers=2 sets the processes that step Python environments on backend [a-z ]+; "
                        rf"{where}, in one process \(allowed: 0\)", refusal(done)), refusal(done)
    assert artefacts(outputs) == []


def test_a_float_beyond_exact_integers_is_no_integer_setting(tmp_path):
    done = run("rwg", ["rwg.policies=1e99", f"paths.outputs={tmp_path / 'out'}"], tmp_path)
    assert refusal(done) == ("error: rwg.policies must be an integer, got 1e+99 (1e+99 is beyond 2**53, where a "
                             "number with an exponent is no exact integer)")


def test_a_whole_float_within_exact_integers_still_reads_as_the_integer():
    from taskcomplexity.config import build
    from taskcomplexity.rwg.settings import RWGSettings

    assert build(RWGSettings, {"policies": 1e6, "episodes": 2.0}, "rwg").policies == 1_000_000
    with pytest.raises(Exception, match=r"rwg\.policies must be an integer, got 2\.5$"):
        build(RWGSettings, {"policies": 2.5}, "rwg")


@pytest.mark.parametrize(("args", "line"), [
    (["task=cartpole", "task.kwargs.bogus=1"],
     "error: task.kwargs.bogus: CartPole-v1 takes no such keyword argument (allowed: render_mode, sutton_barto_reward)"),
    (["task=cartpole", "+task.kwargs.bogus=1"],
     "error: task.kwargs.bogus=1: CartPole-v1 takes no such keyword argument (allowed: render_mode, "
     "sutton_barto_reward)"),
    (["task=pendulum", "task.kwargs.g=3"],
     "error: task.kwargs.g: a keyword argument of Pendulum-v1 is added to task.kwargs with '+': "
     "+task.kwargs.g=<value>"),
    (["task.kwargs.bogus=1"],
     "error: task.kwargs.bogus: task=reaching takes no keyword arguments (task.kwargs is a gymnasium task's: task=gym "
     "task.env_id=<id> +task.kwargs.<name>=<value>; an arm's settings are arm.*, reward.*)"),
])
def test_a_keyword_argument_the_task_does_not_take_names_those_it_takes(tmp_path, args, line):
    done = run("rwg", [*args, "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={tmp_path / 'out'}"], tmp_path)
    assert refusal(done) == line


def own_study(tmp_path: Path, text: str) -> list[str]:
    (tmp_path / "conf" / "study").mkdir(parents=True)
    (tmp_path / "conf" / "study" / "mine.yaml").write_text(textwrap.dedent(text))
    return ["study=mine", f"hydra.searchpath=[file://{tmp_path / 'conf'}]", f"paths.outputs={tmp_path / 'out'}"]


def test_a_study_entry_naming_a_missing_preset_is_one_line_naming_the_study_and_the_presets(tmp_path):
    from taskcomplexity.cli import CONF_DIR

    args = own_study(tmp_path, """\
        name: mine
        tasks: [{task: cartpole}, {task: cartpol}]
        relations: []
        """)
    presets = ", ".join(sorted(p.stem for p in (CONF_DIR / "task").glob("*.yaml")))
    assert refusal(run("study", args, tmp_path)) == (
        f"error: study mine: study.tasks[1] (cartpol) names task=cartpol, which is not a task preset (allowed: "
        f"{presets})")
    assert artefacts(tmp_path / "out") == []


def test_a_relation_without_its_kind_is_refused_in_one_line(tmp_path):
    args = own_study(tmp_path, """\
        name: mine
        tasks: [{task: cartpole}, {task: pendulum}]
        relations:
          - {easier: cartpole, harder: pendulum}
        """)
    assert refusal(run("study", [*args, "experiment=smoke"], tmp_path)) == (
        "error: study.relations[0].kind must say why the relation is known (a non-empty string, e.g. reward or "
        "degrees_of_freedom: the verdict's tables group relations by it), got None")
    assert artefacts(tmp_path / "out") == []


@pytest.mark.parametrize("missing", ["mujoco", "imageio"])
def test_the_installed_command_with_a_mujoco_task_and_no_mujoco_extra_is_one_line_with_the_pip_command(
        tmp_path, missing):
    """The mujoco extra is MuJoCo and gymnasium's renderer (imageio): either one missing is simulated by a
    ``sitecustomize`` that makes its import fail."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(f"import sys\nsys.modules[{missing!r}] = None\n")
    done = run("taskcomplexity-rwg", ["task=half_cheetah", "rwg.policies=2", "rwg.episodes=2",
                                      f"paths.outputs={tmp_path / 'out'}"], tmp_path, env={"PYTHONPATH": str(site)})
    # the first module the import misses is named unless it is MuJoCo itself (on a machine without the extra, CI's,
    # that is MuJoCo whichever one the sitecustomize removes)
    first = missing if importlib.util.find_spec("mujoco") is not None else "mujoco"
    why = "" if first == "mujoco" else f" (no module {first})"
    assert refusal(done) == (f"error: task.env_id=HalfCheetah-v5 needs MuJoCo, which is not installed{why}: "
                             f"{install_command('mujoco')}")


class _Distribution:
    def __init__(self, direct_url: dict | None):
        self.direct_url = direct_url

    def read_text(self, name: str) -> str | None:
        return json.dumps(self.direct_url) if name == "direct_url.json" and self.direct_url is not None else None


@pytest.mark.parametrize(("direct_url", "command"), [
    ({"url": "file:///home/me/taskcomplexity", "dir_info": {"editable": True}}, "pip install -e '.[mujoco]'"),
    ({"url": "file:///tmp/my%20clone", "dir_info": {}}, "pip install '/tmp/my clone[mujoco]'"),
    (None, "pip install 'taskcomplexity[mujoco]'"),
])
def test_the_pip_command_of_an_extra_is_the_one_for_how_the_package_was_installed(monkeypatch, direct_url, command):
    from taskcomplexity import extras

    monkeypatch.setattr(extras.metadata, "distribution", lambda name: _Distribution(direct_url))
    assert extras.install_command("mujoco") == command
