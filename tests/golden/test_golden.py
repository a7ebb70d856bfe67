"""Each stage's numbers at fixed tiny settings are those recorded at its version (``golden_runs.py``).

A change of a stage's numbers without a bump of its ``NUMERICS.version`` fails here, naming the stage; a
refactor that keeps the numbers passes, and keeps every cache key (``tests/stages/test_keys.py``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from golden_runs import Golden, numbers_digest, problem, recorded, rounded, run_all

STAGES = ("rwg", "metrics", "diagnostics", "primitives", "sac", "occupancy", "learning_path", "verdict")


@pytest.fixture(scope="module")
def now(tmp_path_factory):
    return run_all(tmp_path_factory.mktemp("golden"))


@pytest.mark.parametrize("stage", STAGES)
def test_a_stages_numbers_are_those_recorded_at_its_version(now, stage):
    assert set(now) == set(STAGES) == set(recorded()), "every stage has one golden run, recorded"
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
    changed = {**record, "sac": {**record["sac"], "sha256": {**record["sac"]["sha256"],
                                                             "one_link_1m0-dense sac": "0" * 64}}}
    assert problem("sac", now, changed) == (
        "stage sac's numbers changed without a version bump (cases: one_link_1m0-dense sac): bump NUMERICS.version "
        "in src/taskcomplexity/stages/sac_stage.py (name the change in the commit) and re-record with "
        "`PYTHONPATH=src python tests/golden/golden_runs.py --record sac`; if the change was not meant, a refactor "
        "changed the numbers")
    assert problem("occupancy", now, changed) is None  # its own numbers are as recorded
    both = {**changed, "occupancy": {**record["occupancy"], "sha256": {"one_link_1m0-dense": "1" * 64}}}
    assert problem("occupancy", now, both) == ("stage occupancy's inputs (sac) changed their numbers: see their "
                                               "failures first")
    bumped = {**record, "rwg": {**record["rwg"], "version": now["rwg"].version - 1}}
    assert problem("rwg", now, bumped).startswith(f"stage rwg's version moved ({now['rwg'].version - 1} → ")
    assert "re-record" in problem("rwg", now, bumped)
    upstream = {**record, "metrics": {**record["metrics"], "inputs": {"rwg": 0}}}
    assert "stage metrics's inputs moved version" in problem("metrics", now, upstream)
    assert "no recorded golden run" in problem("verdict", now, {k: e for k, e in record.items() if k != "verdict"})
    assert isinstance(now["rwg"], Golden) and len(now["rwg"].sha256) == 6
