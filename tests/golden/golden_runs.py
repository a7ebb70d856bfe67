"""Golden runs: every stage at fixed tiny settings, the values of its artefact recorded and compared.

A stage's cache key holds its declared numerics version, not its code (:mod:`taskcomplexity.stages.keys`),
so a change of its numbers must come with a version bump. ``test_golden.py`` runs the stages here and
compares each artefact's values with those recorded under ``values/``, together with the stage's version and
the versions of the stages upstream of it (``records.json``). After a deliberate change of numbers (with its
version bump) re-record::

    PYTHONPATH=src python tests/golden/golden_runs.py --record            # every stage
    PYTHONPATH=src python tests/golden/golden_runs.py --record sac        # one (the chain runs anyway)
    PYTHONPATH=src python tests/golden/golden_runs.py                     # compare only, print the verdicts

What is recorded is every parquet column and ``.npz`` array of the artefact, with its name, never the parquet
bytes (they carry library metadata); wall-clock columns (``time/…``) and manifests are left out. Integers,
booleans and labels must be equal; floats within :data:`TOLERANCE` (its docstring says why that size). A
disagreement names the case, file and column, the first differing value and its relative difference.

Every run pins numba, BLAS, OpenMP and torch to one thread, so the values do not depend on the machine's
cores. The whole chain takes about a minute.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import re
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).parent
RECORDS = HERE / "records.json"
VALUES = HERE / "values"
LEFT_OUT = ("time/",)
"""Column prefixes that hold no number of the stage (wall-clock durations)."""
RECORD = "PYTHONPATH=src python tests/golden/golden_runs.py --record"
CPU_DEPENDENT = ("sac", "occupancy", "learning_path")
"""Stages whose numbers come from float32 torch training, recorded per CPU kind (:func:`cpu_kind`) and compared
within :data:`TOLERANCE` on a CPU of the same kind. Each gradient step carries a last-bit difference of the
CPU's kernels (torch, MKL and oneDNN pick them by instruction set and vendor) into the next: between the AVX-512
and AVX2 paths of one Intel CPU the actors' weights after the golden run's 300 steps differ by up to 3e-7
(5e-5 relative on small weights) and the stages computed from them by up to 5e-9 relative. No tolerance
measured on the kinds at hand covers a vendor's BLAS not yet seen, so a kind is recorded where it runs, and an
unrecorded kind skips these three with the command that records it. The other stages' values agree within
:data:`TOLERANCE` on every CPU."""


@dataclass(frozen=True)
class Tolerance:
    """|now − recorded| <= relative · max(|now|, |recorded|) + absolute, for every float value."""

    relative: float
    absolute: float

    def close(self, now: np.ndarray, recorded: np.ndarray) -> np.ndarray:
        """Elementwise: within the tolerance, or NaN in both."""
        with np.errstate(invalid="ignore"):
            bound = self.relative * np.maximum(np.abs(now), np.abs(recorded)) + self.absolute
            return (np.abs(now - recorded) <= bound) | (now == recorded) | (np.isnan(now) & np.isnan(recorded))


TOLERANCE = Tolerance(relative=1e-9, absolute=1e-12)
"""How far a golden value may move between CPUs. The vector kernels that NumPy dispatches by instruction set
(``exp``, ``log``, ``power``: AVX-512 against AVX2) differ in the last bit of some results, about 1e-16
relative. Sums over the tiny runs' values carry that to at most 1.1e-13 relative (a standard deviation of
nearly equal null values), and a difference of two nearly equal values (POIC's observed value minus its null
mean, ~0.1 nat) to a few 1e-15 absolute, which is large relative to a difference near zero: hence an absolute
term. Both terms sit at least 10³ times above what was measured between the two paths and far below any
change of an estimator, a setting or a seed, which moves these values by 1e-6 or more."""


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


Values = dict[str, np.ndarray]
"""An artefact's values: ``file › column`` (or ``file › array``) → values, in file and column order."""


@dataclass
class Golden:
    """One stage's golden run: each case's artefact values and the versions they were computed at."""

    stage: str
    version: int
    inputs: dict[str, int]
    values: dict[str, Values] = field(default_factory=dict)

    def entry(self, previous: dict | None = None) -> dict:
        """The record of this run; a CPU-dependent stage keeps the CPU kinds of ``previous`` when it is
        recorded at the same versions."""
        entry: dict = {"version": self.version, "inputs": dict(sorted(self.inputs.items()))}
        if self.stage in CPU_DEPENDENT:
            entry["cpu_kinds"] = sorted({*same_versions_kinds(entry, previous), cpu_kind()})
        return entry


def same_versions_kinds(entry: dict, previous: dict | None) -> list[str]:
    """The CPU kinds recorded in ``previous`` if it is at the versions of ``entry``, else none."""
    same = previous is not None and previous["version"] == entry["version"] and \
        previous.get("inputs", {}) == entry["inputs"]
    return list(previous.get("cpu_kinds", [])) if same else []


def _column(values: np.ndarray) -> np.ndarray:
    """One column as stored: numbers as they are, anything else as text (no pickled objects)."""
    values = np.asarray(values)
    if values.dtype.kind in "fiub":
        return values.astype(np.float64) if values.dtype.kind == "f" else values
    return np.array([str(v) for v in values.ravel().tolist()], dtype=str).reshape(values.shape)


def artefact_values(directory: Path) -> Values:
    """The values of every ``.parquet`` and ``.npz`` file of an artefact directory (see module)."""
    values: Values = {}
    files = sorted(p for p in Path(directory).iterdir() if p.suffix in (".parquet", ".npz"))
    if not files:
        raise ValueError(f"{directory}: no parquet or npz file to record")
    for path in files:
        if path.suffix == ".parquet":
            frame = pd.read_parquet(path)
            for column in frame.columns:
                if not str(column).startswith(LEFT_OUT):
                    values[f"{path.name} › {column}"] = _column(frame[column].to_numpy())
        else:
            with np.load(path) as arrays:
                for name in sorted(arrays.files):
                    values[f"{path.name} › {name}"] = _column(arrays[name])
    return values


def difference(now: Values, recorded: Values, tolerance: Tolerance = TOLERANCE) -> str | None:
    """The first disagreement of two artefacts' values in one line (None: they agree)."""
    if list(now) != list(recorded):
        gone, new = [n for n in recorded if n not in now], [n for n in now if n not in recorded]
        return (f"its files or columns differ (recorded only: {', '.join(gone) or '-'}; now only: "
                f"{', '.join(new) or '-'}; or their order)" if gone or new else "its columns are in another order")
    for name, value in now.items():
        then = recorded[name]
        if value.shape != then.shape or value.dtype.kind != then.dtype.kind:
            return f"{name}: shape {value.shape} {value.dtype} against the recorded {then.shape} {then.dtype}"
        if value.dtype.kind == "f":
            wrong = np.flatnonzero(~tolerance.close(value.ravel(), then.ravel()))
            if wrong.size:
                i = wrong[0]
                a, b = float(value.ravel()[i]), float(then.ravel()[i])
                relative = abs(a - b) / max(abs(a), abs(b)) if np.isfinite(a) and np.isfinite(b) else np.inf
                return (f"{name}: {wrong.size} of {value.size} values differ; value {i}: {a!r} against the "
                        f"recorded {b!r} (relative difference {relative:.3g}; the tolerance is "
                        f"{tolerance.relative:g} relative + {tolerance.absolute:g})")
        elif not np.array_equal(value, then):
            i = np.flatnonzero(value.ravel() != then.ravel())[0]
            return f"{name}: value {i} is {value.ravel()[i].item()!r} against the recorded {then.ravel()[i].item()!r}"
    return None


def values_file(stage: str, kind: str | None = None) -> Path:
    """Where a stage's values are recorded: one file, or one per CPU kind for a CPU-dependent stage."""
    return VALUES / (f"{stage}.npz" if kind is None else f"{stage}@{re.sub(r'[^A-Za-z0-9]+', '-', kind)}.npz")


def save_values(path: Path, cases: dict[str, Values]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{f"{case} › {name}": value for case, values in cases.items()
                                 for name, value in values.items()})


def load_values(path: Path) -> dict[str, Values]:
    cases: dict[str, Values] = {}
    with np.load(path, allow_pickle=False) as arrays:
        for key in arrays.files:
            case, _, name = key.partition(" › ")
            cases.setdefault(case, {})[name] = arrays[key]
    return cases


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
    golden["rwg"].values = {name: artefact_values(artefact.path) for name, (_, artefact) in cases.items()}
    request, returns = cases["one_link_1m0-dense batched"]

    estimators = MetricsSettings(bins=16, resamples=20, batches=2)
    metrics, _ = run_metrics_stage(cache, returns, estimators)
    golden["metrics"].values = {"one_link_1m0-dense": artefact_values(metrics.path)}
    diagnostics_settings = DiagnosticsSettings(repeats=2, bins_sweep=(4, 16), subsample_fractions=(0.5, 1.0),
                                               knn_max_samples=100, knn_episodes_per_policy=4)
    diagnostics, _ = run_diagnostics_stage(cache, returns, estimators, diagnostics_settings)
    golden["diagnostics"].values = {"one_link_1m0-dense": artefact_values(diagnostics.path)}
    family = PrimitivesSettings(policies=8, episodes=3, bins=8, batches=2)
    primitives, _ = run_primitives_stage(cache, family.request(request), estimators, family)
    golden["primitives"].values = {"one_link_1m0-dense": artefact_values(primitives.path)}

    # SAC: a few hundred steps of two seeds on the 1-link dense task, and of HER on the 2-link sparse task
    sac = SACSettings(hidden_sizes=(32, 32), batch_size=32, total_steps=300, warmup_steps=100, eval_every=100,
                      eval_episodes=2, checkpoint_every=100, seeds=(0, 1), num_threads=1)
    plain, _ = run_sac_stage(cache, one_link, sac)
    her_task = make_task("two_link", "sparse")
    her = [variant for variant in protocol_variants(her_task, dataclasses.replace(sac, total_steps=200, seeds=(0,)))
           if variant.her]
    her_run, _ = run_sac_stage(cache, her_task, her[0])
    golden["sac"].values = {"one_link_1m0-dense sac": artefact_values(plain.path),
                            "two_link-sparse sac+her": artefact_values(her_run.path)}

    actors = plain.path / ACTORS_FILE
    occupancy, _ = run_occupancy_stage(cache, request, plain.key, actors,
                                       OccupancySettings(policies=4, episodes=1, pairs=20, resamples=10, batches=2))
    golden["occupancy"].values = {"one_link_1m0-dense": artefact_values(occupancy.path)}
    path, _ = run_learning_path_stage(cache, request, plain.key, actors,
                                      LearningPathSettings(policies=4, episodes=2, bins=4, batches=2), estimators)
    golden["learning_path"].values = {"one_link_1m0-dense": artefact_values(path.path)}

    # the verdict of a three-task study on its metrics and diagnostics
    from taskcomplexity.cli import CONF_DIR

    study = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
    ids = ("one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense")
    per_task = {i: rwg(task_from_id(i), 16, 4)[1] for i in ids}
    verdict, _ = run_verdict_stage(
        cache, study, {i: run_metrics_stage(cache, a, estimators)[0] for i, a in per_task.items()},
        diagnostics={i: run_diagnostics_stage(cache, a, estimators, diagnostics_settings)[0]
                     for i, a in per_task.items()})
    golden["verdict"].values = {"three tasks": artefact_values(verdict.path)}
    return golden


def recorded() -> dict[str, dict]:
    return json.loads(RECORDS.read_text(encoding="utf-8")) if RECORDS.exists() else {}


def recorded_values(stage: str, entry: dict | None) -> dict[str, Values] | None:
    """The recorded values of ``stage`` that apply on this machine (None: none recorded for its CPU kind)."""
    if entry is None:
        return None
    if stage not in CPU_DEPENDENT:
        return load_values(values_file(stage))
    return load_values(values_file(stage, cpu_kind())) if cpu_kind() in entry.get("cpu_kinds", []) else None


def unrecorded_cpu(stage: str, then: dict[str, dict]) -> str | None:
    """Why a CPU-dependent stage cannot be compared on this machine (None: it can)."""
    entry = then.get(stage)
    if stage not in CPU_DEPENDENT or entry is None or cpu_kind() in entry.get("cpu_kinds", []):
        return None
    return (f"stage {stage}'s golden run is recorded for {', '.join(entry.get('cpu_kinds', [])) or 'no CPU'}, not "
            f"for this CPU ({cpu_kind()}): record it here with `{RECORD} {stage}` (the others are kept)")


def disagreement(golden: Golden, cases: dict[str, Values] | None) -> str | None:
    """The first case whose values disagree with ``cases``, and how (None: every case agrees)."""
    if cases is None:
        return "nothing is recorded"
    if set(cases) != set(golden.values):
        return f"its cases are {sorted(golden.values)}, recorded {sorted(cases)}"
    for case, values in golden.values.items():
        differs = difference(values, cases[case])
        if differs:
            return f"case {case}, {differs}"
    return None


def problem(stage: str, now: dict[str, Golden], then: dict[str, dict],
            values: dict[str, dict[str, Values] | None] | None = None) -> str | None:
    """Why ``stage``'s golden run disagrees with the record (None: it agrees).

    ``values`` holds the recorded values per stage (read from ``values/`` when absent)."""
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
    unrecorded = unrecorded_cpu(stage, then)
    if unrecorded:
        return unrecorded

    def values_of(s: str) -> dict[str, Values] | None:
        return values[s] if values is not None else recorded_values(s, then.get(s))

    differs = disagreement(golden, values_of(stage))
    if differs is None:
        return None
    upstream = [s for s in golden.inputs if not unrecorded_cpu(s, then) and disagreement(now[s], values_of(s))]
    if upstream:
        return f"stage {stage}'s inputs ({', '.join(upstream)}) changed their numbers: see their failures first"
    return (f"stage {stage}'s numbers changed without a version bump ({differs}): bump NUMERICS.version in "
            f"{module} (name the change in the commit) and re-record with `{RECORD} {stage}`; if the change was "
            "not meant, a refactor changed the numbers")


def record(now: dict[str, Golden], stages: list[str]) -> None:
    """Write the values and records of ``stages`` (a CPU-dependent stage: this CPU kind's, the others kept
    while the versions stay)."""
    then = recorded()
    for stage in stages:
        entry = now[stage].entry(then.get(stage))
        if stage in CPU_DEPENDENT:
            for stale in VALUES.glob(f"{stage}@*.npz"):
                if stale not in {values_file(stage, kind) for kind in entry["cpu_kinds"]}:
                    stale.unlink()
        save_values(values_file(stage, cpu_kind() if stage in CPU_DEPENDENT else None), now[stage].values)
        then[stage] = entry
    RECORDS.write_text(json.dumps(dict(sorted(then.items())), indent=2) + "\n", encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--record", action="store_true", help="write the values of the stages named (default all)")
    parser.add_argument("stages", nargs="*", help="stages to record (default: every stage)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="golden-") as root:
        now = run_all(Path(root))
    unknown = set(args.stages) - set(now)
    if unknown:
        parser.error(f"unknown stages {sorted(unknown)} (allowed: {', '.join(now)})")
    if args.record:
        record(now, args.stages or list(now))
        print(f"recorded {', '.join(args.stages or now)} in {VALUES} ({cpu_kind()} for {', '.join(CPU_DEPENDENT)})")
        return 0
    then = recorded()
    failures = [p for s in now if (p := problem(s, now, then)) is not None]
    print("\n".join(failures) or "every stage's numbers agree with the record")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
