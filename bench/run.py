"""`make bench`: run the benchmark scripts one after another and write what they print to one page.

    python bench/run.py                          # every bench_*.py at its own defaults (tens of minutes)
    python bench/run.py --quick                  # every script at the small budgets of QUICK (minutes)
    python bench/run.py --only rwg sac           # bench_rwg.py and bench_sac.py
    python bench/run.py --only rwg -- --one-task # extra arguments after -- go to every script run
    python bench/run.py --no-page                # print only
    python bench/run.py --native-only            # no second run on the AVX2 path

Each script's output goes to the console as it comes and, verbatim, into the page ``docs/benchmarks/results.md``
(``--page``), under a header that says where and when it was measured: the machine (CPU model, its vector
extensions, cores, memory, load average), the date, the commit (and whether the working tree differed from
it), the Python, torch, NumPy and numba versions, and the command. Each script gets its command, wall time,
CPU seconds (its process and the processes it waited for) and exit status. The page holds only the last run:
a run of some scripts, or at the quick budgets, says so at its top. The scripts never fail on a timing; this
exits with status 1 when one of them failed.

The scripts of :data:`AVX2_RUNS` measure RWG's backends against their floors and print a ``floor:`` line per
measurement (``bench/floors.py``); each runs again right after its native run, on the AVX2 path of numba, NumPy, torch
and the BLAS (``tests/cpu_paths.py``; ``--native-only`` skips it). At the end (and on the page, before the scripts'
output) one table gathers the lines of this run: per backend and task family, its floor, ×floor on each CPU path and
the cores busy; a figure this run did not measure is shown as missing.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import os
import platform
import re
import resource
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PAGE = ROOT / "docs" / "benchmarks" / "results.md"

QUICK: dict[str, list[str]] = {
    "bench_classic": ["--policies", "32", "--episodes", "16", "--gym-policies", "2", "--vector-steps", "20",
                      "--repeats", "1", "--paths-policies", "60", "--paths-repeats", "1"],
    "bench_contacts": ["--policies", "100", "--episodes", "20"],
    "bench_diagnostics": ["--policies", "200", "--episodes", "100", "--resamples", "100", "--repeats", "1",
                          "--skip-old"],
    "bench_gym": ["--steps", "3000", "--policies", "8", "--episodes", "8", "--repeats", "1"],
    "bench_kernel_split": ["--policies", "20", "--episodes", "100", "--repeats", "1"],
    "bench_metaworld": ["--tasks", "reach,stick-push", "--steps", "500", "--policies", "8", "--episodes", "4",
                        "--repeats", "1"],
    "bench_metrics": ["--policies", "500", "--episodes", "200", "--resamples", "50", "--repeats", "1"],
    "bench_mujoco": ["--steps", "1000", "--policies", "4", "--episodes", "8", "--chunk-policies", "2",
                     "--max-steps", "100", "--repeats", "1", "--pool-policies", "16"],
    "bench_report": ["--repeats", "3"],
    "bench_rwg": ["--one-task", "--policies", "1000", "--episodes", "100", "--chunk-policies", "50",
                  "--repeats", "1"],
    "bench_sac": ["--steps", "300", "--no-concurrent"],
    "bench_startup": ["--repeats", "5"],
    "bench_study": ["--policies", "200", "--episodes", "20", "--resamples", "20"],
}
"""Each script's small budget for ``--quick``: the same measurements on less work (their ratios are noisier)."""

AVX2_RUNS: dict[str, list[str]] = {
    "bench_classic": ["--paths-repeats", "0"],  # the classic-control study already runs on both paths inside it
    "bench_kernel_split": [],
    "bench_rwg": ["--floors-only"],
    "bench_mujoco": [],
    "bench_gym": [],
}
"""The scripts that print floor lines, run a second time on the AVX2 path, with these arguments after their own
(the part of the script that measures the floors)."""

VECTOR_FLAGS = ("avx512f", "avx512dq", "avx512bw", "avx512vl", "avx512_vnni", "avx512_bf16", "avx512_fp16",
                "amx_tile", "avx2", "fma", "avx", "f16c", "sse4_2", "asimd", "sve", "sve2")
"""The /proc/cpuinfo flags that decide which code paths numba, NumPy, torch and the BLAS take."""

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


@dataclass
class Result:
    """One script's run: its command, what it printed (as a terminal shows it), and what it cost."""

    name: str
    command: list[str]
    output: str
    wall: float
    cpu: float
    status: int


def scripts(only: list[str]) -> list[Path]:
    """The bench_*.py of this directory, sorted; or the ``only`` ones (``rwg``, ``bench_rwg`` or ``bench_rwg.py``)."""
    found = sorted(HERE.glob("bench_*.py"))
    if not only:
        return found
    by_name = {path.stem: path for path in found}
    chosen = []
    for name in only:
        stem = Path(name).stem
        stem = stem if stem.startswith("bench_") else f"bench_{stem}"
        if stem not in by_name:
            raise SystemExit(f"error: --only {name}: no bench/{stem}.py; choose from "
                             f"{', '.join(s.removeprefix('bench_') for s in by_name)}")
        chosen.append(by_name[stem])
    return chosen


def as_displayed(raw: str) -> str:
    """Text as a terminal shows it: colour codes dropped, a carriage return overwriting its line."""
    lines = []
    for line in ANSI.sub("", raw).replace("\r\n", "\n").split("\n"):
        lines.append(line.rsplit("\r", 1)[-1] if "\r" in line.rstrip("\r") else line.rstrip("\r"))
    return "\n".join(lines).rstrip() + "\n"


def run_script(path: Path, arguments: list[str], environment: dict[str, str] | None = None,
               name: str | None = None) -> Result:
    """Run one script, echoing its output, and time it (wall; CPU of it and the processes it waited for);
    ``environment``: variables added to this process's (the AVX2 path's), ``name``: the result's, if not the file's."""
    command = [sys.executable, str(path), *arguments]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               env={**os.environ, **(environment or {}), "PYTHONUNBUFFERED": "1"})
    chunks = []
    assert process.stdout is not None
    for chunk in iter(lambda: process.stdout.read1(4096), b""):
        sys.stdout.buffer.write(chunk)
        sys.stdout.flush()
        chunks.append(chunk)
    status = process.wait()
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    shown = [f"bench/{path.name}", *arguments]
    if environment:
        shown = ["tests/cpu_paths.py", "--", "python", *shown]
    return Result(name or path.name, shown, as_displayed(b"".join(chunks).decode("utf-8", "replace")), wall, cpu,
                  status)


def avx2_environment(numba_cache: str) -> dict[str, str]:
    """``tests/cpu_paths.py``'s AVX2 path (numba's kernels for it cached in ``numba_cache``)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from cpu_paths import avx2_environment as environment

    return environment(numba_cache)


def git(*arguments: str) -> str:
    done = subprocess.run(["git", *arguments], cwd=ROOT, capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else ""


def machine() -> dict[str, str]:
    """The header's facts about this machine and this checkout (the code paths the libraries take here: what
    ``tests/cpu_paths.py`` describes, as pytest's summary prints it)."""
    cpuinfo = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    model = re.search(r"^(?:model name|Model)\s*:\s*(.+)$", cpuinfo, flags=re.MULTILINE)
    flags = re.search(r"^(?:flags|Features)\s*:\s*(.+)$", cpuinfo, flags=re.MULTILINE)
    present = set(flags.group(1).split()) if flags else set()
    meminfo = Path("/proc/meminfo").read_text() if Path("/proc/meminfo").exists() else ""
    memory = re.search(r"^MemTotal:\s*(\d+) kB", meminfo, flags=re.MULTILINE)
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    versions = []
    for package in ("torch", "numpy", "numba"):
        try:
            versions.append(f"{package} {importlib.metadata.version(package)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{package} not installed")
    paths = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, 'tests'); "
                            "from cpu_paths import describe; print(describe())"],
                           cwd=ROOT, capture_output=True, text=True)
    return {
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "commit": f"`{commit}`" + (" + uncommitted changes (dirty)" if dirty else ""),
        "CPU": model.group(1).strip() if model else platform.processor() or platform.machine(),
        "vector extensions": " ".join(f for f in VECTOR_FLAGS if f in present) or "none of " + ", ".join(VECTOR_FLAGS),
        "cores": f"{os.cpu_count()} ({usable} usable by this process)",
        "memory": f"{int(memory.group(1)) / 1024**2:.1f} GiB" if memory else "unknown",
        "load average at the start": " ".join(f"{x:.2f}" for x in os.getloadavg()),
        "Python": f"{platform.python_version()} ({platform.python_implementation()})",
        "libraries": ", ".join(versions),
        "code paths": paths.stdout.strip() if paths.returncode == 0 else "unknown (tests/cpu_paths.py failed)",
    }


def fence(text: str) -> str:
    """A code fence longer than any run of backticks in ``text``."""
    longest = max((len(run) for run in re.findall(r"`+", text)), default=0)
    return "`" * max(3, longest + 1)


def anchor(heading: str) -> str:
    """The id MkDocs gives a heading (its ``toc`` extension's default slug)."""
    return re.sub(r"[-\s]+", "-", re.sub(r"[^\w\s-]", "", heading).strip().lower())


def floor_summary(results: list[Result]) -> str:
    """The table of every floor line the scripts printed (``bench/floors.py``), with its heading."""
    from floors import HEADING, collect, summary

    return f"{HEADING}\n\n{summary(collect([r.output for r in results]))}"


def page(header: dict[str, str], command: str, selection: str, results: list[Result], total: float) -> str:
    """The Markdown of the results page."""
    rows = "\n".join(f"| {key} | {value} |" for key, value in header.items())
    lines = [
        "# Benchmark results",
        "",
        "<!-- Written by `make bench` (bench/run.py) from its own output; `make bench` rewrites it. -->",
        "",
        f"The output of the last `make bench` run, verbatim. [Benchmarks](../benchmarks.md) says what each script "
        f"measures. {selection}",
        "",
        "| | |",
        "|---|---|",
        rows,
        f"| command | `{command}` |",
        f"| total | {total:.0f} s wall, {sum(r.cpu for r in results):.0f} CPU-seconds |",
        "",
        "| script | wall s | CPU s | exit status |",
        "|---|---:|---:|---:|",
        *(f"| [{r.name}](#{anchor(r.name)}) | {r.wall:.1f} | {r.cpu:.1f} | {r.status} |" for r in results),
        "",
        "## Each backend against its floor",
        "",
        floor_summary(results),
    ]
    for r in results:
        marks = fence(r.output)
        lines += [
            "",
            f"## {r.name}",
            "",
            f"`python {shlex.join(r.command)}`: {r.wall:.1f} s wall, {r.cpu:.1f} CPU-seconds, exit status {r.status}.",
            "",
            f"{marks}text",
            r.output.rstrip("\n"),
            marks,
        ]
    return "\n".join(lines) + "\n"


def parse_arguments(argv: list[str] | None = None) -> tuple[argparse.Namespace, list[str]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     epilog="Arguments after -- are passed to every script run.")
    parser.add_argument("--only", nargs="+", default=[], metavar="NAME",
                        help="run only these scripts (rwg, bench_rwg or bench_rwg.py)")
    parser.add_argument("--quick", action="store_true", help="every script at its small budget (QUICK)")
    parser.add_argument("--page", type=Path, default=PAGE, help=f"the page to write (default {PAGE.relative_to(ROOT)})")
    parser.add_argument("--no-page", action="store_true", help="print only, write no page")
    parser.add_argument("--native-only", action="store_true",
                        help="run no script again on the AVX2 path (AVX2_RUNS)")
    argv = sys.argv[1:] if argv is None else argv
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    return parser.parse_args(argv[:argv.index("--")] if "--" in argv else argv), extra


def main(argv: list[str] | None = None) -> int:
    args, extra = parse_arguments(argv)
    chosen = scripts(args.only)
    header = machine()
    invoked = shlex.join(["bench/run.py", *(sys.argv[1:] if argv is None else argv)])
    results = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-numba-avx2-") as numba_cache:  # one compilation per run
        for path in chosen:
            arguments = [*(QUICK.get(path.stem, []) if args.quick else []), *extra]
            runs = [(path.name, arguments, None)]
            if path.stem in AVX2_RUNS and not args.native_only:
                runs.append((f"{path.name} on the AVX2 path", [*arguments, *AVX2_RUNS[path.stem]],
                             avx2_environment(numba_cache)))
            for name, these, environment in runs:
                print(f"\n=== {name}: {shlex.join(these)} ===", flush=True)
                results.append(run_script(path, these, environment, name))
                print(f"=== {name}: {results[-1].wall:.1f} s wall, {results[-1].cpu:.1f} CPU-seconds, "
                      f"exit status {results[-1].status} ===", flush=True)
    total = time.perf_counter() - started
    print(f"\n{floor_summary(results)}", flush=True)
    everything = len(chosen) == len(scripts([]))
    selection = "Every script ran" if everything else f"Only {', '.join(r.name for r in results)} ran"
    if args.quick:
        selection += (" at the small budgets of `--quick` (the same measurements on less work: noisier ratios, no "
                      "full-scale figure)")
    if extra:
        selection += f"{',' if args.quick else ''} with `{shlex.join(extra)}`"
    selection += "." if args.quick or extra else " at their own defaults."
    if not args.no_page:
        args.page.parent.mkdir(parents=True, exist_ok=True)
        args.page.write_text(page(header, invoked, selection, results, total), encoding="utf-8")
        print(f"\nwritten: {args.page}")
    return 1 if any(r.status for r in results) else 0


if __name__ == "__main__":
    raise SystemExit(main())
