"""The report's figures: what writing one costs, :func:`~taskcomplexity.report.figures.save_figure` beside
matplotlib's usual way of saving a laid-out figure.

The figure is a study's RWG trios (figure (a): one row of three panels per task, the report's largest figure) of
``--tasks`` tasks, drawn from random returns of ``--policies`` × ``--episodes``. Each way writes the PNG (150 dpi)
and the PDF from a figure drawn afresh, its ticks made legible first (:func:`~taskcomplexity.report.figures.
legible_ticks`, which lays the figure out once more for each change it makes):

- ``save_figure``: both files at the bounding box of legible_ticks' last layout, no layout engine while they are
  written: ``savefig`` draws each file once.
- ``savefig, tight``: ``savefig(bbox_inches="tight")``, the layout engine held off as well: ``savefig`` draws each
  file twice (once to find the box, then the file).

Each line gives the median CPU seconds of ``--repeats`` runs (this process; min and max beside) and the wall
seconds; the last line the ratio of the medians. The PNGs of the two ways are compared pixel by pixel.

    .venv/bin/python bench/bench_report.py                       # 7 tasks (make run's study), N = 10 × M = 4
    .venv/bin/python bench/bench_report.py --policies 10000 --episodes 500
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import matplotlib.image
import numpy as np

from taskcomplexity.metrics import policy_statistics
from taskcomplexity.report.figures import DPI, legible_ticks, paper_style, rwg_trios_figure, save_figure
from taskcomplexity.report.labels import TaskStyle


def trios(tasks: int, policies: int, episodes: int):
    """The RWG trios figure of ``tasks`` tasks of random returns (seeded: every repeat draws the same figure)."""
    rng = np.random.default_rng(0)
    returns = {f"task{i}": rng.normal(-100.0 * (i + 1), 30.0, (policies, episodes)) for i in range(tasks)}
    styles = {task: TaskStyle(task, task, task, None, f"C{i % 10}", "o") for i, task in enumerate(returns)}
    return rwg_trios_figure({t: policy_statistics(r) for t, r in returns.items()}, styles, returns=returns)


def savefig_tight(figure, directory: Path, name: str) -> list[Path]:
    """Both files with ``bbox_inches="tight"``, the layout of legible_ticks' last layout kept (engine "none")."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / f"{name}.png", directory / f"{name}.pdf"]
    with paper_style():
        figure.set_dpi(DPI)
        legible_ticks(figure)
        figure.set_layout_engine("none")
        for path in paths:
            figure.savefig(path, dpi=DPI, bbox_inches="tight",
                           metadata={"CreationDate": None} if path.suffix == ".pdf" else None)
    return paths


WAYS = {"save_figure": save_figure, "savefig, tight": savefig_tight}
"""What is timed: name → (figure, directory, name) → the paths written."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=7, help="rows of the figure (default: make run's 7 tasks)")
    parser.add_argument("--policies", type=int, default=10, help="N per task (default: experiment=smoke's)")
    parser.add_argument("--episodes", type=int, default=4, help="M per task")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs of each way")
    args = parser.parse_args()
    print(f"RWG trios of {args.tasks} tasks at N = {args.policies} × M = {args.episodes}, PNG + PDF, median of "
          f"{args.repeats} runs (min … max), load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"{'way':<16}{'CPU s':>8}{'(min … max)':>16}{'wall s':>8}")
    medians = {}
    with tempfile.TemporaryDirectory(prefix="taskcomplexity-bench-report-") as scratch:
        for way, save in WAYS.items():
            cpus, walls = [], []
            for _ in range(args.repeats):
                figure = trios(args.tasks, args.policies, args.episodes)
                wall, cpu = time.perf_counter(), time.process_time()
                save(figure, Path(scratch) / way, "rwg_trios")
                cpus.append(time.process_time() - cpu)
                walls.append(time.perf_counter() - wall)
            medians[way] = statistics.median(cpus)
            print(f"{way:<16}{medians[way]:>8.2f}{f'({min(cpus):.2f} … {max(cpus):.2f})':>16}"
                  f"{statistics.median(walls):>8.2f}")
        png = [matplotlib.image.imread(Path(scratch) / way / "rwg_trios.png") for way in WAYS]
        same = png[0].shape == png[1].shape and float(np.abs(png[0] - png[1]).max()) == 0.0
    first, second = WAYS
    print(f"{first} / {second}: {medians[first] / medians[second]:.2f} of the CPU time; "
          f"PNGs {'pixel-identical' if same else 'DIFFERENT'}")


if __name__ == "__main__":
    main()
