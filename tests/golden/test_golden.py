"""Each stage's numbers at fixed tiny settings are those recorded at its version (``golden_runs.py``).

A change of a stage's numbers without a bump of its ``NUMERICS.version`` fails here, naming the stage; a
refactor that keeps the numbers passes, and keeps every cache key (``tests/stages/test_keys.py``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from golden_runs import (
    CPU_DEPENDENT,
    Golden,
    cpu_kind,
    numbers_digest,
    problem,
    recorded,
    rounded,
    run_all,
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
    return numbers_digest(directory)


def test_the_digest_holds_values_and_names_not_file_bytes_nor_wall_clock(tmp_path):
    frame = pd.DataFrame({"return": [1.5, -2.25, np.nan], "steps": [3, 4, 5], "task": ["a", "b", "c"],
                          "time/seconds": [0.1, 0.2, 0.3]})
    base = _artefact(tmp_path / "base", frame)
    assert _artefact(tmp_path / "zstd", frame, compression="zstd") == base  # other file bytes, same values
    assert _artefact(tmp_path / "clock", frame.assign(**{"time/seconds": [9.0, 9.0, 9.0]})) == base
    assert _artefact(tmp_path / "last bit", frame.assign(**{"return": [1.5 * (1 + 2e-16), -2.25, np.nan]})) == base
    for name, other in {"a value": frame.assign(**{"return": [1.5 * (1 + 1e-9), -2.25, np.nan]}),
                        "an integer": frame.assign(steps=[3, 4, 6]), "a label": frame.assign(task=["a", "b", "d"]),
                        "a column name": frame.rename(columns={"steps": "length"}),
                        "the column order": frame[["steps", "return", "task", "time/seconds"]]}.items():
        assert _artefact(tmp_path / name, other) != base, name
    third = rounded(np.array([-0.0, np.nan, 1 / 3]))
    assert np.signbit(third[0]) == False and np.isnan(third[1])  # noqa: E712 - one zero, one NaN
    assert abs(third[2] - 1 / 3) <= 2.0**-37 and third[2] != 1 / 3  # 36 significant bits of 1/3 = 0.0101…


def test_the_verdict_of_a_comparison_names_the_cause(now):
    record = {s: g.entry() for s, g in now.items()}
    assert all(problem(s, now, record) is None for s in now)
    kind = cpu_kind()
    changed = {**record, "sac": {**record["sac"], "sha256": {kind: {**record["sac"]["sha256"][kind],
                                                                     "one_link_1m0-dense sac": "0" * 64}}}}
    assert problem("sac", now, changed) == (
        "stage sac's numbers changed without a version bump (cases: one_link_1m0-dense sac): bump NUMERICS.version "
        "in src/taskcomplexity/stages/sac_stage.py (name the change in the commit) and re-record with "
        "`PYTHONPATH=src python tests/golden/golden_runs.py --record sac`; if the change was not meant, a refactor "
        "changed the numbers")
    assert problem("occupancy", now, changed) is None  # its own numbers are as recorded
    both = {**changed, "occupancy": {**record["occupancy"], "sha256": {kind: {"one_link_1m0-dense": "1" * 64}}}}
    assert problem("occupancy", now, both) == ("stage occupancy's inputs (sac) changed their numbers: see their "
                                               "failures first")
    bumped = {**record, "rwg": {**record["rwg"], "version": now["rwg"].version - 1}}
    assert problem("rwg", now, bumped).startswith(f"stage rwg's version moved ({now['rwg'].version - 1} → ")
    assert "re-record" in problem("rwg", now, bumped)
    upstream = {**record, "metrics": {**record["metrics"], "inputs": {"rwg": 0}}}
    assert "stage metrics's inputs moved version" in problem("metrics", now, upstream)
    assert "no recorded golden run" in problem("verdict", now, {k: e for k, e in record.items() if k != "verdict"})
    assert isinstance(now["rwg"], Golden) and len(now["rwg"].sha256) == 6
    # a CPU-dependent stage is compared with its own CPU kind's record, never with another kind's
    elsewhere = {**record, "sac": {**record["sac"], "sha256": {"AVX512 SomeVendor": record["sac"]["sha256"][kind]}}}
    assert problem("sac", now, elsewhere) == unrecorded_cpu("sac", elsewhere) != None  # noqa: E711
    assert kind not in unrecorded_cpu("sac", elsewhere).split("recorded for ")[1].split(",")[0]
    assert set(CPU_DEPENDENT) < set(STAGES) and unrecorded_cpu("rwg", elsewhere) is None
    # recording keeps the other kinds at the same versions, and drops them when the version moves
    merged = now["sac"].entry(elsewhere["sac"])["sha256"]
    assert set(merged) == {kind, "AVX512 SomeVendor"}
    bumped_sac = dict(now)
    bumped_sac["sac"] = Golden("sac", now["sac"].version + 1, now["sac"].inputs, now["sac"].sha256)
    assert set(bumped_sac["sac"].entry(elsewhere["sac"])["sha256"]) == {kind}
