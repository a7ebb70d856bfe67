"""``make bench``'s table of each backend against its floor (``bench/floors.py``, ``bench/run.py``), on canned output.

The figures are the scripts' own ``floor:`` lines, collected from both CPU paths; these tests hold the parsing and the
table together, so that a renamed field or a moved line shows as a failure here, not as a silently missing column.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench"

NATIVE_MUJOCO = """\
Hopper-v5: frame_skip 4, 3 actuators
path                                         steps  CPU-µs/step  ×floor
floor: mj_step ×4                            5,000         20.0    1.00
floor, policies' actions                     5,000         21.0    1.05
goal (rwg within 1.3× of the floor per step, all 2 cores busy): CPU ×floor 2.08 (> 1.3): not met
floor: backend=gym family=mujoco task=Hopper-v5 path=native ratio=3.100 busy=0.950
floor: backend=envpool family=mujoco task=Hopper-v5 path=native ratio=2.080 busy=0.890 part=1.340
floor: backend=gym family=mujoco task=Ant-v5 path=native ratio=2.900 busy=0.910
floor: backend=envpool family=mujoco task=Ant-v5 path=native ratio=1.900 busy=0.700 part=1.360
floor: backend=envpool family=mujoco task=Walker2d-v5 path=native ratio=2.000 busy=0.800
"""
AVX2_MUJOCO = """\
floor: backend=envpool family=mujoco task=Hopper-v5 path=AVX2 ratio=2.500 busy=0.910
floor: backend=gym family=mujoco task=Hopper-v5 path=AVX2 ratio=3.300 busy=0.960
"""
NATIVE_RWG = """\
one_link_1m0-dense            2,310      383.1    141.8    2.70
floor: backend=pybullet family=reaching-arms task=one_link_1m0-dense path=native ratio=2.702
floor: backend=pybullet family=reaching-arms task=two_link-sparse path=native ratio=ratio-is-not-a-number
floor: backend=toy family=classic-control task=CartPole-v1 path=native ratio=1.500
"""


@pytest.fixture
def bench(monkeypatch):
    """``bench/floors.py`` and ``bench/run.py`` imported as the scripts import them (bench/ on the path)."""
    monkeypatch.syspath_prepend(str(BENCH))
    import floors

    spec = importlib.util.spec_from_file_location("bench_run", BENCH / "run.py")
    run = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "bench_run", run)  # its dataclasses look their module up
    spec.loader.exec_module(run)
    return floors, run


def row_of(rows: list[dict], backend: str, family: str) -> dict:
    [row] = [r for r in rows if (r["backend"], r["family"]) == (backend, family)]
    return row


def test_lines_are_collected_and_the_table_rows_ignored(bench):
    floors, _ = bench
    found = floors.collect([NATIVE_MUJOCO, AVX2_MUJOCO, NATIVE_RWG])
    # the table rows that begin with "floor:" and the line whose ratio is not a number are not figures
    assert len(found) == 9
    assert found[0] == {"backend": "gym", "family": "mujoco", "task": "Hopper-v5", "path": "native", "ratio": 3.1,
                        "busy": 0.95, "part": None}
    assert [r["part"] for r in found if r["backend"] == "envpool"] == [1.34, 1.36, None, None]
    assert {r["task"] for r in found if r["backend"] == "pybullet"} == {"one_link_1m0-dense"}
    assert [r["busy"] for r in found if r["backend"] == "pybullet"] == [None]


def test_the_table_has_both_paths_and_shows_what_is_missing(bench):
    floors, _ = bench
    rows = floors.rows(floors.collect([NATIVE_MUJOCO, AVX2_MUJOCO, NATIVE_RWG]))
    envpool = row_of(rows, "envpool", "mujoco")
    # native: the median of three tasks and their range; AVX2: one task, its figure alone
    assert envpool["×floor native"] == "2.00 (1.90–2.08)"
    assert envpool["×floor AVX2"] == "2.50"
    assert envpool["busy native"] == "80% (70%–89%)"
    assert envpool["busy AVX2"] == "91%"
    assert envpool["tasks"] == "Hopper-v5, Ant-v5, Walker2d-v5"
    assert envpool["goal"] == "≤ 1.3×, ≥ 90 % busy"
    assert "mj_step" in envpool["floor"]
    # the part of the distance measured beside it: two tasks natively, none on the AVX2 path
    assert envpool["of which"] == ("EnvPool alone: its pool stepped on random actions, no policy: native 1.35 "
                                   "(1.34–1.36), AVX2 missing")
    assert row_of(rows, "pybullet", "reaching-arms")["of which"] == "—"  # its floor declares no part
    pybullet = row_of(rows, "pybullet", "reaching-arms")
    assert (pybullet["×floor native"], pybullet["busy native"]) == ("2.70", "not measured")
    assert (pybullet["×floor AVX2"], pybullet["busy AVX2"]) == ("missing", "missing")
    kernel = row_of(rows, "kernel", "classic-control")  # declared, not in this run: missing, never invented
    assert [kernel[c] for c in ("×floor native", "×floor AVX2", "busy native", "busy AVX2", "tasks")] == ["missing"] * 5
    toy = row_of(rows, "toy", "classic-control")  # a line no FLOORS entry declares still shows, and says so
    assert toy["floor"] == "not declared in bench/floors.py" and toy["×floor native"] == "1.50"
    declared = [(f.backend, f.family) for f in floors.FLOORS]
    many = [f"floor: backend=kernel family=classic-control task=T{i} path=native ratio=1.0" for i in range(7)]
    assert row_of(floors.rows(floors.collect(many)), "kernel", "classic-control")["tasks"] == "7"  # counted
    assert [(r["backend"], r["family"]) for r in rows] == [*declared, ("toy", "classic-control")]


def test_the_summary_is_one_markdown_row_per_backend_and_family(bench):
    floors, _ = bench
    text = floors.summary(floors.collect([NATIVE_MUJOCO, AVX2_MUJOCO]))
    lines = text.splitlines()
    assert lines[0] == "| " + " | ".join(floors.COLUMNS) + " |"
    assert len(lines) == 2 + len(floors.FLOORS)
    assert all(line.count("|") == len(floors.COLUMNS) + 1 for line in lines)
    assert "| envpool | mujoco | 2.00 (1.90–2.08) | 2.50 | 80% (70%–89%) | 91% |" in text


def test_a_script_line_names_its_cpu_path(bench, monkeypatch):
    floors, _ = bench
    from cpu_paths import AVX2_TARGET

    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    native = floors.line("gym", "user-env", "point_mass", 1.234567, 0.5, part=1.1)
    assert native == ("floor: backend=gym family=user-env task=point_mass path=native ratio=1.235 busy=0.500 "
                      "part=1.100")
    monkeypatch.setenv("NUMBA_CPU_NAME", AVX2_TARGET)
    monkeypatch.setenv("ATEN_CPU_CAPABILITY", "avx2")
    avx2 = floors.line("kernel", "classic-control", "CartPole-v1/mlp32", 2.0)
    assert [(r["path"], r["ratio"], r["busy"]) for r in floors.collect([native, avx2])] == [
        ("native", 1.235, 0.5), ("AVX2", 2.0, None)]


def test_every_declared_floor_is_reported_by_its_script_and_run_on_both_paths(bench):
    floors, run = bench
    for floor in floors.FLOORS:
        source = (BENCH / f"{floor.script}.py").read_text()
        assert re.search(rf'report\(\s*"{floor.backend}",\s*"{floor.family}"', source), (
            f"bench/{floor.script}.py prints no floor line of {floor.backend} on {floor.family}")
        assert floor.script in run.AVX2_RUNS, f"bench/{floor.script}.py is not run again on the AVX2 path"
    assert all((BENCH / f"{name}.py").is_file() for name in run.AVX2_RUNS)


def test_the_page_holds_the_table_and_links_every_run(bench):
    _, run = bench
    results = [run.Result("bench_mujoco.py", ["bench/bench_mujoco.py"], NATIVE_MUJOCO, 10.0, 19.0, 0),
               run.Result("bench_mujoco.py on the AVX2 path", ["tests/cpu_paths.py", "--", "python",
                                                               "bench/bench_mujoco.py"], AVX2_MUJOCO, 11.0, 20.0, 0)]
    text = run.page({"date": "today"}, "bench/run.py --only mujoco", "Only bench_mujoco.py ran.", results, 21.0)
    assert "| [bench_mujoco.py on the AVX2 path](#bench_mujocopy-on-the-avx2-path) | 11.0 | 20.0 | 0 |" in text
    assert "| [bench_mujoco.py](#bench_mujocopy) |" in text
    assert "## bench_mujoco.py on the AVX2 path" in text
    assert "| envpool | mujoco | 2.00 (1.90–2.08) | 2.50 |" in text
    assert "| kernel | classic-control | missing | missing |" in text
