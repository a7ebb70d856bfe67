"""Each stage's numbers at fixed tiny settings are those recorded at its version (``golden_runs.py``).

A change of a stage's numbers without a bump of its ``NUMERICS.version`` fails here, naming the stage, the
column and the size of the change; a refactor that keeps the numbers passes, and keeps every cache key
(``tests/stages/test_keys.py``). The numbers of a CPU's vector kernels (AVX2 or AVX-512) are the same numbers
within ``golden_runs.TOLERANCE``: CI runs this file on both paths (``tests/cpu_paths.py``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from golden_runs import (
    CPU_DEPENDENT,
    TOLERANCE,
    Golden,
    artefact_values,
    cpu_kind,
    difference,
    disagreement,
    load_values,
    problem,
    recorded,
    run_all,
    save_values,
    unrecorded_cpu,
)

STAGES = ("rwg", "metrics", "diagnostics", "primitives", "sac", "occupancy", "learning_path", "verdict")


@pytest.fixture(scope="module")
def now(tmp_path_factory):
    return run_all(tmp_path_factory.mktemp("golden"))


@pytest.mark.parametrize("stage", STAGES)
def test_a_stages_numbers_are_those_recorded_at_its_version(now, stage):
    assert set(now) == set(STAGES) == set(recorded()), "every stage has one golden run, recorded"
    unrecorded = unrecorded_cpu(stage, recorded())
    if unrecorded:
        pytest.skip(unrecorded)
    message = problem(stage, now, recorded())
    assert message is None, message


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
    kind = cpu_kind()
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
    # a CPU-dependent stage is compared with its own CPU kind's record, never with another kind's
    elsewhere = {**record, "sac": {**record["sac"], "cpu_kinds": ["AVX512 SomeVendor"]}}
    assert problem("sac", now, elsewhere, values) == unrecorded_cpu("sac", elsewhere) != None  # noqa: E711
    assert "recorded for AVX512 SomeVendor, not for this CPU" in unrecorded_cpu("sac", elsewhere)
    assert set(CPU_DEPENDENT) < set(STAGES) and unrecorded_cpu("rwg", elsewhere) is None
    # recording keeps the other kinds at the same versions, and drops them when the version moves
    assert set(now["sac"].entry(elsewhere["sac"])["cpu_kinds"]) == {kind, "AVX512 SomeVendor"}
    bumped_sac = Golden("sac", now["sac"].version + 1, now["sac"].inputs, now["sac"].values)
    assert bumped_sac.entry(elsewhere["sac"])["cpu_kinds"] == [kind]
