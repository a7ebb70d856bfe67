"""Each stage's numbers at fixed tiny settings are those recorded at its version (``golden_runs.py``).

A change of a stage's numbers without a bump of its ``NUMERICS.version`` fails here, naming the stage, the
column and the size of the change; a refactor that keeps the numbers passes, and keeps every cache key
(``tests/stages/test_keys.py``). One record holds for every CPU: the numbers of a CPU's kernels (AVX2 or
AVX-512, Intel or AMD) are the same numbers within ``golden_runs.TOLERANCE``, or within the wider tolerance of
the stages SAC's float32 training reaches (``TRAINING_TOLERANCE``, ``ACTORS_TOLERANCE``); CI runs this file on
both paths where the CPU has both (``tests/cpu_paths.py``).

The stages are read from the stage records. A declared stage without a golden run, or a golden run without a
record, is skipped with the line that says how to add or record it; values a golden run holds that are not
recorded (a new metric's columns and rows) fail nothing and are reported as a warning naming the command that
records them; a recorded value that is gone or changed fails.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from golden_runs import (
    ACTORS_TOLERANCE,
    CASES,
    RECORD,
    TOLERANCE,
    TRAINING_TOLERANCE,
    Golden,
    GoldenRuns,
    additions,
    artefact_values,
    declared_stages,
    difference,
    disagreement,
    load_values,
    orphans,
    problem,
    recorded,
    recorded_values,
    save_values,
    unrecorded_note,
    unrecorded_stage,
)

STAGES = declared_stages()
"""Every stage of the chain, read from the stage records."""


# The warning is a built-in UserWarning: pytest-xdist sends a worker's warnings to the controller by their class,
# which must be importable there, and a class of this test module is not (make test runs on workers).
@pytest.fixture(scope="module")
def now(tmp_path_factory):
    """Every golden run, each computed when a test first reads it (one stage's test runs what it reads only)."""
    return GoldenRuns(tmp_path_factory.mktemp("golden"))


def compare(stage: str, now, then: dict, values: dict | None = None) -> None:
    """Skip a stage that cannot be compared (no golden run, no record), fail one whose recorded values moved,
    and warn of the values its run holds that are not recorded. ``values``: the recorded values per stage (read
    from ``values/`` when None)."""
    missing = unrecorded_stage(stage, then)
    if missing:
        pytest.skip(missing)
    message = problem(stage, now, then, values)
    assert message is None, message
    added = additions(now[stage], values[stage] if values is not None else recorded_values(stage, then[stage]))
    if added:
        warnings.warn(unrecorded_note(stage, added), UserWarning, stacklevel=2)


@pytest.mark.parametrize("stage", STAGES)
def test_a_stages_numbers_are_those_recorded_at_its_version(now, stage):
    compare(stage, now, recorded())


def test_every_golden_run_is_a_declared_stage_and_every_record_has_its_run():
    assert set(CASES) <= set(STAGES), "a golden run of a stage no record declares"
    assert not orphans(recorded()), "a recorded stage without a golden run: restore it or remove its record"


def _reads_sac(stage: str) -> bool:
    """Whether ``stage``'s golden run reads SAC's output at any depth (its case's inputs, or its stage record's)."""
    from taskcomplexity.study.chain import CHAIN

    records = {record.name: record for record in CHAIN}
    case = CASES.get(stage)
    inputs = case.inputs if case is not None and case.inputs is not None else records[stage].inputs
    return stage == "sac" or any(_reads_sac(source) for source in inputs)


def test_the_wider_tolerances_are_those_of_the_stages_sacs_training_reaches():
    # SAC's float32 training moves last bits between CPUs (TRAINING_TOLERANCE), and the stages computed from its
    # actors inherit them (ACTORS_TOLERANCE); a stage its training reaches declares a tolerance, every other
    # stage keeps TOLERANCE (its values agree to ~1e-13 between CPUs)
    reaching = {stage for stage in CASES if _reads_sac(stage)}
    assert {"sac", "occupancy", "learning_path"} <= reaching
    assert "verdict" not in reaching  # its golden run judges the metrics and diagnostics only
    assert CASES["sac"].tolerance == TRAINING_TOLERANCE
    assert CASES["occupancy"].tolerance == CASES["learning_path"].tolerance == ACTORS_TOLERANCE
    assert all(CASES[stage].tolerance != TOLERANCE for stage in reaching)
    assert all(CASES[stage].tolerance == TOLERANCE for stage in set(CASES) - reaching)


def _artefact(directory, frame: pd.DataFrame, **parquet):
    directory.mkdir(exist_ok=True)
    frame.to_parquet(directory / "table.parquet", index=False, **parquet)
    return artefact_values(directory)


def test_values_are_compared_by_name_within_the_tolerance_not_by_file_bytes_nor_wall_clock(tmp_path):
    frame = pd.DataFrame({"return": [1.5, -2.25, np.nan], "excess": [3e-3, 0.0, -1e-14], "steps": [3, 4, 5],
                          "task": ["a", "b", "c"], "time/seconds": [0.1, 0.2, 0.3]})
    base = _artefact(tmp_path / "base", frame)
    assert difference(_artefact(tmp_path / "zstd", frame, compression="zstd"), base) is None  # other file bytes
    assert difference(_artefact(tmp_path / "clock", frame.assign(**{"time/seconds": [9.0, 9.0, 9.0]})), base) is None
    # the last bits a CPU's vector kernels move, and a difference of nearly equal values near zero
    last_bits = frame.assign(**{"return": [1.5 * (1 + 1e-13), -2.25, np.nan], "excess": [3e-3, 4e-15, -5e-15]})
    assert difference(_artefact(tmp_path / "last bits", last_bits), base) is None
    changes = {"a value": (frame.assign(**{"return": [1.5 * (1 + 1e-8), -2.25, np.nan]}),
                           "table.parquet › return: 1 of 3 values differ; value 0: 1.500000015 against the recorded "
                           "1.5 (relative difference 1e-08; the tolerance is 1e-09 relative + 1e-12)"),
               "a value near zero": (frame.assign(excess=[3e-3, 1e-11, -1e-14]), "table.parquet › excess: 1 of 3"),
               "a NaN": (frame.assign(**{"return": [1.5, np.nan, np.nan]}), "value 1: nan against the recorded -2.25"),
               "an integer": (frame.assign(steps=[3, 4, 6]), "table.parquet › steps: value 2 is 6 against the "
                              "recorded 5"),
               "a label": (frame.assign(task=["a", "b", "d"]), "table.parquet › task: value 2 is 'd'"),
               "a column name": (frame.rename(columns={"steps": "length"}), "recorded only: table.parquet › steps"),
               "the column order": (frame[["steps", "return", "excess", "task", "time/seconds"]],
                                    "its columns are in another order")}
    for name, (other, message) in changes.items():
        found = difference(_artefact(tmp_path / name, other), base)
        assert found is not None and found.startswith(message) if name == "a value" else message in found, name
    assert TOLERANCE.close(np.array([1e6 * (1 + 9e-10)]), np.array([1e6])).all()
    assert not TOLERANCE.close(np.array([1e6 * (1 + 2e-9)]), np.array([1e6])).any()


def test_recorded_values_round_trip_through_their_file(tmp_path, now):
    path = tmp_path / "values.npz"
    save_values(path, now["verdict"].values)
    loaded = load_values(path)
    assert disagreement(now["verdict"], loaded) is None
    assert all(a.dtype.kind != "O" for values in loaded.values() for a in values.values())  # no pickled objects


def test_the_verdict_of_a_comparison_names_the_cause(now):
    record = {s: g.entry() for s, g in now.items()}
    values = {s: g.values for s, g in now.items()}
    assert all(problem(s, now, record, values) is None for s in now)
    case = "one_link_1m0-dense sac"
    column = next(n for n, v in values["sac"][case].items() if v.dtype.kind == "f")
    moved = {**values["sac"][case], column: values["sac"][case][column] + 1.0}
    changed = {**values, "sac": {**values["sac"], case: moved}}
    message = problem("sac", now, record, changed)
    assert message.startswith(f"stage sac's numbers changed without a version bump (case {case}, {column}: ")
    assert message.endswith(
        "bump NUMERICS.version in src/taskcomplexity/stages/sac_stage.py (name the change in the commit) and "
        "re-record with `PYTHONPATH=src python tests/golden/golden_runs.py --record sac`; if the change was not "
        "meant, a refactor changed the numbers")
    assert problem("occupancy", now, record, changed) is None  # its own numbers are as recorded
    occupancy = next(iter(values["occupancy"]))
    both = {**changed, "occupancy": {occupancy: {n: v[::-1].copy() if v.dtype.kind == "f" else v
                                                 for n, v in values["occupancy"][occupancy].items()}}}
    assert problem("occupancy", now, record, both) == ("stage occupancy's inputs (sac) changed their numbers: see "
                                                       "their failures first")
    bumped = {**record, "rwg": {**record["rwg"], "version": now["rwg"].version - 1}}
    assert problem("rwg", now, bumped, values).startswith(f"stage rwg's version moved ({now['rwg'].version - 1} → ")
    assert "re-record" in problem("rwg", now, bumped, values)
    upstream = {**record, "metrics": {**record["metrics"], "inputs": {"rwg": 0}}}
    assert "stage metrics's inputs moved version" in problem("metrics", now, upstream, values)
    assert "no recorded golden run" in problem("verdict", now, {k: e for k, e in record.items() if k != "verdict"},
                                               values)
    assert isinstance(now["rwg"], Golden) and len(now["rwg"].values) == 6


def test_the_stages_sacs_training_reaches_pass_another_cpus_last_bits_and_fail_a_change(now):
    record = {s: g.entry() for s, g in now.items()}
    values = {s: g.values for s, g in now.items()}

    def moved(stage: str, change) -> dict:
        """The recorded values with every float of ``stage``'s first case changed by ``change``."""
        case = next(iter(values[stage]))
        cases = {case: {n: change(v) if v.dtype.kind == "f" else v for n, v in values[stage][case].items()}}
        return {**values, stage: {**values[stage], **cases}}

    # SAC's weights: 3e-7, the most two CPU kinds were measured apart (Intel AVX-512, Intel AVX2, AMD Zen 4 and Zen 3),
    # passes; 1e-5, a hundredth of one Adam step at the actor's learning rate of 1e-3, fails
    assert problem("sac", now, record, moved("sac", lambda v: v + 3e-7)) is None
    assert not TOLERANCE.close(np.array([0.1 + 3e-7]), np.array([0.1])).all()  # hence its own tolerance
    assert "numbers changed without a version bump" in problem("sac", now, record, moved("sac", lambda v: v + 1e-5))
    # the stages computed from its actors: 7e-9 relative, the most measured, passes; 1e-6 fails
    assert not TOLERANCE.close(np.array([1 + 7e-9]), np.array([1.0])).all()
    for stage in ("occupancy", "learning_path"):
        assert problem(stage, now, record, moved(stage, lambda v: v * (1 + 7e-9))) is None, stage
        message = problem(stage, now, record, moved(stage, lambda v: v * (1 + 1e-6)))
        assert "numbers changed without a version bump" in message and "1e-07 relative + 1e-12" in message, stage


def _tidy(directory, metrics: list[str], values: list[float]):
    """An artefact of a wide table (one column per metric) and a tidy one (one row per metric and task)."""
    directory.mkdir()
    pd.DataFrame({m: [v] for m, v in zip(metrics, values, strict=True)}).to_parquet(
        directory / "metrics.parquet", index=False)
    pd.DataFrame({"metric": [m for m in metrics for _ in (0, 1)], "task": ["a", "b"] * len(metrics),
                  "value": [v + t for v in values for t in (0.0, 1.0)]}).to_parquet(directory / "verdict.parquet",
                                                                                    index=False)
    return artefact_values(directory)


@pytest.fixture
def recorded_metrics(tmp_path):
    """A synthetic record of the metrics stage (two metrics) and the record's entry."""
    values = {"metrics": {"case": _tidy(tmp_path / "recorded", ["pic", "poic"], [0.5, 0.25])}}
    entry = Golden("metrics", 3, {"rwg": 1}).entry()
    return values, {"metrics": entry}


def _now(tmp_path, name, metrics, values) -> dict[str, Golden]:
    """The golden runs now: the metrics stage's run with ``metrics`` at ``values``."""
    return {"metrics": Golden("metrics", 3, {"rwg": 1}, {"case": _tidy(tmp_path / name, metrics, values)})}


def test_a_new_metrics_columns_and_rows_are_reported_with_the_record_command_and_fail_nothing(tmp_path,
                                                                                            recorded_metrics):
    values, then = recorded_metrics
    now = _now(tmp_path, "new metric", ["pic", "poic", "best"], [0.5, 0.25, 7.0])
    assert difference(now["metrics"].values["case"], values["metrics"]["case"]) is None
    assert additions(now["metrics"], values["metrics"]) == [
        "case › verdict.parquet › rows of metric best", "case › metrics.parquet › best"]
    with pytest.warns(UserWarning, match=r"stage metrics's golden run holds values that are not recorded "
                      r"\(case › verdict.parquet › rows of metric best, case › metrics.parquet › best\): they are "
                      r"not compared until you record them with `PYTHONPATH=src python tests/golden/golden_runs.py "
                      r"--record metrics`"):
        compare("metrics", now, then, values)
    # a new case is reported the same way
    with_case = {"metrics": Golden("metrics", 3, {"rwg": 1}, {**now["metrics"].values, "other": {}})}
    assert additions(with_case["metrics"], values["metrics"])[0] == "case other"


def test_a_recorded_column_or_row_that_changes_or_is_gone_fails(tmp_path, recorded_metrics):
    values, then = recorded_metrics
    changed = _now(tmp_path, "changed", ["pic", "poic", "best"], [0.5, 0.25 * (1 + 1e-6), 7.0])
    with pytest.raises(AssertionError, match=r"numbers changed without a version bump \(case case, "
                                             r"metrics.parquet › poic: 1 of 1 values differ"):
        compare("metrics", changed, then, values)
    gone = _now(tmp_path, "gone", ["pic", "best"], [0.5, 7.0])
    with pytest.raises(AssertionError, match=r"recorded files or columns are gone \(recorded only: "
                                             r"metrics.parquet › poic\)"):
        compare("metrics", gone, then, values)
    # a recorded metric's tidy rows: one of them gone is a change of shape, not a new metric
    rows = {n: (v[:3] if n.startswith("verdict") else v) for n, v in values["metrics"]["case"].items()}
    short = {"metrics": Golden("metrics", 3, {"rwg": 1}, {"case": rows})}
    with pytest.raises(AssertionError, match=r"verdict.parquet › metric: shape \(3,\)"):
        compare("metrics", short, then, values)
    lost = {"metrics": Golden("metrics", 3, {"rwg": 1}, {})}
    with pytest.raises(AssertionError, match=r"its recorded cases \['case'\] are gone"):
        compare("metrics", lost, then, values)


def test_a_stage_without_a_golden_run_or_a_record_is_skipped_with_what_to_do(recorded_metrics):
    values, then = recorded_metrics
    with pytest.raises(pytest.skip.Exception, match=r"stage unheard_of has no golden run: declare one with "
                       r"@golden\('unheard_of'\) in tests/golden/golden_runs.py and record it with "
                       r"`PYTHONPATH=src python tests/golden/golden_runs.py --record unheard_of`"):
        compare("unheard_of", {}, then, values)
    with pytest.raises(pytest.skip.Exception, match=r"stage verdict has no recorded golden run: record it with "
                       r"`PYTHONPATH=src python tests/golden/golden_runs.py --record verdict`"):
        compare("verdict", {}, then, values)
    assert RECORD.endswith("--record") and orphans({"unheard_of": {}}) == ["unheard_of"]
