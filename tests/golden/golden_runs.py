"""Golden runs: every stage at fixed tiny settings, the numbers of its artefact hashed.

A stage's cache key holds its declared numerics version, not its code (:mod:`taskcomplexity.stages.keys`),
so a change of its numbers must come with a version bump. ``test_golden.py`` runs the stages here and
compares each artefact's hash with ``hashes.json``, where it was recorded together with the stage's
version and the versions of the stages upstream of it in the chain below. After a deliberate change of
numbers (with its version bump) re-record::

    PYTHONPATH=src python tests/golden/golden_runs.py --record            # every stage
    PYTHONPATH=src python tests/golden/golden_runs.py --record sac        # one (the chain runs anyway)
    PYTHONPATH=src python tests/golden/golden_runs.py                     # compare only, print the verdicts

What is hashed is the artefact's values (every parquet column and ``.npz`` array, in file and column order,
with their names), never the parquet bytes, which carry library metadata; wall-clock columns (``time/…``) and
manifests are left out. Floats are rounded to :data:`SIGNIFICANT_BITS` first, so that a last-bit difference
between two CPUs' vector math (numpy's and torch's kernels differ by instruction set) is no change, while
any change a result would show is. Every run pins numba, BLAS, OpenMP and torch to one thread, so the hashes
do not depend on the machine's cores. The whole chain takes about a minute.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import hashlib
import json
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

HASHES = Path(__file__).with_name("hashes.json")
SIGNIFICANT_BITS = 36
"""Floats keep 36 significant bits (a relative precision of 1.5·10⁻¹¹) before they are hashed."""
LEFT_OUT = ("time/",)
"""Column prefixes that hold no number of the stage (wall-clock durations)."""
RECORD = "PYTHONPATH=src python tests/golden/golden_runs.py --record"
CPU_DEPENDENT = ("sac", "occupancy", "learning_path")
"""Stages whose numbers come from float32 torch training: hundreds of gradient steps carry a last-bit
difference of the CPU's kernels (torch and its BLAS pick them by instruction set and vendor) into every
digit, so their hashes are recorded per CPU kind (:func:`cpu_kind`); the other stages' rounded values are
the same on every CPU."""


def cpu_kind() -> str:
    """The kind of CPU torch computes on: its vector capability and the vendor, e.g. ``AVX2 AuthenticAMD``."""
    import torch

    vendor = "unknown"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("vendor_id"):
                vendor = line.partition(":")[2].strip()
                break
    return f"{torch.backends.cpu.get_cpu_capability()} {vendor}"


@dataclass
class Golden:
    """One stage's golden run: the hash of each case's artefact and the versions it was computed at."""

    stage: str
    version: int
    inputs: dict[str, int]
    sha256: dict[str, str] = field(default_factory=dict)

    def entry(self, previous: dict | None = None) -> dict:
        """The record of this run; a CPU-dependent stage keeps the other CPU kinds' hashes of ``previous``
        when it is recorded at the same versions."""
        sha256: dict = dict(self.sha256)
        if self.stage in CPU_DEPENDENT:
            same = previous is not None and previous["version"] == self.version and \
                previous.get("inputs", {}) == self.inputs
            sha256 = {**(previous["sha256"] if same else {}), cpu_kind(): sha256}
        return {"version": self.version, "inputs": dict(sorted(self.inputs.items())), "sha256": dict(sorted(sha256.items()))}


def rounded(values: np.ndarray) -> np.ndarray:
    """Floats to :data:`SIGNIFICANT_BITS` significant bits, −0 as 0, one NaN; other dtypes as they are."""
    if values.dtype.kind != "f":
        return values
    values = values.astype(np.float64)
    mantissa, exponent = np.frexp(values)
    scale = float(2**SIGNIFICANT_BITS)
    out = np.ldexp(np.round(mantissa * scale) / scale, exponent) + 0.0
    out[np.isnan(values)] = np.nan
    return out


def _update(digest, name: str, values) -> None:
    values = np.asarray(values)
    digest.update(f"{name}\x1f{values.dtype.kind}\x1f{values.shape}\x1e".encode())
    if values.dtype.kind in "fiub":
        digest.update(np.ascontiguousarray(rounded(values).astype(np.float64 if values.dtype.kind == "f"
                                                                 else np.int64)).tobytes())
    else:
        digest.update("\x1f".join(map(str, values.ravel().tolist())).encode())


def numbers_digest(directory: Path) -> str:
    """SHA-256 of the values of every ``.parquet`` and ``.npz`` file of an artefact directory (see module)."""
    digest = hashlib.sha256()
    files = sorted(p for p in Path(directory).iterdir() if p.suffix in (".parquet", ".npz"))
    if not files:
        raise ValueError(f"{directory}: no parquet or npz file to hash")
    for path in files:
        digest.update(f"\x1d{path.name}".encode())
        if path.suffix == ".parquet":
            frame = pd.read_parquet(path)
            for column in frame.columns:
                if not str(column).startswith(LEFT_OUT):
                    _update(digest, str(column), frame[column].to_numpy())
        else:
            with np.load(path) as arrays:
                for name in sorted(arrays.files):
                    _update(digest, name, arrays[name])
    return digest.hexdigest()


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """numba, BLAS/OpenMP and torch on one thread for the span of the block (restored afterwards)."""
    import numba
    import torch
    from threadpoolctl import threadpool_limits

    numba_threads, torch_threads = numba.get_num_threads(), torch.get_num_threads()
    numba.set_num_threads(1)
    torch.set_num_threads(1)
    try:
        with threadpool_limits(1):
            yield
    finally:
        numba.set_num_threads(numba_threads)
        torch.set_num_threads(torch_threads)


def _version(stage: str) -> int:
    import importlib

    return importlib.import_module(f"taskcomplexity.stages.{stage}_stage").NUMERICS.version


def run_all(root: Path) -> dict[str, Golden]:
    """Every stage's golden run in a fresh cache under ``root``: {stage: Golden}."""
    with one_thread():
        return _chain(root)


def _chain(root: Path) -> dict[str, Golden]:
    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
    from taskcomplexity.policies.primitives import PrimitiveSpec
    from taskcomplexity.rl import protocol_variants
    from taskcomplexity.rl.settings import SACSettings
    from taskcomplexity.rl.snapshots import ACTORS_FILE
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.cache import Cache
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, run_diagnostics_stage
    from taskcomplexity.stages.learning_path_stage import LearningPathSettings, run_learning_path_stage
    from taskcomplexity.stages.metrics_stage import MetricsSettings, run_metrics_stage
    from taskcomplexity.stages.occupancy_stage import OccupancySettings, run_occupancy_stage
    from taskcomplexity.stages.primitives_stage import PrimitivesSettings, run_primitives_stage
    from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage
    from taskcomplexity.stages.sac_stage import run_sac_stage
    from taskcomplexity.stages.verdict_stage import run_verdict_stage
    from taskcomplexity.study_data import load_study_file
    from taskcomplexity.tasks.gym_task import GymTask
    from taskcomplexity.tasks.spec import make_task, task_from_id

    cache = Cache(root)
    v = {s: _version(s) for s in ("rwg", "metrics", "diagnostics", "primitives", "sac", "occupancy",
                                  "learning_path", "verdict")}
    golden = {
        "rwg": Golden("rwg", v["rwg"], {}),
        "metrics": Golden("metrics", v["metrics"], {"rwg": v["rwg"]}),
        "diagnostics": Golden("diagnostics", v["diagnostics"], {"rwg": v["rwg"]}),
        "primitives": Golden("primitives", v["primitives"], {"rwg": v["rwg"]}),
        "sac": Golden("sac", v["sac"], {}),
        "occupancy": Golden("occupancy", v["occupancy"], {"sac": v["sac"]}),
        "learning_path": Golden("learning_path", v["learning_path"], {"sac": v["sac"]}),
        "verdict": Golden("verdict", v["verdict"], {"rwg": v["rwg"], "metrics": v["metrics"],
                                                    "diagnostics": v["diagnostics"]}),
    }

    def rwg(task, policies, episodes, *, network=None, backend="batched", **settings):
        request = RWGRequest(task, network or NetworkSpec(), PriorSpec(),
                             RWGSettings(policies=policies, episodes=episodes, seed=3, **settings), backend)
        return request, run_rwg_stage(cache, request)[0]

    # RWG: every backend and family, the contact model, a classic-control kernel and a gymnasium env
    one_link = make_task("one_link_1m0", "dense")
    cases = {
        "one_link_1m0-dense batched": rwg(one_link, 16, 4),
        "two_link_obstacle contact model": rwg(make_task("two_link_obstacle"), 8, 3, contacts="model"),
        "two_link-sparse pybullet": rwg(make_task("two_link", "sparse"), 2, 2, backend="pybullet"),
        "Pendulum-v1 kernel": rwg(GymTask("Pendulum-v1"), 8, 2, backend="kernel"),
        "CartPole-v1 gym": rwg(GymTask("CartPole-v1"), 4, 2, backend="gym"),
        "one_link_1m65-dense dmp": rwg(make_task("one_link_1m65", "dense"), 8, 3, network=PrimitiveSpec()),
    }
    golden["rwg"].sha256 = {name: numbers_digest(artefact.path) for name, (_, artefact) in cases.items()}
    request, returns = cases["one_link_1m0-dense batched"]

    estimators = MetricsSettings(bins=16, resamples=20, batches=2)
    metrics, _ = run_metrics_stage(cache, returns, estimators)
    golden["metrics"].sha256 = {"one_link_1m0-dense": numbers_digest(metrics.path)}
    diagnostics_settings = DiagnosticsSettings(repeats=2, bins_sweep=(4, 16), subsample_fractions=(0.5, 1.0),
                                               knn_max_samples=100, knn_episodes_per_policy=4)
    diagnostics, _ = run_diagnostics_stage(cache, returns, estimators, diagnostics_settings)
    golden["diagnostics"].sha256 = {"one_link_1m0-dense": numbers_digest(diagnostics.path)}
    family = PrimitivesSettings(policies=8, episodes=3, bins=8, batches=2)
    primitives, _ = run_primitives_stage(cache, family.request(request), estimators, family)
    golden["primitives"].sha256 = {"one_link_1m0-dense": numbers_digest(primitives.path)}

    # SAC: a few hundred steps of two seeds on the 1-link dense task, and of HER on the 2-link sparse task
    sac = SACSettings(hidden_sizes=(32, 32), batch_size=32, total_steps=300, warmup_steps=100, eval_every=100,
                      eval_episodes=2, checkpoint_every=100, seeds=(0, 1), num_threads=1)
    plain, _ = run_sac_stage(cache, one_link, sac)
    her_task = make_task("two_link", "sparse")
    her = [variant for variant in protocol_variants(her_task, dataclasses.replace(sac, total_steps=200, seeds=(0,)))
           if variant.her]
    her_run, _ = run_sac_stage(cache, her_task, her[0])
    golden["sac"].sha256 = {"one_link_1m0-dense sac": numbers_digest(plain.path),
                            "two_link-sparse sac+her": numbers_digest(her_run.path)}

    actors = plain.path / ACTORS_FILE
    occupancy, _ = run_occupancy_stage(cache, request, plain.key, actors,
                                       OccupancySettings(policies=4, episodes=1, pairs=20, resamples=10, batches=2))
    golden["occupancy"].sha256 = {"one_link_1m0-dense": numbers_digest(occupancy.path)}
    path, _ = run_learning_path_stage(cache, request, plain.key, actors,
                                      LearningPathSettings(policies=4, episodes=2, bins=4, batches=2), estimators)
    golden["learning_path"].sha256 = {"one_link_1m0-dense": numbers_digest(path.path)}

    # the verdict of a three-task study on its metrics and diagnostics
    from taskcomplexity.cli import CONF_DIR

    study = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
    ids = ("one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense")
    per_task = {i: rwg(task_from_id(i), 16, 4)[1] for i in ids}
    verdict, _ = run_verdict_stage(
        cache, study, {i: run_metrics_stage(cache, a, estimators)[0] for i, a in per_task.items()},
        diagnostics={i: run_diagnostics_stage(cache, a, estimators, diagnostics_settings)[0]
                     for i, a in per_task.items()})
    golden["verdict"].sha256 = {"three tasks": numbers_digest(verdict.path)}
    return golden


def recorded() -> dict[str, dict]:
    return json.loads(HASHES.read_text(encoding="utf-8")) if HASHES.exists() else {}


def recorded_hashes(stage: str, entry: dict | None) -> dict | None:
    """The recorded hashes of ``stage`` that apply on this machine (None: none recorded for its CPU kind)."""
    if entry is None:
        return None
    return entry["sha256"].get(cpu_kind()) if stage in CPU_DEPENDENT else entry["sha256"]


def unrecorded_cpu(stage: str, then: dict[str, dict]) -> str | None:
    """Why a CPU-dependent stage cannot be compared on this machine (None: it can)."""
    entry = then.get(stage)
    if stage not in CPU_DEPENDENT or entry is None or recorded_hashes(stage, entry) is not None:
        return None
    return (f"stage {stage}'s golden run is recorded for {', '.join(entry['sha256'])}, not for this CPU "
            f"({cpu_kind()}): record it here with `{RECORD} {stage}` (the others are kept)")


def problem(stage: str, now: dict[str, Golden], then: dict[str, dict]) -> str | None:
    """Why ``stage``'s golden run disagrees with the record (None: it agrees)."""
    golden, entry = now[stage], then.get(stage)
    module = f"src/taskcomplexity/stages/{stage}_stage.py"
    if entry is None:
        return f"stage {stage} has no recorded golden run: record it with `{RECORD} {stage}`"
    if entry["version"] != golden.version:
        return (f"stage {stage}'s version moved ({entry['version']} → {golden.version}): re-record its golden run "
                f"with `{RECORD} {stage}`")
    moved = {s: (v, golden.inputs.get(s)) for s, v in entry.get("inputs", {}).items() if golden.inputs.get(s) != v}
    if moved or set(golden.inputs) != set(entry.get("inputs", {})):
        return (f"stage {stage}'s inputs moved version ({moved}): re-record its golden run with "
                f"`{RECORD} {stage}`")
    hashes = recorded_hashes(stage, entry)
    if hashes is None:
        return unrecorded_cpu(stage, then)
    if hashes == golden.sha256:
        return None
    upstream = [s for s in golden.inputs if now[s].sha256 != recorded_hashes(s, then.get(s))]
    if upstream:
        return f"stage {stage}'s inputs ({', '.join(upstream)}) changed their numbers: see their failures first"
    changed = sorted(set(hashes) ^ set(golden.sha256) | {c for c in golden.sha256 if hashes.get(c) != golden.sha256[c]})
    return (f"stage {stage}'s numbers changed without a version bump (cases: {', '.join(changed)}): bump "
            f"NUMERICS.version in {module} (name the change in the commit) and re-record with `{RECORD} {stage}`; "
            "if the change was not meant, a refactor changed the numbers")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--record", action="store_true", help="write the hashes of the stages named (default all)")
    parser.add_argument("stages", nargs="*", help="stages to record (default: every stage)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="golden-") as root:
        now = run_all(Path(root))
    then = recorded()
    unknown = set(args.stages) - set(now)
    if unknown:
        parser.error(f"unknown stages {sorted(unknown)} (allowed: {', '.join(now)})")
    if args.record:
        for stage in args.stages or list(now):
            then[stage] = now[stage].entry(then.get(stage))
        HASHES.write_text(json.dumps(dict(sorted(then.items())), indent=2) + "\n", encoding="utf-8")
        print(f"recorded {', '.join(args.stages or now)} in {HASHES}")
        return 0
    failures = [p for s in now if (p := problem(s, now, then)) is not None]
    print("\n".join(failures) or "every stage's numbers agree with the record")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
