"""Start-up: how long a command takes that does no work, a refused one and ``--help``, whole process, median of runs.

A refused command (``pipelines/study.py rwg.policies=-1``: Hydra composes the config, the study's plan reads its
settings and refuses the first bad one) and ``pipelines/study.py --help`` are timed from outside, as a shell runs
them: wall seconds from start to exit, and CPU seconds (user + system) of the process from the operating system's
own accounting. The interpreter's bare start (``python -c pass``) is the floor under both. Each line gives the
median of ``--repeats`` runs after one untimed run (which fills the file cache), and their min and max; the goal is
1 s of wall time for each, on an otherwise idle machine (other load lengthens the wall time, not the CPU time).

    .venv/bin/python bench/bench_startup.py               # 11 runs of each
    .venv/bin/python bench/bench_startup.py --repeats 5
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = str(ROOT / "pipelines" / "study.py")
COMMANDS = {
    "refused (rwg.policies=-1)": [sys.executable, STUDY, "rwg.policies=-1"],
    "--help": [sys.executable, STUDY, "--help"],
    "python -c pass (floor)": [sys.executable, "-c", "pass"],
}
"""What is timed: name → command."""
GOAL_SECONDS = 1.0


def timed(command: list[str], outputs: str) -> tuple[float, float, int]:
    """(wall s, CPU s, exit status) of one run of ``command``, its outputs under ``outputs``."""
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"} | {"TASKCOMPLEXITY_OUTPUTS": outputs}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(command, cwd=outputs, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=11, help="timed runs of each command (after one untimed run)")
    args = parser.parse_args()
    print(f"start-up of the commands, median of {args.repeats} runs (min … max), load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"{'command':<28}{'wall s':>8}{'(min … max)':>16}{'CPU s':>8}{'(min … max)':>16}{'exit':>6}  goal")
    with tempfile.TemporaryDirectory(prefix="taskcomplexity-bench-startup-") as outputs:
        for name, command in COMMANDS.items():
            timed(command, outputs)
            runs = [timed(command, outputs) for _ in range(args.repeats)]
            walls, cpus, codes = zip(*runs, strict=True)
            wall, cpu = statistics.median(walls), statistics.median(cpus)
            goal = "" if "floor" in name else ("met" if wall <= GOAL_SECONDS else f"over {GOAL_SECONDS:.0f} s")
            print(f"{name:<28}{wall:8.2f}{f'({min(walls):.2f} … {max(walls):.2f})':>16}{cpu:8.2f}"
                  f"{f'({min(cpus):.2f} … {max(cpus):.2f})':>16}{'/'.join(sorted({str(c) for c in codes})):>6}  {goal}",
                  flush=True)


if __name__ == "__main__":
    main()
