"""A command that does no work starts light: a refused command and ``--help`` import none of the heavy libraries
(what they import is read from ``python -X importtime``, never a clock: CI does not gate on wall time; ``make bench``
times them, bench/bench_startup.py). ``--help`` is Hydra's own help, and Hydra's composition errors are one line."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from taskcomplexity.cli import CONF_DIR, one_composition

ROOT = Path(__file__).resolve().parents[2]
PIPELINES = ROOT / "pipelines"
HEAVY = ("torch", "torchrl", "tensordict", "seaborn", "matplotlib", "scipy", "pandas", "pyarrow", "numba", "llvmlite",
         "gymnasium", "pybullet", "sklearn", "envpool", "mujoco", "metaworld", "ot")
"""Libraries a command that does no work must not import (each costs from 50 ms to seconds of start-up)."""
IMPORTED = re.compile(r"^import time:\s+\d+ \|\s+\d+ \|\s*(\S+)$", re.MULTILINE)


def run(args: list[str], cwd: Path, *, env: dict | None = None) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if k not in ("HYDRA_FULL_ERROR", "TASKCOMPLEXITY_OUTPUTS")}
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env=environment | (env or {}))


def imported(done: subprocess.CompletedProcess) -> set[str]:
    """The top-level packages a ``-X importtime`` run imported."""
    return {name.split(".")[0] for name in IMPORTED.findall(done.stderr)}


def messages(done: subprocess.CompletedProcess) -> list[str]:
    """Standard error without the ``-X importtime`` lines."""
    return [line for line in done.stderr.splitlines() if line.strip() and not line.startswith("import time:")]


@pytest.mark.parametrize(("script", "args", "line"), [
    ("study", ["rwg.policies=-1"], "error: rwg.policies must be an integer >= 2 (N), got -1"),
    ("rwg", ["rwg.policies=-1"], "error: rwg.policies must be an integer >= 2 (N), got -1"),
    ("metrics", ["metrics.bins=1"], "error: metrics.bins must be an integer >= 2 (B) or auto (N·M / 50, or the "
                                    "study's pinned B at its published N and M), got 1"),
    ("sac", ["sac.actor_lr=-1"], "error: sac.actor_lr must be a finite number > 0, got -1.0"),
    ("verdict", ["diagnostics.repeats=1"], "error: diagnostics.repeats must be an integer >= 2, got 1"),
    ("cost", ["rwg.episodes=1"], "error: rwg.episodes must be an integer >= 2 (M), got 1"),
    ("study", ["rwg.polices=3"], "error: rwg.polices is not a known key (allowed: chunk_memory_mb, chunk_policies, "
                                 "common_initial_states, contacts, entry, episodes, policies, precision, seed, shard, "
                                 "shards, workers)"),
])
def test_a_refused_command_imports_none_of_the_heavy_libraries(tmp_path, script, args, line):
    done = run(["-X", "importtime", str(PIPELINES / f"{script}.py"), *args, f"paths.outputs={tmp_path / 'out'}"],
               tmp_path)
    assert done.returncode == 2 and messages(done) == [line], done.stderr[-2000:]
    loaded = imported(done)
    assert {"hydra", "omegaconf", "taskcomplexity"} <= loaded  # the run was read, composed and refused
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_help_imports_none_of_the_heavy_libraries_and_is_hydras_own_help(tmp_path):
    fast = run(["-X", "importtime", str(PIPELINES / "study.py"), "--help"], tmp_path)
    assert fast.returncode == 0 and not messages(fast), fast.stderr[-2000:]
    assert not imported(fast) & set(HEAVY), sorted(imported(fast) & set(HEAVY))
    # Hydra's app itself, as the entry point runs it after its checks, answers the same
    hydra = run(["-c", "import sys; from taskcomplexity.commands.study import main; "
                       "sys.argv = ['study.py', *sys.argv[1:]]; main.hydra_app()", "--help"], tmp_path)
    assert hydra.returncode == 0 and fast.stdout == hydra.stdout
    assert fast.stdout.startswith("study is powered by Hydra.\n\n== Configuration groups ==\n")
    assert "\nstudy: ablation, cartpole_noise, classic_control, " in fast.stdout


def test_help_with_overrides_and_a_search_path_is_hydras_help_of_that_config(tmp_path):
    (tmp_path / "conf" / "study").mkdir(parents=True)
    (tmp_path / "conf" / "study" / "mine.yaml").write_text("name: mine\ntasks: [{task: cartpole}]\nrelations: []\n")
    args = ["--help", "study=mine", "rwg.policies=7", f"hydra.searchpath=[file://{tmp_path / 'conf'}]", "--resolve"]
    fast = run([str(PIPELINES / "rwg.py"), *args], tmp_path)
    hydra = run(["-c", "import sys; from taskcomplexity.commands.rwg import main; "
                       "sys.argv = ['rwg.py', *sys.argv[1:]]; main.hydra_app()", *args], tmp_path)
    assert fast.returncode == hydra.returncode == 0 and fast.stdout == hydra.stdout
    assert fast.stdout.startswith("rwg is powered by Hydra.") and "  policies: 7\n" in fast.stdout
    assert "\n  name: mine\n" in fast.stdout  # the search path's study composed (Hydra lists the groups it started with)


def test_help_with_an_unknown_key_is_one_line(tmp_path):
    done = run([str(PIPELINES / "study.py"), "--help", "rwg.polices=3"], tmp_path)
    assert done.returncode == 2 and done.stderr.splitlines()[0].startswith("error: rwg.polices is not a known key")
    assert len(done.stderr.splitlines()) == 1


def test_a_composition_error_keeps_its_traceback_with_hydra_full_error_and_a_bug_in_the_task_keeps_hydras_report(
        tmp_path):
    args = [str(PIPELINES / "rwg.py"), "rwg.polices=3", f"paths.outputs={tmp_path / 'out'}"]
    full = run(args, tmp_path, env={"HYDRA_FULL_ERROR": "1"})
    assert full.returncode == 1 and "Traceback" in full.stderr and "rwg.polices" in full.stderr
    # the task's own bug: Hydra's report, which names HYDRA_FULL_ERROR (the variable was given back to the task)
    bug = run(["-c", "import runpy, sys; import taskcomplexity.stages.rwg_stage as stage; "
                     "stage.check_plan = lambda cache, request: [][1]; "
                     f"sys.argv = [{str(PIPELINES / 'rwg.py')!r}, *sys.argv[1:]]; "
                     f"runpy.run_path({str(PIPELINES / 'rwg.py')!r}, run_name='__main__')",
               "task=cartpole", "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={tmp_path / 'bug'}"], tmp_path)
    assert bug.returncode == 1 and "IndexError: list index out of range" in bug.stderr
    assert "Set the environment variable HYDRA_FULL_ERROR=1 for a complete stack trace" in bug.stderr


def test_importing_the_package_imports_no_heavy_library_and_registers_its_ids_once_gymnasium_is_imported(tmp_path):
    code = ("import sys, taskcomplexity; heavy = [m for m in sys.argv[1:] if m in sys.modules]; "
            "import gymnasium; print(heavy, 'taskcomplexity/TwoLink-Sparse-v0' in gymnasium.registry, "
            "'taskcomplexity/NoisyCartPole-v0' in gymnasium.registry, type(gymnasium.__loader__).__name__)")
    done = run(["-c", code, *HEAVY], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["[]", "True", "True", "SourceFileLoader"]
    first = run(["-c", "import gymnasium, taskcomplexity; print('taskcomplexity/TwoLink-Dense-v0' in gymnasium.registry)"],
                tmp_path)
    assert first.stdout.strip() == "True"


def test_compilations_are_announced_when_numba_is_imported_inside_the_block(tmp_path):
    code = """
import sys
from taskcomplexity.commands.compilation import announce_compilation
lines = []
with announce_compilation(lines.append, sets=(("lab", "lab"),), settle=600) as compiled:
    assert "numba" not in sys.modules
    import numba

    def twice(x):
        return 2 * x
    twice.__module__ = "lab.kernels"
    assert numba.njit(twice)(3) == 6
print(compiled.kernels, lines[0].split(":")[0], lines[1].split(" in ")[0])
"""
    done = run(["-c", code], tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split("\n")[0] == "1 compiling the lab kernels compiled the lab kernels"


def test_the_settings_name_the_kernels_contact_modes_and_precisions():
    """rwg.contacts and rwg.precision are read without the kernels, which hold the same names."""
    from taskcomplexity.rwg.settings import CONTACTS, PRECISIONS
    from taskcomplexity.tasks.dynamics import CONTACT_MODES
    from taskcomplexity.tasks.rollout_kernel import PRECISIONS as KERNEL_PRECISIONS

    assert CONTACTS == tuple(CONTACT_MODES) and PRECISIONS == tuple(KERNEL_PRECISIONS)


def _options(group: str) -> list[str]:
    return sorted(path.stem for path in (CONF_DIR / group).glob("*.yaml"))


@pytest.mark.parametrize("override", [f"experiment={name}" for name in _options("experiment")]
                         + [f"hydra/launcher={name}" for name in _options("hydra/launcher")])
def test_no_packaged_config_sets_hydras_mode_so_reading_it_composes_nothing(override):
    # one_composition tells Hydra that nothing sets hydra.mode instead of composing the config to read it: true of
    # every experiment and launcher, as Hydra's own reading finds
    from hydra import initialize_config_dir
    from hydra._internal.hydra import Hydra
    from hydra.core.global_hydra import GlobalHydra

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        hydra = Hydra(task_name="study", config_loader=GlobalHydra.instance().config_loader())
        assert hydra.get_mode(config_name="config", overrides=[override]) is None


@pytest.mark.parametrize(("argv", "reads"), [
    (["study.py", "rwg.policies=-1"], False),
    (["study.py", "-m", "study.policies=10,20"], False),
    (["study.py", "hydra.mode=MULTIRUN"], True),
    (["study.py", "--config-dir", "mine", "study=own"], True),
    (["study.py", "-cp", "/home/me/conf", "study=own"], True),
    (["study.py", "hydra.searchpath=[file://mine]", "study=own"], True),
])
def test_hydra_reads_the_mode_itself_only_where_a_config_of_the_users_or_an_override_may_set_it(argv, reads):
    from hydra._internal.hydra import Hydra

    own = Hydra.get_mode
    with one_composition(argv):
        assert (Hydra.get_mode is own) == reads
    assert Hydra.get_mode is own


def test_a_command_composes_its_config_once(tmp_path):
    script = ("import sys; from hydra._internal.hydra import Hydra; calls = []; compose = Hydra.compose_config\n"
              "def counted(self, *a, **k):\n    calls.append(1); return compose(self, *a, **k)\n"
              "Hydra.compose_config = counted\n"
              "import atexit; atexit.register(lambda: print('compositions', len(calls), file=sys.stderr))\n"
              "from taskcomplexity.commands.study import main; sys.argv = ['study.py', 'rwg.policies=-1']; main()")
    done = run(["-c", script], tmp_path, env={"TASKCOMPLEXITY_OUTPUTS": str(tmp_path)})
    assert done.returncode == 2 and "error: rwg.policies must be an integer >= 2 (N), got -1" in done.stderr
    assert "compositions 1" in done.stderr
