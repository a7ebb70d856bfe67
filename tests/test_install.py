"""The package installed (not editable) into a fresh venv runs its entry points from a directory outside
the repository: the configs ship as package data, and the console scripts find them.

The fresh venv has no copy of the dependencies: a ``.pth`` line puts this interpreter's site-packages
(torch, numba, PyBullet, …) on its path, so nothing is downloaded. A plain path line does not run the
``.pth`` files found there, so the editable install of the checkout stays out of the fresh venv; a test
checks that ``taskcomplexity`` is imported from the venv. The build is from a copy of the working tree's
``pyproject.toml``, ``README.md`` and ``src/`` (what a fresh clone holds), so the repository is not written.

Measured on the 2-core development machine: the CI tests take 20 s of CPU (the install 5 s, the refused
override 3 s, the RWG run 6 s) and 42 s of wall time with both cores busy. The studies are ``slow``:
every numba kernel they reach compiles cold in a fresh install (the metrics stage alone 20–40 s), so the
study of two gym tasks takes 50–110 s and the seven-task smoke study 60–200 s, depending on the load.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.study_data import load_study_file

ROOT = Path(__file__).resolve().parents[1]
SEVEN_IDS = sorted(task.id for task in load_study_file(CONF_DIR / "study" / "seven_tasks.yaml").tasks)
SCRIPTS = ("taskcomplexity-rwg", "taskcomplexity-metrics", "taskcomplexity-sac", "taskcomplexity-verdict",
           "taskcomplexity-study")

PRESET = textwrap.dedent("""
    # a researcher's own preset on the search path, over a packaged one
    defaults:
      - pendulum
      - _self_
    max_steps: 20
""")

STUDY = textwrap.dedent("""
    name: mine
    tasks:
      - {id: cart, task: cartpole, label: "CartPole"}
      - {id: pend, task: pendulum, label: "Pendulum"}
    relations:
      - {easier: cart, harder: pend, kind: swing-up}
""")


def _environment() -> dict[str, str]:
    """This process's environment without what would point the run back at the checkout or its outputs."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "TASKCOMPLEXITY_OUTPUTS", "HYDRA_FULL_ERROR")}
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return env


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    """A fresh venv with the package installed from a copy of the working tree (``pip install --no-deps .``)."""
    root = tmp_path_factory.mktemp("install")
    clone = root / "clone"
    clone.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, clone / name)
    shutil.copytree(ROOT / "src", clone / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "*.nbi", "*.nbc"))
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--no-deps", "--ignore-installed", "--no-build-isolation",
         "--no-index", "--no-cache-dir", str(clone)],
        capture_output=True, text=True, env=_environment(), timeout=600)
    assert install.returncode == 0, install.stderr[-3000:]
    return venv


@pytest.fixture
def workdir(tmp_path) -> Path:
    """An empty directory outside the repository to run in."""
    work = tmp_path / "work"
    work.mkdir()
    assert not work.resolve().is_relative_to(ROOT.resolve())
    return work


def _run(venv: Path, workdir: Path, *args: str, timeout: int = 600) -> subprocess.CompletedProcess:
    command = [str(venv / "bin" / args[0]), *args[1:]]
    return subprocess.run(command, capture_output=True, text=True, cwd=workdir, env=_environment(), timeout=timeout)


def test_the_installed_package_holds_its_configs_and_commands(venv, workdir):
    assert all((venv / "bin" / name).is_file() for name in SCRIPTS)
    probe = ("import sys, taskcomplexity, taskcomplexity.cli as cli; "
             f"print(taskcomplexity.__file__); print(cli.CONF_DIR); print({str(ROOT / 'src')!r} in sys.path)")
    result = _run(venv, workdir, "python", "-c", probe)
    assert result.returncode == 0, result.stderr[-2000:]
    module, conf, checkout_on_path = result.stdout.split()
    assert Path(module).is_relative_to(venv) and Path(conf).is_relative_to(venv)  # not the checkout's src/
    assert checkout_on_path == "False"
    installed = Path(conf)
    assert (installed / "config.yaml").is_file()
    for group in ("arm", "reward", "task", "study", "experiment", "sac", "hydra/launcher"):
        assert sorted(p.name for p in (installed / group).glob("*.yaml")) == sorted(
            p.name for p in (ROOT / "src" / "taskcomplexity" / "conf" / group).glob("*.yaml")), group


def test_the_installed_package_renders_the_report_page_from_its_templates(venv, workdir):
    probe = ("import taskcomplexity.report.html as page; "
             "print(page.render_html(page.Document('A & B', 'sub', ('Lead.',), (), (('N', '10'),))))")
    result = _run(venv, workdir, "python", "-c", probe)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "<title>A &amp; B</title>" in result.stdout and "<dt>N</dt><dd>10</dd>" in result.stdout
    module = _run(venv, workdir, "python", "-c", "import taskcomplexity; print(taskcomplexity.__file__)").stdout
    installed = Path(module.strip()).parent / "report" / "templates"
    assert sorted(p.name for p in installed.glob("*.j2")) == sorted(
        p.name for p in (ROOT / "src" / "taskcomplexity" / "report" / "templates").glob("*.j2"))


def test_an_unknown_option_is_refused_in_one_line_by_the_installed_command(venv, workdir):
    result = _run(venv, workdir, "taskcomplexity-rwg", "arm=three_link", timeout=120)
    assert result.returncode == 2
    arms = ", ".join(sorted(p.stem for p in (ROOT / "src" / "taskcomplexity" / "conf" / "arm").glob("*.yaml")))
    assert result.stderr.strip().splitlines() == [f"error: arm=three_link is not a known option (allowed: {arms})"]
    assert not any((workdir / "outputs").rglob("*"))  # nothing ran (the writability probe leaves an empty outputs/)


def test_the_installed_rwg_command_runs_a_preset_of_ones_own_from_any_directory(venv, workdir, tmp_path):
    """A task preset on the user's search path over a packaged preset (pendulum), tiny N × M, the gym backend."""
    lab = tmp_path / "lab"
    (lab / "task").mkdir(parents=True)
    (lab / "task" / "short_pendulum.yaml").write_text(PRESET)
    result = _run(venv, workdir, "taskcomplexity-rwg", f"hydra.searchpath=[file://{lab}]", "task=short_pendulum",
                  "rwg.policies=4", "rwg.episodes=2", "backend=gym", timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    outputs = workdir / "outputs"  # the default paths.outputs, under the directory the command ran in
    (returns,) = outputs.glob("cache/rwg/*/returns.parquet")
    table = pd.read_parquet(returns)
    assert len(table) == 4 * 2 and (table["steps"] == 20).all()  # Pendulum-v1 runs to the preset's max_steps
    (log,) = outputs.glob("runs/*/*/rwg.log")
    assert "computed returns Pendulum-v1" in log.read_text()


@pytest.mark.slow
def test_the_installed_study_command_runs_a_study_of_ones_own_from_any_directory(venv, workdir, tmp_path):
    """Packaged task presets (cartpole, pendulum), a study file on the user's search path, every stage but SAC."""
    studies = tmp_path / "studies"
    (studies / "study").mkdir(parents=True)
    (studies / "study" / "mine.yaml").write_text(STUDY)
    result = _run(venv, workdir, "taskcomplexity-study", f"hydra.searchpath=[file://{studies}]", "study=mine",
                  "experiment=smoke", "sac.enabled=false", "backend=gym")
    assert result.returncode == 0, result.stderr[-3000:]
    outputs = workdir / "outputs"
    returns = sorted(outputs.glob("cache/rwg/*/returns.parquet"))
    assert len(returns) == 2
    assert all(len(pd.read_parquet(path)) == 10 * 4 for path in returns)  # experiment=smoke: N = 10 × M = 4
    assert len(list(outputs.glob("cache/metrics/*/metrics.parquet"))) == 2
    (verdict,) = outputs.glob("cache/verdict/*/verdict.parquet")
    assert not pd.read_parquet(verdict).empty
    (report,) = (path.parent for path in outputs.glob("reports/mine-smoke/*/run.json"))
    assert (report / "index.html").is_file() and (report / "report.md").is_file()
    assert f"Report: {report / 'index.html'}" in result.stdout
    assert (outputs / "reports" / "mine-smoke" / "index.html").is_file()  # the stable link to the latest
    (config,) = outputs.glob("runs/*/*/.hydra/config.yaml")
    assert "name: mine" in config.read_text()


@pytest.mark.slow
def test_the_installed_study_command_runs_the_seven_task_smoke_study(venv, workdir):
    result = _run(venv, workdir, "taskcomplexity-study", "experiment=smoke", "sac.enabled=false")
    assert result.returncode == 0, result.stderr[-3000:]
    outputs = workdir / "outputs"
    samples = [json.loads(path.read_text()) for path in outputs.glob("cache/rwg/*/manifest.json")]
    families = sorted((m["config"]["network"].get("family", "mlp"), m["label"].split()[0]) for m in samples)
    # each task's MLP sample and its movement-primitive family's (the primitives stage's RWG)
    assert families == sorted((family, task) for family in ("dmp", "mlp") for task in SEVEN_IDS)
    assert len(list(outputs.glob("cache/metrics/*/metrics.parquet"))) == 7
    assert (outputs / "reports" / "seven_tasks-smoke" / "index.html").is_file()
