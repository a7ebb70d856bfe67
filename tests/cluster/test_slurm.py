"""The cluster path on a real scheduler: jobs sent through ``hydra/launcher=cluster`` to the local single-node SLURM
(``make cluster-up``, partition ``local``), and what must hold there.

- A sharded RWG multirun is a job array; the last shard merges, and the artefact is byte for byte the one-job run's.
- A failing shard comes back as one line with its job id and log; the other shards still merge.
- A job cancelled mid-shard (``scancel``) is named with its state; the rerun resumes from its saved chunks.
- A job that reaches its time limit is requeued by submitit and resumes from its saved chunks.
- In every case the artefact's job records (``manifest.json``: ``jobs``) add up to N policies computed once each.
- Two studies sent at once onto one cache both finish, each artefact valid and computed once; their reports' Methods
  name the SLURM jobs that computed their returns.

Each test waits on real jobs; ``make test-cluster`` runs them (CI too, between ``make cluster-up`` and
``make cluster-down``).
"""

from __future__ import annotations

import itertools
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

import preloaded
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.tasks.spec import make_task

pytestmark = pytest.mark.cluster

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
PAGE = ROOT / "docs" / "tutorials" / "scale-out.md"
RWG = str(ROOT / "pipelines" / "rwg.py")
STUDY = str(ROOT / "pipelines" / "study.py")
PARTITION = "local"
LAUNCHER = ("hydra/launcher=cluster", f"hydra.launcher.partition={PARTITION}")
SLOW = ("task=gym", "task.env_id=slow_drift:SlowDrift-v0", "rwg.chunk_policies=1")
"""A task whose steps take wall time (``SLOW_DRIFT_STEP_SECONDS``), one policy per chunk: a chunk saved every few
seconds."""


@pytest.fixture(scope="module")
def environment() -> dict:
    """The environment of a user of the local cluster: its configuration, and the slow env importable."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "SLURM_JOB", "HYDRA_"))}
    conf = ROOT / "outputs" / "cluster" / "etc" / "slurm.conf"
    if "SLURM_CONF" not in env and conf.is_file():
        env["SLURM_CONF"] = str(conf)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), env.get("PYTHONPATH", "")) if p)
    answer = subprocess.run(["sinfo", "-h", "-p", PARTITION, "-o", "%T"], capture_output=True, text=True, env=env)
    if answer.returncode != 0 or not re.search(r"idle|mixed|allocated|completing", answer.stdout):
        pytest.fail(f"no SLURM partition '{PARTITION}' answers (sinfo: {answer.stderr.strip() or answer.stdout.strip()}):"
                    " start the local cluster with make cluster-up")
    return env


def run(*args: str, env: dict, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return preloaded.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout)


def start(*args: str, env: dict, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=cwd, env=env)


def wait_for(condition, seconds: float, what: str):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if (found := condition()):
            return found
        time.sleep(0.5)
    raise AssertionError(f"{what} did not happen within {seconds:.0f} s")


def sacct(job: str, env: dict, *, attempts: bool = False) -> list[dict]:
    """The accounting rows of ``job`` (its steps included) as sacct reports them; with ``attempts``, one row per
    attempt of a requeued job (``--duplicates``)."""
    command = ["sacct", "-j", job, "--parsable2", "-o", "JobID,State,NodeList,TotalCPU", *(["-D"] if attempts else [])]
    out = subprocess.run(command, capture_output=True, text=True, env=env, check=True).stdout.splitlines()
    head = out[0].split("|")
    return [dict(zip(head, line.split("|"), strict=True)) for line in out[1:]]


def settled(job: str, env: dict, seconds: float = 60) -> list[dict]:
    """The accounting rows of ``job`` itself, one per attempt, once its last attempt has ended: the sweep returns
    as soon as a job has written its result, while the job's process is still ending (sacct: RUNNING, COMPLETING)."""
    def ended():
        rows = [r for r in sacct(job, env, attempts=True) if r["JobID"] == job]
        return rows if rows and rows[-1]["State"] not in ("PENDING", "RUNNING", "COMPLETING", "REQUEUED") else None

    return wait_for(ended, seconds, f"the end of job {job} in sacct")


def artefact(outputs: Path) -> Path:
    [found] = (outputs / "cache" / "rwg").glob("[!.]*/returns.parquet")
    return found.parent


def jobs_of(outputs: Path) -> list[dict]:
    return json.loads((artefact(outputs) / "manifest.json").read_text())["jobs"]


def array_tasks(sweep: Path) -> list[str]:
    """The job ids submitit made folders for under the sweep directory: ``<array>_<task>`` for the tasks of an
    array, a plain job id for a sweep of one job (submitit sends it as a job of its own)."""
    found = [p.name for p in (sweep / ".submitit").glob("[0-9]*") if p.is_dir()]
    tasks = [job for job in found if "_" in job]   # an array's own folder beside its tasks' is no job of the sweep
    return sorted(tasks or found, key=lambda job: tuple(int(part) for part in job.split("_")))


def one_job_run(tmp_path: Path, *overrides: str, env: dict) -> Path:
    """The same RWG run as one job on this machine (no slow steps): the reference artefact."""
    outputs = tmp_path / "single"
    done = run(RWG, *overrides, f"paths.outputs={outputs}", env={**env, "SLOW_DRIFT_STEP_SECONDS": "0"}, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    return artefact(outputs)


def test_a_sharded_rwg_job_array_merges_into_the_one_job_artefact(environment, tmp_path):
    overrides = ("arm=one_link_1m65", "experiment=smoke", "rwg.policies=16")
    sweep, outputs = tmp_path / "sweep", tmp_path / "sharded"
    done = run(RWG, "-m", *LAUNCHER, *overrides, "rwg.shards=4", "rwg.shard=range(4)", f"paths.outputs={outputs}",
               f"hydra.sweep.dir={sweep}", env=environment, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Submitit 'slurm'" in done.stdout + done.stderr
    jobs = array_tasks(sweep)
    assert len(jobs) == 4 and len({j.split("_")[0] for j in jobs}) == 1  # one array of 4 tasks
    for job in jobs:
        row = settled(job, environment)[-1]
        assert row["State"] == "COMPLETED" and row["NodeList"]
    merged = artefact(outputs)
    single = one_job_run(tmp_path, *overrides, env=environment)
    assert merged.name == single.name  # the same key
    assert (merged / "returns.parquet").read_bytes() == (single / "returns.parquet").read_bytes()
    records = jobs_of(outputs)
    assert sorted(r["job"] for r in records) == jobs and {r["scheduler"] for r in records} == {"slurm"}
    assert sorted(r["part"] for r in records) == [f"shard {i} of 4" for i in range(4)]
    assert sum(r["units"] for r in records) == 16 and all(r["reused"] == 0 for r in records)
    # The merge is done by one shard's job: the last to find every shard present.
    logs = [next((sweep / ".submitit" / job).glob("*_log.out")).read_text() for job in jobs]
    assert sum("computed returns" in log for log in logs) == 1
    assert sum(bool(re.search(r"shard \d/4 done", log)) for log in logs) == 3


def test_a_failing_shard_is_one_line_with_its_job_and_log_and_the_others_merge(environment, tmp_path):
    outputs, sweep = tmp_path / "out", tmp_path / "sweep"
    done = run(RWG, "-m", *LAUNCHER, "arm=one_link_1m65", "experiment=smoke", "rwg.shards=3", "rwg.shard=range(4)",
               f"paths.outputs={outputs}", f"hydra.sweep.dir={sweep}", env=environment, cwd=tmp_path)
    assert done.returncode == 2, done.stderr[-3000:]
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    job = array_tasks(sweep)[3]
    log = sweep / ".submitit" / job / f"{job}_0_log.err"
    assert errors == [f"error: arm=one_link_1m65 experiment=smoke rwg.shards=3 rwg.shard=3 paths.outputs={outputs}: "
                      f"rwg.shard must be in [0, 2] (rwg.shards=3), got 3 [job {job} on {os.uname().nodename} "
                      f"(log: {log})]"]
    assert "Traceback" not in done.stderr
    assert "rwg.shard must be in [0, 2]" in log.read_text()
    assert sum(r["units"] for r in jobs_of(outputs)) == 10  # shards 0-2 merged: experiment=smoke's N


def test_a_cancelled_job_is_named_and_the_rerun_resumes_from_its_saved_chunks(environment, tmp_path):
    slow = {**environment, "SLOW_DRIFT_STEP_SECONDS": "0.05"}  # 1 s per episode: 4 s per chunk
    overrides = (*SLOW, "rwg.policies=8", "rwg.episodes=4")
    outputs, sweep = tmp_path / "out", tmp_path / "sweep"
    command = (RWG, "-m", *LAUNCHER, *overrides, "rwg.shards=2", "rwg.shard=range(2)", f"paths.outputs={outputs}",
               f"hydra.sweep.dir={sweep}")
    sweeping = start(*command, env=slow, cwd=tmp_path)
    scratch = wait_for(lambda: next((outputs / "cache" / "rwg").glob(".partial-*"), None), 120, "a scratch directory")
    wait_for(lambda: (scratch / "chunk-0000004-0000005.npz").exists(), 120, "shard 1's first saved chunk")
    job = array_tasks(sweep)[1]
    subprocess.run(["scancel", job], env=environment, check=True)
    _, stderr = sweeping.communicate(timeout=300)
    assert sweeping.returncode == 1
    [error] = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert error.startswith(f"error: job {job} ended without a result (state: CANCELLED")
    assert f"{job}_0_log.err" in error and "rerun the same command to resume" in error
    assert wait_for(lambda: [r for r in sacct(job, environment) if r["JobID"] == job and "CANCELLED" in r["State"]],
                    30, "sacct's CANCELLED state")
    saved = len(list(scratch.glob("chunk-*.npz")))
    assert saved >= 1

    again = run(*command[:-1], f"hydra.sweep.dir={tmp_path / 'sweep-again'}", env=slow, cwd=tmp_path)
    assert again.returncode == 0, again.stderr[-3000:]
    records = jobs_of(outputs)
    shard1 = [r for r in records if r["part"] == "shard 1 of 2"]
    assert [r["job"] for r in shard1][0] == job and len(shard1) == 2
    cancelled, resumed = shard1
    assert resumed["reused"] == cancelled["units"] == saved >= 1   # what the cancelled job saved, nothing more
    assert sum(r["units"] for r in records) == 8   # every policy computed once
    single = one_job_run(tmp_path, *overrides, env=environment)
    assert (artefact(outputs) / "returns.parquet").read_bytes() == (single / "returns.parquet").read_bytes()


def test_a_job_at_its_time_limit_is_requeued_and_resumes_from_its_saved_chunks(environment, tmp_path):
    # One job of about 50 s at a time limit of 1 min. SLURM's controller checks time limits every 30 s and signals
    # a job at the first check from which the next would come too late: with signal_delay_s=5, 25 to 55 s after
    # it started. Submitit requeues it and the requeued job resumes; 6 requeues allowed (the default is 3).
    slow = {**environment, "SLOW_DRIFT_STEP_SECONDS": "0.05"}
    overrides = (*SLOW, "rwg.policies=12", "rwg.episodes=4")
    outputs, sweep = tmp_path / "out", tmp_path / "sweep"
    done = run(RWG, "-m", *LAUNCHER, "hydra.launcher.timeout_min=1", "hydra.launcher.signal_delay_s=5",
               "hydra.launcher.max_num_timeout=6", *overrides,
               f"paths.outputs={outputs}", f"hydra.sweep.dir={sweep}", env=slow, cwd=tmp_path, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    [job] = array_tasks(sweep)
    log = next((sweep / ".submitit" / job).glob("*_log.err")).read_text()
    assert "this job is timed-out" in log and "Requeued" not in done.stderr
    records = jobs_of(outputs)
    assert len(records) >= 2 and {r["job"] for r in records} == {job}
    restarts = [r["restarts"] for r in records]   # one record per attempt that saved a chunk
    assert restarts == sorted(set(restarts)) and restarts[-1] >= 1 and records[0]["reused"] == 0
    assert all(later["reused"] == earlier["reused"] + earlier["units"] for earlier, later in itertools.pairwise(records))
    assert sum(r["units"] for r in records) == 12   # every policy computed once over the attempts
    # every attempt but the last was requeued: at least those that saved a chunk, and one that had saved its last
    # chunk (or none) when the time-limit signal came before it returned (under load, or a late start)
    attempts = [r["State"] for r in settled(job, environment)]
    assert attempts[-1] == "COMPLETED" and set(attempts[:-1]) == {"REQUEUED"}
    assert len(attempts) - 1 >= restarts[-1], attempts
    single = one_job_run(tmp_path, *overrides, env=environment)
    assert (artefact(outputs) / "returns.parquet").read_bytes() == (single / "returns.parquet").read_bytes()


def test_a_job_past_its_last_requeue_is_one_line_and_keeps_its_saved_chunks(environment, tmp_path):
    slow = {**environment, "SLOW_DRIFT_STEP_SECONDS": "0.05"}
    outputs, sweep = tmp_path / "out", tmp_path / "sweep"
    done = run(RWG, "-m", *LAUNCHER, "hydra.launcher.timeout_min=1", "hydra.launcher.signal_delay_s=5",
               "hydra.launcher.max_num_timeout=0", *SLOW, "rwg.policies=30", "rwg.episodes=4",
               f"paths.outputs={outputs}", f"hydra.sweep.dir={sweep}", env=slow, cwd=tmp_path, timeout=600)
    assert done.returncode == 1, done.stderr[-3000:]
    [job] = array_tasks(sweep)
    [error] = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert "the job reached its time limit and was not requeued" in error and "raised in" not in error
    assert f"[job {job} on " in error and "rerun the same command to resume" in error
    [scratch] = (outputs / "cache" / "rwg").glob(".partial-*")
    [record] = [json.loads(p.read_text()) for p in scratch.glob("job-*.json")]
    assert record["job"] == job and record["units"] == len(list(scratch.glob("chunk-*.npz"))) >= 1


def test_two_studies_sent_at_once_share_the_cache_and_their_methods_name_the_jobs(environment, tmp_path):
    # study=ablation's `default` variant is seven_tasks' one_link_1m65-dense: at experiment=smoke both studies need
    # the same RWG key. Sent at once, one job computes it and the other waits for it and reads it. SAC is off: what
    # is shared here is the RWG (test_sac_runs_sent_as_jobs_are_read_back_by_the_study sends SAC as jobs).
    outputs = tmp_path / "out"
    studies = ("seven_tasks", "ablation")
    running = [start(STUDY, "-m", *LAUNCHER, "experiment=smoke", "sac.enabled=false", f"study={study}",
                     f"paths.outputs={outputs}",
                     f"hydra.sweep.dir={tmp_path / study}", env=environment, cwd=tmp_path) for study in studies]
    for study, process in zip(studies, running, strict=True):
        _, stderr = process.communicate(timeout=600)
        assert process.returncode == 0, f"{study}: {stderr[-3000:]}"
    jobs = {study: array_tasks(tmp_path / study) for study in studies}
    assert all(len(ids) == 1 for ids in jobs.values())
    rwg = outputs / "cache" / "rwg"
    assert not list(rwg.glob(".partial-*")) and not list(rwg.glob(".tmp-*"))
    shared = RWGRequest(make_task("one_link_1m65", "dense"), NetworkSpec(), PriorSpec(),
                        RWGSettings(policies=10, episodes=4)).key   # experiment=smoke's N and M
    [record] = json.loads((rwg / shared / "manifest.json").read_text())["jobs"]
    assert record["job"] in (jobs["seven_tasks"][0], jobs["ablation"][0]) and record["units"] == 10
    for study in studies:
        [report] = (tmp_path / study).glob("**/report.md")
        [where] = [line for line in report.read_text().splitlines() if line.startswith("- **Where the RWG ran**")]
        # this study's own job, and the other's where it computed the shared task
        ids = {jobs[study][0], record["job"]}
        named = re.match(rf"- \*\*Where the RWG ran\*\*: {len(ids)} SLURM jobs? \(([^)]*)\) on "
                         rf"{os.uname().nodename} \(every task\);", where)
        assert named and set(named.group(1).split(", ")) == ids, where


def printed(start: str) -> str:
    """The shell block of the scale-out tutorial (``docs/tutorials/scale-out.md``) that starts with ``start``."""
    found = [b for b in re.findall(r"```bash\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S) if b.startswith(start)]
    assert len(found) == 1, f"scale-out.md has {len(found)} blocks starting with {start!r}"
    return found[0]


def test_sac_runs_sent_as_jobs_are_read_back_by_the_study(environment, tmp_path):
    # The scale-out tutorial's two blocks as printed: make paper-jobs on the local cluster, then the study with the
    # same SAC settings, which trains nothing and finds every run in the cache.
    outputs = tmp_path / "out"
    env = {**environment, "TASKCOMPLEXITY_OUTPUTS": str(outputs)}
    for start in ("make paper-jobs EXPERIMENT=smoke", ".venv/bin/python pipelines/study.py experiment=smoke"):
        done = subprocess.run(["bash", "-euo", "pipefail", "-c", printed(start)], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, f"{start}: {done.stderr[-3000:]}"
    sweep = next((outputs / "runs" / "multirun").glob("*/*"))
    assert len(array_tasks(sweep)) == 7   # one job per study task (its variants and seeds together)
    log = next((outputs / "runs").glob("*/*/study.log")).read_text()
    assert "all 10 runs in the cache" in log
    jobs = array_tasks(sweep)
    [report] = (outputs / "reports").glob("*/*/report.md")
    [where] = [line for line in report.read_text().splitlines() if line.startswith("- **Where SAC ran**")]
    assert where.startswith(f"- **Where SAC ran**: 7 SLURM jobs ({jobs[0]}–{jobs[-1]}) on {os.uname().nodename} "
                            "(every task);")
