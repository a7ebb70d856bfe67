"""Each backend against its floor: the line a bench script prints per measurement, and ``make bench``'s summary of them.

A script that measures an RWG backend against its floor prints one machine-readable line per backend, task family and
task, on the CPU path it runs on (:func:`cpu_path`)::

    floor: backend=envpool family=mujoco task=Hopper-v5 path=native ratio=2.08 busy=0.89

``ratio`` is the backend's CPU per environment step over its floor's (×floor), ``busy`` (where the script measures it)
CPU-s / wall-s / usable cores of the backend's run. :data:`FLOORS` says, once, what the floor of each backend on each
family is; ``bench/run.py`` runs the scripts natively and again on the AVX2 path (``tests/cpu_paths.py``), collects
the lines of both (:func:`collect`) and prints :func:`summary`: one row per :data:`FLOORS` entry, a figure missing
from the run shown as missing, never filled in.
"""

from __future__ import annotations

import os
import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

PREFIX = "floor:"
PATHS = ("native", "AVX2")
"""The CPU paths, in the summary's order: the machine's own, and the AVX2 path of an AVX-512 machine."""


@dataclass(frozen=True)
class Floor:
    """What a backend's ×floor on a task family is measured against, and by which script."""

    backend: str
    family: str
    floor: str
    script: str
    goal: str = ""
    part: str = ""
    """What the line's ``part`` measures: a part of the distance to the floor, as ×floor (empty: none)."""


FLOORS: tuple[Floor, ...] = (
    Floor("kernel", "classic-control", "the forward pass alone on the kernel's batch (N × M rows of the same "
          "policies, no physics), CPU per row", "bench_classic"),
    Floor("batched", "reaching-arms", "the fused kernel's parts alone on 256 contiguous environments: the forward "
          "pass's MACs at NumPy's one-thread matmul rate + physics + obs/reward (contact-free tasks)",
          "bench_kernel_split"),
    Floor("pybullet", "reaching-arms", "bare stepSimulation × substeps on the same PyBullet world, random torques, "
          "one process", "bench_rwg"),
    Floor("envpool", "mujoco", "bare mj_step × frame skip (gymnasium's mujoco), uniform random controls, net of "
          "making the pools", "bench_mujoco", "≤ 1.3×, ≥ 90 % busy",
          "EnvPool alone: its pool stepped on random actions, no policy"),
    Floor("gym", "mujoco", "bare mj_step × frame skip, all cores' run net of env setup", "bench_mujoco", "",
          "gymnasium.make().step in a plain loop, one env"),
    Floor("gym", "user-env", "a bare loop of one env's step() on random actions, all cores' run net of env setup",
          "bench_gym", "≤ 1.3×, ≥ 90 % busy", "the same loop over the envs one process keeps in flight, in turn"),
    Floor("vector", "user-env", "the vector env's own step() on random actions, as many environments as one "
          "process keeps in flight, all cores' run", "bench_gym"),
)
"""Every backend × task family a bench script measures against its floor, in the summary's order."""

LINE = re.compile(r"^floor: (backend=.*)$", flags=re.MULTILINE)
"""A floor line (a script's table rows that begin with ``floor:`` name no backend)."""
FIELD = re.compile(r"(\w+)=(\S+)")


def cpu_path() -> str:
    """``AVX2`` in a process that ``tests/cpu_paths.py``'s :func:`avx2_environment` put on the AVX2 path, else
    ``native`` (an AVX2 machine's native path is its AVX2 path, and is called native)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
    from cpu_paths import AVX2_TARGET

    avx2 = os.environ.get("NUMBA_CPU_NAME") == AVX2_TARGET and os.environ.get("ATEN_CPU_CAPABILITY") == "avx2"
    return "AVX2" if avx2 else "native"


def line(backend: str, family: str, task: str, ratio: float, busy: float | None = None,
         part: float | None = None) -> str:
    """The machine-readable line of one measurement on this process's CPU path (``busy``: a share of the cores;
    ``part``: the ×floor of the part of the distance that :attr:`Floor.part` names)."""
    fields = f"backend={backend} family={family} task={task} path={cpu_path()} ratio={ratio:.3f}"
    return (f"{PREFIX} {fields}" + ("" if busy is None else f" busy={busy:.3f}")
            + ("" if part is None else f" part={part:.3f}"))


def report(backend: str, family: str, task: str, ratio: float, busy: float | None = None,
           part: float | None = None) -> None:
    """Print :func:`line`."""
    print(line(backend, family, task, ratio, busy, part), flush=True)


def collect(outputs: list[str]) -> list[dict]:
    """Every floor line of the scripts' ``outputs``: dicts of backend, family, task, path, ratio and busy (None where
    the line has none). A line whose fields do not parse is skipped."""
    found = []
    for output in outputs:
        for match in LINE.finditer(output):
            fields = dict(FIELD.findall(match.group(1)))
            try:
                found.append({"backend": fields["backend"], "family": fields["family"], "task": fields["task"],
                              "path": fields["path"], "ratio": float(fields["ratio"]),
                              "busy": float(fields["busy"]) if "busy" in fields else None,
                              "part": float(fields["part"]) if "part" in fields else None})
            except (KeyError, ValueError):
                continue
    return found


def _figure(values: list[float], percent: bool = False) -> str:
    """The median of ``values`` and, over several tasks, their range; ``missing`` for none."""
    if not values:
        return "missing"
    show = (lambda v: f"{v:.0%}") if percent else (lambda v: f"{v:.2f}")
    middle = show(statistics.median(values))
    return middle if len(values) == 1 else f"{middle} ({show(min(values))}–{show(max(values))})"


MAX_TASKS_NAMED = 6
"""A row names its tasks up to this many, else counts them (each script's output names every task's figure)."""


def rows(found: list[dict]) -> list[dict[str, str]]:
    """One row per :data:`FLOORS` entry (then any backend × family the lines name that it lacks): the floor, ×floor
    and cores busy on each path (median over tasks, their range), the tasks, the goal."""
    declared = {(f.backend, f.family): f for f in FLOORS}
    extra = {(r["backend"], r["family"]) for r in found} - declared.keys()
    table = []
    for key in [*declared, *sorted(extra)]:
        entry = declared.get(key)
        mine = [r for r in found if (r["backend"], r["family"]) == key]
        row = {"backend": key[0], "family": key[1],
               "floor": entry.floor if entry else "not declared in bench/floors.py"}
        for path in PATHS:
            on = [r for r in mine if r["path"] == path]
            row[f"×floor {path}"] = _figure([r["ratio"] for r in on])
            busy = [r["busy"] for r in on if r["busy"] is not None]
            row[f"busy {path}"] = _figure(busy, percent=True) if busy else ("missing" if not on else "not measured")
        tasks = list(dict.fromkeys(r["task"] for r in mine))
        row["tasks"] = (", ".join(tasks) if len(tasks) <= MAX_TASKS_NAMED else f"{len(tasks)}") or "missing"
        row["goal"] = entry.goal if entry and entry.goal else "—"
        parts = {path: [r["part"] for r in mine if r["path"] == path and r["part"] is not None] for path in PATHS}
        row["of which"] = (f"{entry.part}: " + ", ".join(f"{path} {_figure(parts[path])}" for path in PATHS)
                           if entry and entry.part else "—")
        table.append(row)
    return table


COLUMNS = ("backend", "family", "×floor native", "×floor AVX2", "busy native", "busy AVX2", "goal", "of which",
           "tasks", "floor")


def summary(found: list[dict]) -> str:
    """The Markdown table of :func:`rows` (it reads as text on a console too)."""
    table = rows(found)
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "|".join("---:" if "floor " in c or "busy" in c else "---"
                                                              for c in COLUMNS) + "|"]
    lines += ["| " + " | ".join(row[c] for c in COLUMNS) + " |" for row in table]
    return "\n".join(lines)


HEADING = ("×floor: the backend's CPU per environment step over its floor's (median over the tasks, their range); "
           "busy: CPU-s / wall-s / usable cores of the backend's run; of which: the ×floor of a part of the distance, "
           "measured in the same run; missing: not measured in this run. Each script "
           "ran natively and, right after, on the AVX2 path (tests/cpu_paths.py); each ratio is measured within one "
           "run, its two sides interleaved.")
