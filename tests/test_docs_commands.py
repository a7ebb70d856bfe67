"""Every shell block of the README and the tutorials runs as printed, at a tiny budget, or says why it cannot.

A block (```bash, ```sh or ```console) runs as a new user pastes it: ``bash -euo pipefail``, the repository as
the working directory, a temporary ``$HOME``, the outputs in a temporary ``$TASKCOMPLEXITY_OUTPUTS`` (shared
by the blocks, so that one block's artefacts serve the next), and no virtualenv activated (``.venv/bin`` is
not on ``PATH``, so a bare ``python`` fails). A ``make <target>`` line runs its target's recipe as ``make -n``
prints it. Only the budget changes: :data:`BUDGETS` lists each substitution with its reason, and a
substitution that no block uses fails. A block that cannot run here says so on the line before it,
``<!-- illustrative: <reason> -->``; every other block is run (``test_every_unmarked_block_ran``): here, or
with the slow tests (``make test-all``) when it takes minutes of CPU and CI covers its path elsewhere
(:data:`SLOW`), or with the cluster tests (``make test-cluster``) when it sends jobs to the local SLURM cluster
(:data:`CLUSTER`), or by another test that names its page (:data:`RUN_ELSEWHERE`).

``python tests/test_docs_commands.py`` lists the blocks and what happens to each.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VENV_BIN = ROOT / ".venv" / "bin"
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs" / "tutorials").glob("*.md"))]
SHELLS = ("bash", "sh", "console")
ILLUSTRATIVE = re.compile(r"^<!--\s*illustrative:\s*(?P<reason>\S.*?)\s*-->\s*$")

TINY = "rwg.policies=16 rwg.episodes=4 metrics.bins=1000 metrics.resamples=20"
"""A study's work shrunk to seconds (``experiment=smoke``'s sizes, N divisible by the scale-out's 8 shards)."""

SAC_TINY = ("sac.budget_fraction=0.005 'sac.seeds=[0]' sac.workers=1 sac.warmup_steps=50 sac.eval_every=50 "
            "sac.eval_episodes=1 sac.checkpoint_every=50 occupancy.policies=10 occupancy.episodes=2 "
            "learning_path.policies=10 learning_path.episodes=4")
"""SAC at 0.5 % of each study entry's budget (its ``sac_steps``, still required), one seed, in this process; the
stages that read its actor at ``experiment=smoke``'s sizes."""

BUDGETS: list[tuple[str, str, str]] = [
    # (printed text, what runs instead, why)
    ("pipelines/study.py experiment=published",
     f"pipelines/study.py experiment=published {TINY} primitives.policies=10 primitives.episodes=4",
     "make run: the published scale takes minutes"),
    ("-m pytest -q -m \"not slow and not cluster\" -n auto --dist loadfile",
     "-m pytest -q -m \"not slow and not cluster\" -n auto --dist loadfile --collect-only -p no:cacheprovider "
     "tests/test_docs_commands.py",
     "make test: the suite this test belongs to, which CI runs (here it would run this test again); this file "
     "collected with its options"),
    ("study=reach1d experiment=quick", f"study=reach1d experiment=quick {TINY}",
     "experiment=quick takes minutes"),
    ("study=mine\n", f"study=mine {TINY} {SAC_TINY}\n",
     "a study at the default N = 1000 × M = 100 and SAC at the study's budgets (20 000 steps × 5 seeds)"),
    ("study=cartpole_noise\n", f"study=cartpole_noise {TINY}\n", "12 tasks at N = M = 1000"),
    ("arm=one_link_1m0,one_link_1m65,two_link reward=dense,sparse rwg.shards=8 'rwg.shard=range(8)'",
     "arm=one_link_1m0,two_link reward=dense rwg.shards=8 'rwg.shard=range(8)' rwg.policies=16 rwg.episodes=4",
     "experiment=published: 6 tasks × 8 shards at N = 10⁴ × M = 500; 2 tasks × 8 shards at N = 16 × M = 4"),
    ("rwg.shards=3 'rwg.shard=range(3)' experiment=smoke", "rwg.shards=3 'rwg.shard=range(3)' experiment=smoke "
     "rwg.policies=6", "3 shards of 2 policies"),
    ("network=pic_linear,pic_h1_4,pic_h1_32,pic_h1_64,pic_h2_4,pic_h2_32,pic_h2_64 "
     "prior=normal,uniform,xavier_normal_tanh,xavier_uniform_tanh study.policies=100 study.episodes=100",
     "network=pic_linear,pic_h1_4 prior=normal study.policies=10 study.episodes=4 metrics.bins=1000 "
     "metrics.resamples=20", "classic-sweep's trial: 28 cells of 5 tasks; 2 cells at a tiny N and M"),
    ("network=pic_linear,pic_h1_4,pic_h1_32,pic_h1_64,pic_h2_4,pic_h2_32,pic_h2_64 "
     "prior=normal,uniform,xavier_normal_tanh,xavier_uniform_tanh hydra/launcher=cluster",
     "network=pic_linear,pic_h1_4 prior=normal study.policies=10 study.episodes=4 metrics.bins=1000 "
     "metrics.resamples=20 hydra/launcher=cluster",
     "classic-sweep on the cluster: 28 cells at N = M = 1000 as jobs; 2 cells at a tiny N and M"),
    ("arm=two_link_obstacle rwg.shards=64 'rwg.shard=range(64)'",
     "arm=two_link_obstacle rwg.shards=4 'rwg.shard=range(4)' rwg.policies=16 rwg.episodes=4",
     "the obstacle task at N = 10⁴ × M = 500 in 64 jobs; at N = 16 × M = 4 in 4 jobs"),
    ("study.policies=1000 study.episodes=1000", "study.policies=10 study.episodes=4",
     "make atlas-cluster: Furuta et al.'s N = M = 1000 (63 CPU-hours); N = 10 × M = 4"),
    ("rwg.shards=8 'rwg.shard=range(8)'", "rwg.shards=1 'rwg.shard=range(1)'",
     "make atlas-cluster: 13 tasks × 8 shards, 104 jobs; × 1 shard, 13 jobs (each job's start costs more CPU than "
     "its RWG at this budget; tests/cluster/test_slurm.py sends and merges shards)"),
    ("rwg.shards=8 hydra/launcher=cluster", "rwg.shards=1 hydra/launcher=cluster",
     "make atlas-cluster's price: of the 1 shard per task it sends"),
]

SLOW = {
    "# the six contact-free tasks × 8 shards": "the launchers' paths run in CI in tests/stages/test_scale_out.py",
    "make classic-sweep ARGS='study.policies=100": "a sweep of 2 cells of 5 tasks: half a CPU-minute; "
                                                   "tests/report/test_sweep_report.py checks the sweep report in CI",
}
"""Blocks run only with the slow tests (``make test-all``): their start → why, and what covers them in CI."""

RUN_ELSEWHERE = {
    "README.md": {".venv/bin/python pipelines/rwg.py task=gym task.env_id=Pendulum-v1 rwg.policies=64 "
                  "rwg.episodes=8\nmkdir -p ~/lab/conf/study": "tests/test_readme.py"},
    "docs/tutorials/scale-out.md": {
        "make cluster-up": "tests/cluster/test_local_cluster.py",
        "make cluster-down": "tests/cluster/test_local_cluster.py",
        "make paper-jobs EXPERIMENT=smoke": "tests/cluster/test_slurm.py",
        ".venv/bin/python pipelines/study.py experiment=smoke sac.enabled=true": "tests/cluster/test_slurm.py",
    },
}
"""Blocks another test runs as printed (page → the block's start → the test): the README's own-task block; the
local cluster's start and stop (a test that stops it starts it again); the SAC jobs and the study that reads them
(a test that checks the study trained nothing)."""

CLUSTER = {
    ".venv/bin/python pipelines/rwg.py -m hydra/launcher=cluster": "a job array on the local SLURM cluster",
    "make atlas-cluster PARTITION=local": "13 tasks × 1 shard as a job array and the study as a job, on the local "
                                          "SLURM cluster",
    "make classic-sweep ARGS='hydra/launcher=cluster": "a sweep's cells as jobs on the local SLURM cluster",
}
"""Blocks that send jobs to the local SLURM cluster (``make cluster-up``): run by ``make test-cluster`` (marker
``cluster``), as CI does between starting and stopping the cluster."""

INSTALLS = {
    "make atlas-cluster PARTITION=local": "its recipe installs the atlas extra (pip install -e '.[atlas]')",
}
"""Blocks whose targets install an extra into ``.venv`` where it is not installed yet (marker ``installs``): pip
reinstalls the package, and a process that imports it meanwhile fails. CI runs the other cluster tests beside
``make test``, then installs the extras these need and runs them beside the AVX2 pass (``.ci/run``);
``test_the_blocks_that_install_an_extra_are_marked`` keeps the list whole."""

DRIFT = '''"""The tutorial's own env: a point drifting on a line, pushed by the action (test_docs_commands)."""
import gymnasium as gym
import numpy as np


class Drift(gym.Env):
    def __init__(self, noise=0.0):
        self.noise = float(noise)
        self.observation_space = gym.spaces.Box(-10.0, 10.0, (1,), dtype=np.float64)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), dtype=np.float64)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(-1.0, 1.0, 1)
        return self.x.copy(), {}

    def step(self, action):
        self.x = np.clip(self.x + 0.1 * np.asarray(action) + self.np_random.normal(0.0, self.noise, 1), -10, 10)
        return self.x.copy(), -abs(float(self.x[0])), False, False, {}


gym.register("Drift-v0", entry_point=Drift, max_episode_steps=20)
'''


@dataclass(frozen=True)
class Block:
    """A shell block of a page: where it starts, its text, and why it is not run (None: it is run)."""

    page: Path
    line: int
    text: str
    illustrative: str | None

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks(page: Path, languages: tuple[str, ...] = SHELLS) -> list[Block]:
    """The fenced blocks of ``page`` in ``languages``, each with the reason of the marker on the line before it."""
    lines = page.read_text(encoding="utf-8").splitlines()
    found, i = [], 0
    while i < len(lines):
        opening = re.match(r"^```(\w+)\s*$", lines[i])
        if not opening:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        if opening.group(1) in languages:
            marker = ILLUSTRATIVE.match(lines[i - 1]) if i else None
            found.append(Block(page, i + 1, "\n".join(lines[i + 1:end]) + "\n",
                               marker.group("reason") if marker else None))
        i = end + 1
    return found


def commands(block: Block) -> str:
    """The block as a script: a ```console block's ``$ `` lines; other blocks as they are."""
    if not block.text.lstrip().startswith("$ "):
        return block.text
    return "".join(line[2:] + "\n" for line in block.text.splitlines() if line.startswith("$ "))


def run_elsewhere(block: Block) -> str | None:
    for start, test in RUN_ELSEWHERE.get(str(block.page.relative_to(ROOT)), {}).items():
        if block.text.startswith(start):
            return test
    return None


def slow(block: Block) -> str | None:
    return next((why for start, why in SLOW.items() if block.text.startswith(start)), None)


def on_cluster(block: Block) -> str | None:
    return next((why for start, why in CLUSTER.items() if block.text.startswith(start)), None)


def installs(block: Block) -> str | None:
    return next((why for start, why in INSTALLS.items() if block.text.startswith(start)), None)


def marks(block: Block) -> list:
    return [*([pytest.mark.slow] if slow(block) else []), *([pytest.mark.cluster] if on_cluster(block) else []),
            *([pytest.mark.installs] if installs(block) else [])]


ALL = [block for page in PAGES for block in blocks(page)]
RUNNABLE = [block for block in ALL if block.illustrative is None and run_elsewhere(block) is None]
PARAMS = [pytest.param(block, id=block.id, marks=marks(block)) for block in RUNNABLE]
RAN: set[str] = set()


def logical_lines(script: str) -> list[str]:
    """The script's lines with backslash continuations joined (heredocs pass through line by line)."""
    joined, current = [], ""
    for line in script.splitlines():
        if line.endswith("\\"):
            current += line[:-1]
            continue
        joined.append(current + line)
        current = ""
    return joined


def expand_make(script: str, environment: dict, *, extras_installed: bool = True) -> str:
    """Each ``make …`` line replaced by the recipe ``make -n`` prints for it (the install step taken as done): with
    the install of an extra where its stamp is missing or older than ``pyproject.toml``, and where ``extras_installed``
    is false, always (as on a machine that has not installed it yet)."""
    out = []
    fresh = "" if extras_installed else "-W pyproject.toml "
    for line in logical_lines(script):
        command = line.split("#", 1)[0].strip() if not line.lstrip().startswith("#") else ""
        if command.startswith("make "):
            dry = subprocess.run(["bash", "-c", f"make -n {fresh}-o .venv/.installed {command[len('make '):]}"],
                                 cwd=ROOT, env=environment, capture_output=True, text=True, timeout=120)
            assert dry.returncode == 0, dry.stderr
            recipe = [r for r in dry.stdout.splitlines() if r.strip()]
            assert recipe, f"{command}: make -n printed no recipe"
            out += recipe
        else:
            out.append(line)
    return "\n".join(out) + "\n"


def with_budget(script: str) -> str:
    """The script with every substitution of :data:`BUDGETS` applied."""
    for printed, instead, _ in BUDGETS:
        script = script.replace(printed, instead)
    return script


def prepare(block: Block, home: Path) -> None:
    """What a block needs that an earlier part of its page gave: a YAML block whose first line names its file
    under ``~`` is written there, and the own-study example's package ``my_lab`` (its env ``Drift-v0``)."""
    for yaml in blocks(block.page, ("yaml",)):
        named = re.match(r"#\s*~/(\S+)", yaml.text)
        if named:
            target = home / named.group(1)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(yaml.text, encoding="utf-8")
    if "PYTHONPATH=~/lab" in block.text:
        (home / "lab" / "my_lab.py").write_text(DRIFT, encoding="utf-8")


def user_environment(home: Path, outputs: Path) -> dict:
    """A new user's shell: HOME and the outputs in the temporary directory, no virtualenv activated."""
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("VIRTUAL_ENV", "HYDRA_FULL_ERROR", "PYTHONPATH", "MAKEFLAGS", "MFLAGS", "MAKELEVEL")
                   and not k.startswith("PYTEST_")}
    environment["PATH"] = os.pathsep.join(
        p for p in os.environ.get("PATH", "").split(os.pathsep) if p and Path(p).resolve() != VENV_BIN.resolve())
    environment.update(HOME=str(home), TASKCOMPLEXITY_OUTPUTS=str(outputs))
    return environment


@pytest.fixture(scope="module")
def outputs(tmp_path_factory) -> Path:
    """One outputs directory for every block: an artefact one block computed serves the next."""
    return tmp_path_factory.mktemp("docs-commands") / "outputs"


def test_the_pages_have_shell_blocks():
    assert {b.page.name for b in ALL} >= {"README.md", "own-task.md", "scale-out.md", "reproduce-the-paper.md"}
    assert all(block.illustrative.strip() for block in ALL if block.illustrative is not None)


def test_every_budget_substitution_is_used():
    # A substitution that matches no block is stale: the block it shrank changed, and now runs at full size.
    texts = [expand_make(commands(b), user_environment(ROOT, ROOT / "outputs")) for b in RUNNABLE]
    unused = [printed for printed, _, _ in BUDGETS if not any(printed in text for text in texts)]
    assert unused == []


def test_the_blocks_that_install_an_extra_are_marked():
    # CI runs the cluster tests beside make test, but a block that installs into .venv only after it: the blocks
    # whose script (make targets expanded) runs pip install on a machine without the extras are those of INSTALLS
    environment = user_environment(ROOT, ROOT / "outputs")
    pip = {b.id for b in RUNNABLE
           if re.search(r"\bpip install\b", expand_make(commands(b), environment, extras_installed=False))}
    assert pip == {b.id for b in RUNNABLE if installs(b)} and pip


@pytest.mark.parametrize(("marker", "paths"), [("cluster", "'tests/cluster tests/test_docs_commands.py'"),
                                              ("installs", "tests/test_docs_commands.py")])
def test_ci_collects_the_cluster_tests_where_they_are(marker, paths):
    # .ci/run collects each lane of cluster tests from its paths (CLUSTER_PATHS), not from the whole suite: a test
    # marked outside them would never run in CI
    allowed = [ROOT / path.strip("'") for path in paths.split()]
    marked = [p for p in sorted((ROOT / "tests").rglob("*.py")) if f"mark.{marker}" in p.read_text(encoding="utf-8")]
    assert marked and [p.relative_to(ROOT).as_posix() for p in marked
                       if not any(p == a or a in p.parents for a in allowed)] == []
    assert f"CLUSTER_TESTS='cluster and {'not ' * (marker == 'cluster')}installs' CLUSTER_PATHS={paths}" in (
        ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_no_block_needs_an_activated_virtualenv():
    # `python …` works only after `source .venv/bin/activate`; the pages write .venv/bin/python (or make).
    bare = [b.id for b in ALL if re.search(r"(^|[\s;&|(])(python3?|pip|pytest|mkdocs)\s", commands(b), re.MULTILINE)]
    assert bare == []


@pytest.mark.skipif(not (VENV_BIN / "python").exists(), reason="the pages' commands use .venv")
@pytest.mark.parametrize("block", PARAMS)
def test_block_runs_at_a_tiny_budget(block, outputs, tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    prepare(block, home)
    environment = user_environment(home, outputs)
    script = with_budget(expand_make(commands(block), environment))
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=ROOT, env=environment,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{block.id} ran as\n{script}\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
    RAN.add(block.id)


def test_every_unmarked_block_ran(request):
    # Every block is illustrative, run by another test, or one of this file's runs; every run selected here
    # passed (the slow ones run with make test-all).
    for block in ALL:
        if block.illustrative is None and block not in RUNNABLE:   # the other test names the block's page
            assert block.page.name in (ROOT / run_elsewhere(block)).read_text(encoding="utf-8"), block.id
    assert all(any(block.text.startswith(start) for block in RUNNABLE) for start in SLOW), "a stale SLOW entry"
    assert all(any(block.text.startswith(start) for block in RUNNABLE) for start in CLUSTER), "a stale CLUSTER entry"
    assert all(any(block.text.startswith(start) for block in RUNNABLE) for start in INSTALLS), "a stale INSTALLS entry"
    if getattr(request.config.option, "dist", "no") not in ("no", "loadfile"):
        pytest.skip("the blocks ran on other workers")   # make test: --dist loadfile keeps this file on one worker
    selected = {item.callspec.id for item in request.session.items
                if getattr(item, "originalname", "") == "test_block_runs_at_a_tiny_budget"}
    assert selected - RAN == set(), "these blocks did not run to the end"


if __name__ == "__main__":  # list the blocks and what happens to each
    for b in ALL:
        status = f"illustrative: {b.illustrative}" if b.illustrative else (
            f"run by {run_elsewhere(b)}" if run_elsewhere(b) else f"run (slow: {slow(b)})" if slow(b) else
            f"run (cluster: {on_cluster(b)})" if on_cluster(b) else "run")
        print(f"{b.id:<40} {status}\n    " + commands(b).strip().replace("\n", "\n    "), file=sys.stdout)
