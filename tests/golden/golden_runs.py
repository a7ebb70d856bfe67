"""Golden runs: every stage at fixed tiny settings, the values of its artefact recorded and compared.

A stage's cache key holds its declared numerics version, not its code (:mod:`taskcomplexity.stages.keys`),
so a change of its numbers must come with a version bump. ``test_golden.py`` runs the stages here and
compares each artefact's values with those recorded under ``values/``, together with the stage's version and
the versions of the stages upstream of it (``records.json``). After a deliberate change of numbers (with its
version bump) re-record::

    PYTHONPATH=src python tests/golden/golden_runs.py --record            # every stage
    PYTHONPATH=src python tests/golden/golden_runs.py --record sac        # one (it runs what it reads)
    PYTHONPATH=src python tests/golden/golden_runs.py                     # compare only, print the verdicts

The stages are those of the stage records (:data:`taskcomplexity.study.chain.CHAIN`); each stage's golden run
is one function declared with ``@golden("<stage>")`` (:class:`Case`), which computes its artefacts through one
shared cache (:class:`Runs`) and names the stages whose versions its record holds (by default those its record
reads) and the tolerance its floats are compared within. A declared stage without a golden run, or a golden run
without a record, is skipped with the line that says how to add or record it.

What is recorded is every parquet column and ``.npz`` array of the artefact, with its name, never the parquet
bytes (they carry library metadata); wall-clock columns (``time/…``) and manifests are left out. Integers,
booleans and labels must be equal; floats within :data:`TOLERANCE`, or within the wider tolerance of the stages
that SAC's float32 training reaches (:data:`TRAINING_TOLERANCE` for SAC, :data:`ACTORS_TOLERANCE` for the stages
computed from its actors); each docstring says why that size. One record holds for every CPU: AVX-512 or AVX2,
Intel or AMD. A disagreement names the case, file and column, the first differing value, its relative difference
and the tolerance.

Every recorded value is compared: a recorded case, file, column or row that is gone, changed or moved fails. A
value that is not recorded (a new metric's columns, the rows of its metric in a tidy table such as the
verdict's, a new file or case) is not compared and fails nothing: it is reported, with the command that records
it (:func:`additions`, :func:`unrecorded_note`).

Every run pins numba, BLAS, OpenMP and torch to one thread, so the values do not depend on the machine's
cores. The whole chain takes about a minute.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import json
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from taskcomplexity.rl import WALL_CLOCK

HERE = Path(__file__).parent
RECORDS = HERE / "records.json"
VALUES = HERE / "values"
LEFT_OUT = (WALL_CLOCK,)
"""Column prefixes that hold no number of the stage (wall-clock durations)."""
RECORD = "PYTHONPATH=src python tests/golden/golden_runs.py --record"


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

TRAINING_TOLERANCE = Tolerance(relative=1e-5, absolute=3e-6)
"""How far SAC's golden values (its actors' weights and its curves) may move between CPUs. SAC trains in float32
torch, whose matrix products and vector kernels (MKL, oneDNN, ATen: picked by instruction set and vendor) round
differently on each kind of CPU, and each gradient step carries the difference into the next. After the golden
run's 300 steps the weights (all below 0.41 in size) differ by at most 2.9e-7 between any two of the kinds
measured: Intel AVX-512, Intel AVX2, AMD Zen 4, whose AVX-512 and AVX2 paths agree to the bit, and AMD Zen 3 (AVX2
only; its weights within 9e-8 of the records, its curves equal to the bit). That is up to
7e-5 relative on weights near zero, so the bound is chiefly absolute: 3e-6, ten times the measured, and with the
relative term at most 7e-6 on these weights, over 100 times below one Adam step (the actor's learning rate,
1e-3), by which any change of the training moves them. The curves are float32 returns (up to ~150 in size),
equal to the bit on those kinds; the relative term lets them move by at least 80 float32 last bits."""

ACTORS_TOLERANCE = Tolerance(relative=1e-7, absolute=1e-12)
"""How far the golden values of the stages computed from SAC's actors (occupancy, learning path) may move
between CPUs. The actors' weights differ by float32 last bits (:data:`TRAINING_TOLERANCE`), which moves these
stages' values by at most 6.9e-9 relative between any two of the kinds measured (the occupancy's variance of
the OT distances; the learning path's by at most 6.4e-9, the standard deviation of its POIC; on AMD Zen 3, 6.9e-9 and
5.5e-9 from the records). The bound is about
15 times that, and ten times below the 1e-6 by which a change of an estimator, a setting or a seed moves them;
its absolute term is :data:`TOLERANCE`'s."""


Values = dict[str, np.ndarray]
"""An artefact's values: ``file › column`` (or ``file › array``) → values, in file and column order."""


@dataclass
class Golden:
    """One stage's golden run: each case's artefact values, the versions they were computed at, and the
    tolerance its floats are compared within."""

    stage: str
    version: int
    inputs: dict[str, int]
    values: dict[str, Values] = field(default_factory=dict)
    tolerance: Tolerance = TOLERANCE

    def entry(self) -> dict:
        """The record of this run: its stage's version and those of the stages it reads."""
        return {"version": self.version, "inputs": dict(sorted(self.inputs.items()))}


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


KEY = "metric"
"""The column that names what a row of a tidy table is about (the verdict's metric × relation rows): rows of a
metric that is not recorded are new, not changed."""


def recorded_part(now: Values, recorded: Values) -> tuple[Values, list[str]]:
    """``now`` restricted to what ``recorded`` holds, and the names of the rest: files and columns not recorded,
    and the rows of a tidy table (a file with a :data:`KEY` column) whose metric is not recorded."""
    rows: dict[str, np.ndarray] = {}
    new: list[str] = []
    for name, value in now.items():
        file, _, column = name.partition(" › ")
        if column == KEY and name in recorded and value.ndim == 1:
            rows[file] = np.isin(value, recorded[name])
            new += [f"{file} › rows of {KEY} {label}" for label in dict.fromkeys(value[~rows[file]].tolist())]
    kept: Values = {}
    for name, value in now.items():
        if name not in recorded:
            new.append(name)
            continue
        known = rows.get(name.partition(" › ")[0])
        kept[name] = value[known] if known is not None and value.ndim >= 1 and len(value) == len(known) else value
    return kept, new


def difference(now: Values, recorded: Values, tolerance: Tolerance = TOLERANCE) -> str | None:
    """The first disagreement of an artefact's values with the recorded ones, in one line (None: every recorded
    value is there and agrees). What is not recorded (:func:`recorded_part`) is no disagreement."""
    now, _ = recorded_part(now, recorded)
    gone = [n for n in recorded if n not in now]
    if gone:
        return f"recorded files or columns are gone (recorded only: {', '.join(gone)})"
    if list(now) != list(recorded):
        return "its columns are in another order"
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


def values_file(stage: str) -> Path:
    """Where a stage's values are recorded."""
    return VALUES / f"{stage}.npz"


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


class Runs:
    """What the golden cases share: one cache under ``root``, the tiny settings, and the artefacts several cases
    read (the 1-link dense task's returns, its SAC run), each computed once (a later request is a cache hit)."""

    def __init__(self, root: Path) -> None:
        from taskcomplexity.rl.settings import SACSettings
        from taskcomplexity.stages.cache import Cache
        from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings
        from taskcomplexity.stages.metrics_stage import MetricsSettings
        from taskcomplexity.tasks.spec import make_task

        self.cache = Cache(root)
        self.one_link = make_task("one_link_1m0", "dense")
        self.estimators = MetricsSettings(bins=16, resamples=20, batches=2)
        self.diagnostics = DiagnosticsSettings(repeats=2, bins_sweep=(4, 16), subsample_fractions=(0.5, 1.0),
                                               knn_max_samples=100, knn_episodes_per_policy=4)
        self.sac_settings = SACSettings(hidden_sizes=(32, 32), batch_size=32, total_steps=300, warmup_steps=100,
                                        eval_every=100, eval_episodes=2, checkpoint_every=100, seeds=(0, 1),
                                        num_threads=1)

    def rwg(self, task, policies: int, episodes: int, *, network=None, backend: str = "batched", **settings):
        """(RWG request, artefact) of ``task`` at N = ``policies``, M = ``episodes``, seed 3."""
        from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
        from taskcomplexity.rwg import RWGSettings
        from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage

        request = RWGRequest(task, network or NetworkSpec(), PriorSpec(),
                             RWGSettings(policies=policies, episodes=episodes, seed=3, **settings), backend)
        return request, run_rwg_stage(self.cache, request)[0]

    @functools.cached_property
    def returns(self):
        """(request, artefact) of the 1-link dense task's RWG run that the stages on returns read."""
        return self.rwg(self.one_link, 16, 4)

    @functools.cached_property
    def sac(self):
        """The SAC artefact of the 1-link dense task (two seeds, 300 steps) that the actor stages read."""
        from taskcomplexity.stages.sac_stage import run_sac_stage

        return run_sac_stage(self.cache, self.one_link, self.sac_settings)[0]


@dataclass(frozen=True)
class Case:
    """A stage's golden run: ``run(runs) -> {case name: artefact directory}`` at fixed tiny settings.

    ``inputs`` are the stages whose versions its record holds; None: the stages its stage record reads
    (:attr:`taskcomplexity.stages.stage.Stage.inputs`). ``tolerance``: how far its floats may move between CPUs
    (:data:`TOLERANCE` unless SAC's training reaches them)."""

    stage: str
    run: Callable[[Runs], dict[str, Path]]
    inputs: tuple[str, ...] | None = None
    tolerance: Tolerance = TOLERANCE


CASES: dict[str, Case] = {}
"""The golden run of each stage that has one (:func:`golden`), by stage name."""


def golden(stage: str, *, inputs: tuple[str, ...] | None = None, tolerance: Tolerance = TOLERANCE):
    """Declare ``stage``'s golden run: the decorated ``run(runs) -> {case: artefact directory}``."""

    def declare(run: Callable[[Runs], dict[str, Path]]) -> Callable[[Runs], dict[str, Path]]:
        if stage in CASES:
            raise ValueError(f"stage {stage} has two golden runs")
        CASES[stage] = Case(stage, run, inputs, tolerance)
        return run

    return declare


@golden("rwg")
def _rwg(runs: Runs) -> dict[str, Path]:
    """Every backend and family, the contact model, a classic-control kernel and a gymnasium env."""
    from taskcomplexity.policies.primitives import PrimitiveSpec
    from taskcomplexity.tasks.gym_task import GymTask
    from taskcomplexity.tasks.spec import make_task

    cases = {
        "one_link_1m0-dense batched": runs.returns,
        "two_link_obstacle contact model": runs.rwg(make_task("two_link_obstacle"), 8, 3, contacts="model"),
        "two_link-sparse pybullet": runs.rwg(make_task("two_link", "sparse"), 2, 2, backend="pybullet"),
        "Pendulum-v1 kernel": runs.rwg(GymTask("Pendulum-v1"), 8, 2, backend="kernel"),
        "CartPole-v1 gym": runs.rwg(GymTask("CartPole-v1"), 4, 2, backend="gym"),
        "one_link_1m65-dense dmp": runs.rwg(make_task("one_link_1m65", "dense"), 8, 3, network=PrimitiveSpec()),
    }
    return {name: artefact.path for name, (_, artefact) in cases.items()}


@golden("metrics")
def _metrics(runs: Runs) -> dict[str, Path]:
    from taskcomplexity.stages.metrics_stage import run_metrics_stage

    return {"one_link_1m0-dense": run_metrics_stage(runs.cache, runs.returns[1], runs.estimators)[0].path}


@golden("diagnostics")
def _diagnostics(runs: Runs) -> dict[str, Path]:
    from taskcomplexity.stages.diagnostics_stage import run_diagnostics_stage

    artefact, _ = run_diagnostics_stage(runs.cache, runs.returns[1], runs.estimators, runs.diagnostics)
    return {"one_link_1m0-dense": artefact.path}


@golden("primitives")
def _primitives(runs: Runs) -> dict[str, Path]:
    from taskcomplexity.stages.primitives_stage import PrimitivesSettings, run_primitives_stage

    family = PrimitivesSettings(policies=8, episodes=3, bins=8, batches=2)
    artefact, _ = run_primitives_stage(runs.cache, family.request(runs.returns[0]), runs.estimators, family)
    return {"one_link_1m0-dense": artefact.path}


@golden("sac", tolerance=TRAINING_TOLERANCE)
def _sac(runs: Runs) -> dict[str, Path]:
    """A few hundred steps of two seeds on the 1-link dense task, and of HER on the 2-link sparse task."""
    from taskcomplexity.rl import protocol_variants
    from taskcomplexity.stages.sac_stage import run_sac_stage
    from taskcomplexity.tasks.spec import make_task

    her_task = make_task("two_link", "sparse")
    her = [variant for variant in protocol_variants(her_task, dataclasses.replace(runs.sac_settings, total_steps=200,
                                                                                  seeds=(0,)))
           if variant.her]
    her_run, _ = run_sac_stage(runs.cache, her_task, her[0])
    return {"one_link_1m0-dense sac": runs.sac.path, "two_link-sparse sac+her": her_run.path}


@golden("occupancy", tolerance=ACTORS_TOLERANCE)
def _occupancy(runs: Runs) -> dict[str, Path]:
    from taskcomplexity.rl.curves import ACTORS_FILE
    from taskcomplexity.stages.occupancy_stage import OccupancySettings, run_occupancy_stage

    settings = OccupancySettings(policies=4, episodes=1, pairs=20, resamples=10, batches=2)
    artefact, _ = run_occupancy_stage(runs.cache, runs.returns[0], runs.sac.key, runs.sac.path / ACTORS_FILE,
                                      settings)
    return {"one_link_1m0-dense": artefact.path}


@golden("learning_path", tolerance=ACTORS_TOLERANCE)
def _learning_path(runs: Runs) -> dict[str, Path]:
    from taskcomplexity.rl.curves import ACTORS_FILE
    from taskcomplexity.stages.learning_path_stage import LearningPathSettings, run_learning_path_stage

    settings = LearningPathSettings(policies=4, episodes=2, bins=4, batches=2)
    artefact, _ = run_learning_path_stage(runs.cache, runs.returns[0], runs.sac.key, runs.sac.path / ACTORS_FILE,
                                          settings, runs.estimators)
    return {"one_link_1m0-dense": artefact.path}


@golden("verdict", inputs=("rwg", "metrics", "diagnostics"))
def _verdict(runs: Runs) -> dict[str, Path]:
    """The verdict of a three-task study on its metrics and diagnostics (no SAC: its inputs are those three)."""
    from taskcomplexity.cli import CONF_DIR
    from taskcomplexity.stages.diagnostics_stage import run_diagnostics_stage
    from taskcomplexity.stages.metrics_stage import run_metrics_stage
    from taskcomplexity.stages.verdict_stage import run_verdict_stage
    from taskcomplexity.study_data import load_study_file
    from taskcomplexity.tasks.spec import task_from_id

    study = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
    ids = ("one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense")
    per_task = {i: runs.rwg(task_from_id(i), 16, 4)[1] for i in ids}
    verdict, _ = run_verdict_stage(
        runs.cache, study, {i: run_metrics_stage(runs.cache, a, runs.estimators)[0] for i, a in per_task.items()},
        diagnostics={i: run_diagnostics_stage(runs.cache, a, runs.estimators, runs.diagnostics)[0]
                     for i, a in per_task.items()})
    return {"three tasks": verdict.path}


def declared_stages() -> tuple[str, ...]:
    """Every stage of a study's chain, in order, read from the stage records (the verdict last)."""
    from taskcomplexity.study.chain import CHAIN

    return tuple(stage.name for stage in CHAIN)


class GoldenRuns(Mapping[str, Golden]):
    """Every golden run (:data:`CASES`, in chain order), each computed on first access in one cache under
    ``root`` with numba, BLAS/OpenMP and torch on one thread; the stages a run reads are computed through the
    cache as far as it needs them."""

    def __init__(self, root: Path) -> None:
        self._root = Path(root)
        self._done: dict[str, Golden] = {}
        self._runs: Runs | None = None

    def __getitem__(self, stage: str) -> Golden:
        if stage not in self._done:
            if stage not in CASES:
                raise KeyError(f"stage {stage!r} has no golden run (those with one: {', '.join(self)})")
            from taskcomplexity.study.chain import CHAIN

            records = {record.name: record for record in CHAIN}
            if stage not in records:
                raise KeyError(f"stage {stage!r} has a golden run but no stage record (declared: "
                               f"{', '.join(records)})")
            case = CASES[stage]
            inputs = records[stage].inputs if case.inputs is None else case.inputs
            with one_thread():
                if self._runs is None:
                    self._runs = Runs(self._root)
                values = {name: artefact_values(path) for name, path in case.run(self._runs).items()}
            self._done[stage] = Golden(stage, records[stage].numerics.version,
                                       {s: records[s].numerics.version for s in inputs}, values, case.tolerance)
        return self._done[stage]

    def __contains__(self, stage: object) -> bool:
        return stage in CASES

    def __iter__(self) -> Iterator[str]:
        order = {stage: i for i, stage in enumerate(declared_stages())}
        return iter(sorted(CASES, key=lambda stage: order.get(stage, len(order))))

    def __len__(self) -> int:
        return len(CASES)


def run_all(root: Path, stages=None) -> dict[str, Golden]:
    """The golden runs of ``stages`` (default: every stage that has one) in a fresh cache under ``root``."""
    runs = GoldenRuns(root)
    return {stage: runs[stage] for stage in (runs if stages is None else stages)}


def recorded() -> dict[str, dict]:
    return json.loads(RECORDS.read_text(encoding="utf-8")) if RECORDS.exists() else {}


def recorded_values(stage: str, entry: dict | None) -> dict[str, Values] | None:
    """The recorded values of ``stage`` (None: it has no record ``entry``)."""
    return None if entry is None else load_values(values_file(stage))


def disagreement(golden: Golden, cases: dict[str, Values] | None) -> str | None:
    """The first recorded case whose values disagree now, and how (None: every recorded value agrees)."""
    if cases is None:
        return "nothing is recorded"
    gone = sorted(set(cases) - set(golden.values))
    if gone:
        return f"its recorded cases {gone} are gone (its cases are {sorted(golden.values)})"
    for case, recorded_values_ in cases.items():
        differs = difference(golden.values[case], recorded_values_, golden.tolerance)
        if differs:
            return f"case {case}, {differs}"
    return None


def additions(golden: Golden, cases: dict[str, Values] | None) -> list[str]:
    """What a stage's golden run holds that is not recorded: its new cases, and each case's new files, columns and
    tidy rows (:func:`recorded_part`). None of it fails a comparison; :func:`unrecorded_note` reports it."""
    if cases is None:
        return []
    new = [f"case {case}" for case in golden.values if case not in cases]
    return new + [f"{case} › {name}" for case, values in golden.values.items() if case in cases
                  for name in recorded_part(values, cases[case])[1]]


def unrecorded_note(stage: str, added: list[str]) -> str:
    """One line naming what ``stage``'s golden run holds that is not recorded, and the command that records it."""
    shown = ", ".join(added[:8]) + (f" and {len(added) - 8} more" if len(added) > 8 else "")
    return (f"stage {stage}'s golden run holds values that are not recorded ({shown}): they are not compared "
            f"until you record them with `{RECORD} {stage}`")


def unrecorded_stage(stage: str, then: dict[str, dict]) -> str | None:
    """Why ``stage`` cannot be compared at all (None: it can): a declared stage with no golden run here, or a
    golden run with no record."""
    if stage not in CASES:
        return (f"stage {stage} has no golden run: declare one with @golden({stage!r}) in tests/golden/"
                f"golden_runs.py and record it with `{RECORD} {stage}`")
    if stage not in then:
        return f"stage {stage} has no recorded golden run: record it with `{RECORD} {stage}`"
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

    def values_of(s: str) -> dict[str, Values] | None:
        return values[s] if values is not None else recorded_values(s, then.get(s))

    differs = disagreement(golden, values_of(stage))
    if differs is None:
        return None
    upstream = [s for s in golden.inputs if s in now and disagreement(now[s], values_of(s))]
    if upstream:
        return f"stage {stage}'s inputs ({', '.join(upstream)}) changed their numbers: see their failures first"
    return (f"stage {stage}'s numbers changed without a version bump ({differs}): bump NUMERICS.version in "
            f"{module} (name the change in the commit) and re-record with `{RECORD} {stage}`; if the change was "
            "not meant, a refactor changed the numbers")


def record(now: dict[str, Golden], stages: list[str]) -> None:
    """Write the values and records of ``stages``."""
    then = recorded()
    for stage in stages:
        save_values(values_file(stage), now[stage].values)
        then[stage] = now[stage].entry()
    RECORDS.write_text(json.dumps(dict(sorted(then.items())), indent=2) + "\n", encoding="utf-8")


def orphans(then: dict[str, dict]) -> list[str]:
    """Recorded stages that have no golden run any more (their record must go with them, or the run come back)."""
    return [stage for stage in then if stage not in CASES]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--record", action="store_true", help="write the values of the stages named (default all)")
    parser.add_argument("stages", nargs="*", help="stages to record (default: every stage with a golden run)")
    args = parser.parse_args(argv)
    unknown = set(args.stages) - set(CASES)
    if unknown:
        parser.error(f"stages without a golden run: {sorted(unknown)} (with one: {', '.join(CASES)})")
    with tempfile.TemporaryDirectory(prefix="golden-") as root:
        now = GoldenRuns(Path(root))
        if args.record:
            chosen = args.stages or list(now)
            record({stage: now[stage] for stage in chosen}, chosen)
            print(f"recorded {', '.join(chosen)} in {VALUES}")
            return 0
        then = recorded()
        failures = [f"stage {s} is recorded but has no golden run: restore it, or remove its record from "
                    f"{RECORDS.name} and its values" for s in orphans(then)]
        notes = []
        for stage in args.stages or declared_stages():
            missing = unrecorded_stage(stage, then)
            if missing:
                notes.append(missing)
            elif (found := problem(stage, now, then)) is not None:
                failures.append(found)
            elif added := additions(now[stage], recorded_values(stage, then[stage])):
                notes.append(unrecorded_note(stage, added))
    print("\n".join([*failures, *notes]) or "every stage's numbers agree with the record")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
