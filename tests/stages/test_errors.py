"""Errors keep their cause: bad input is one line and exit 2; a bug is a traceback and exit 1."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import preloaded

ROOT = Path(__file__).resolve().parents[2]

# Runs pipelines/rwg.py as `python pipelines/rwg.py …` would, after injecting a NumPy shape bug into the
# RWG stage's table writer (a genuine bug, not bad input).
INJECTED = textwrap.dedent("""
    import runpy, sys
    import numpy as np
    import taskcomplexity.stages.rwg_stage as stage

    def broken(chunk):
        return np.ones(3) + np.ones(4)

    stage.returns_frame = broken
    sys.argv = [{script!r}, *sys.argv[1:]]
    runpy.run_path({script!r}, run_name="__main__")
""")


def run(args: list[str], tmp_path: Path, *, code: str | None = None, env: dict | None = None):
    script = str(ROOT / "pipelines" / "rwg.py")
    command = [sys.executable, "-c", code.format(script=script), *args] if code else [sys.executable, script, *args]
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"} | (env or {})
    return preloaded.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=environment)


def test_a_shape_bug_in_a_stage_keeps_its_traceback_and_exits_1(tmp_path):
    done = run(["task=cartpole", "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={tmp_path}"], tmp_path,
               code=INJECTED)
    assert done.returncode == 1
    assert "Traceback" in done.stderr and "operands could not be broadcast together" in done.stderr
    assert "error: operands" not in done.stderr


def test_bad_input_is_one_line_and_exit_2_unless_hydra_full_error_asks_for_the_traceback(tmp_path):
    args = ["task=gym", "task.env_id=Pendulm-v1", f"paths.outputs={tmp_path}"]
    short = run(args, tmp_path)
    assert short.returncode == 2
    lines = [line for line in short.stderr.splitlines() if line.strip()]
    assert lines == [lines[0]] and lines[0].startswith("error: task.env_id=Pendulm-v1 is not a registered")
    full = run(args, tmp_path, env={"HYDRA_FULL_ERROR": "1"})
    assert full.returncode == 1 and "Traceback" in full.stderr and "ConfigError" in full.stderr


def test_unknown_keys_and_additions_no_stage_reads_are_one_line_exit_2(tmp_path):
    cases = {
        "rwg.polices=10": "error: rwg.polices is not a known key (allowed: chunk_memory_mb, chunk_policies, common_initial_states, "
                          "contacts, entry, episodes, policies, precision, seed, shard, shards, workers)",
        "+foo=1": "error: +foo=1: foo is not a key any stage reads ('+' adds keys only to task.kwargs, "
                  "study.reference, study.algorithm_scores, study.orders; remove it or check its spelling)",
        # a free-form study node accepts new keys, but the RWG stage of one task reads no study
        "+study.algorithm_scores.Hopper-v4={max:1,average:0}": "error: +study.algorithm_scores.Hopper-v4="
            "{max:1,average:0} is not read by the RWG stage of one task (pipelines/study.py reads it)",
        "metrics.bins=10": "error: metrics.bins=10 is not read by the RWG stage of one task (pipelines/study.py "
                           "reads it)",
        "arm.links.0.mas=3": "error: arm.links[0].mas is not a known key (allowed: com, joint_damping, length, mass)",
    }
    for override, message in cases.items():
        done = run([override, f"paths.outputs={tmp_path}"], tmp_path)
        assert done.returncode == 2, override
        assert done.stderr.strip().splitlines() == [message]
    assert not (tmp_path / "cache").exists()


def test_unwritable_output_and_cache_paths_are_one_line_however_given(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    by_env = run(["experiment=smoke"], tmp_path, env={"TASKCOMPLEXITY_OUTPUTS": str(blocker / "out")})
    assert by_env.returncode == 2
    assert by_env.stderr.strip().splitlines() == [f"error: paths.outputs: cannot write to {blocker / 'out'} "
                                                  "(Not a directory)"]
    by_key = run(["experiment=smoke", f"paths.outputs={tmp_path / 'ok'}", f"paths.cache={blocker / 'cache'}"],
                 tmp_path)
    assert by_key.returncode == 2
    assert by_key.stderr.strip().splitlines() == [f"error: paths.cache: cannot write to {blocker / 'cache'} "
                                                  "(Not a directory)"]


def study(args: list[str], tmp_path: Path) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    return preloaded.run([sys.executable, str(ROOT / "pipelines" / "study.py"), *args], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300, env=environment)


def test_an_empty_output_or_cache_path_is_one_line_and_nothing_is_written_at_the_root(tmp_path):
    for key in ("paths.outputs", "paths.cache"):
        done = run(["task=cartpole", "rwg.policies=2", "rwg.episodes=2", f"{key}="], tmp_path)
        assert done.returncode == 2, done.stderr[-2000:]
        assert done.stderr.strip().splitlines() == [
            f"error: {key} is empty (allowed: a directory path; the default is outputs, or $TASKCOMPLEXITY_OUTPUTS)"]
    assert not Path("/cache").exists() and not Path("/runs").exists()


def _own_study(tmp_path: Path, text: str) -> list[str]:
    (tmp_path / "conf" / "study").mkdir(parents=True)
    (tmp_path / "conf" / "study" / "mine.yaml").write_text(textwrap.dedent(text))
    return ["study=mine", f"hydra.searchpath=[file://{tmp_path / 'conf'}]", f"paths.outputs={tmp_path / 'out'}"]


def test_a_study_file_that_is_not_yaml_is_one_line_naming_the_file_line_and_column(tmp_path):
    args = _own_study(tmp_path, """\
        name: mine
        tasks: [{task: cartpole}, {task: pendulum}
        relations:
          - {easier: cartpole, harder: pendulum}
        """)
    done = study(args, tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"error: {tmp_path / 'conf' / 'study' / 'mine.yaml'}, line 3, column 1 is not valid YAML: expected ',' or "
        "']', but got '<scalar>' (while parsing a flow sequence)"]
    assert not (tmp_path / "out" / "cache").exists()


def test_relations_that_go_round_in_a_cycle_are_refused_in_one_line_before_any_work(tmp_path):
    args = _own_study(tmp_path, """\
        name: mine
        tasks: [{task: cartpole}, {task: pendulum}, {task: acrobot}]
        relations:
          - {easier: cartpole, harder: pendulum, kind: a}
          - {easier: pendulum, harder: acrobot, kind: b}
          - {easier: acrobot, harder: cartpole, kind: c}
        """)
    done = study([*args, "experiment=smoke"], tmp_path)
    assert done.returncode == 2, done.stderr[-2000:]
    line = done.stderr.strip().splitlines()
    assert len(line) == 1 and line[0].startswith("error: study.relations contradict each other: ")
    cycle = line[0].split(": ", 2)[2].split(" (")[0].split(" < ")
    assert cycle[0] == cycle[-1] and set(cycle) == {"cartpole", "pendulum", "acrobot"}
    relations = {("cartpole", "pendulum"), ("pendulum", "acrobot"), ("acrobot", "cartpole")}
    assert all(pair in relations for pair in zip(cycle, cycle[1:], strict=False))  # each "<" is a stated relation
    assert not list((tmp_path / "out").rglob("*.parquet"))


def test_the_suggested_command_reruns_in_the_environment_it_ran_in(monkeypatch, tmp_path):
    """A report's "train SAC" command, pasted into a shell, finds what the run found: its PYTHONPATH (a user's env
    module), its interpreter and its search path, quoted for the shell."""
    from taskcomplexity import cli

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(tmp_path / "pipelines" / "study.py")])
    monkeypatch.setattr(sys, "executable", str(tmp_path / ".venv" / "bin" / "python"))
    monkeypatch.setenv("PYTHONPATH", "examples/lab")
    monkeypatch.setattr(cli, "user_overrides", lambda: [
        "hydra.searchpath=[file:///home/me/lab/conf]", "study=reach1d", "experiment=quick", "force=true"])
    assert cli.sac_command() == ("PYTHONPATH=examples/lab .venv/bin/python pipelines/study.py "
                                 "'hydra.searchpath=[file:///home/me/lab/conf]' study=reach1d experiment=quick "
                                 "sac.enabled=true")
    monkeypatch.delenv("PYTHONPATH")
    monkeypatch.setattr(cli, "user_overrides", lambda: ["experiment=published"])
    assert cli.sac_command() == "make paper (.venv/bin/python pipelines/study.py experiment=published sac.enabled=true)"
