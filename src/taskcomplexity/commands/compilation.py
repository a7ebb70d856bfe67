"""Say when numba compiles a set of kernels and how long it took, and compile them all ahead (``make install``).

Every kernel of the package is compiled with ``cache=True``: numba compiles a kernel at its first call with
new argument types and writes the machine code to disk (``NUMBA_CACHE_DIR``, else the ``__pycache__``
folders beside the sources); later processes load it in milliseconds until the kernel's source file changes.
How long a compilation takes depends on the machine and on what else runs on it, so nothing here promises a
duration: each kernel set (:data:`KERNEL_SETS`) says when it starts compiling and, once done, how long it took.

:class:`CompilationLog` hears numba's ``numba:compile`` event, which numba fires only on a cache miss (a
real compilation, never a load from disk); :func:`announce_compilation` listens from the moment numba is imported
(:func:`taskcomplexity.post_import.when_imported`), so a run that needs no kernel does not import numba for it.
A set's compilations that follow one another are one burst: one line when it starts, one when it ends (when
another set starts compiling, or when no compilation has started for :data:`SETTLE_SECONDS`). The run log gets
the totals per set when the run ends.

``python -m taskcomplexity.commands.compilation`` (run by ``make install``) compiles every kernel set ahead:
it runs the first calls of the stages that ``make run``, ``make quick`` and ``make classic`` run, at a tiny
size into a temporary cache (:func:`warm_up`), so that their first run loads the kernels instead.
"""

from __future__ import annotations

import logging
import os
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from taskcomplexity.post_import import cancel, when_imported

log = logging.getLogger(__name__)

KERNEL_SETS: tuple[tuple[str, str], ...] = (
    ("taskcomplexity.tasks.classic", "classic-control"),
    ("taskcomplexity.tasks", "reaching-arm"),
    ("taskcomplexity.metrics", "estimator"),
    ("taskcomplexity.policies.tanh_kernel", "forward-pass tanh"),
    ("taskcomplexity.policies", "movement-primitive"),
)
"""(module prefix, set name), the most specific prefix first: a kernel belongs to the set of the first prefix
its module starts with; a kernel of any other module (a user's task) to a set named after its top package."""

SETTLE_SECONDS = 3.0
"""A burst of compilations ends when none has started for this long (s): the kernels of one stage compile one
after another, with the stage's own work between them."""

WARM_UP_RUNS: tuple[tuple[tuple[str, ...], bool], ...] = (
    (("experiment=published", "primitives.policies=10", "primitives.episodes=4", "primitives.bins=100"), True),
    (("experiment=quick",), False),
    (("study=classic_control", "study.policies=10", "study.episodes=4"), False),
)
"""The studies :func:`warm_up` runs at a tiny size (overrides, whether to run the whole chain or only RWG):
``make run``'s whole chain (float32 forward passes, the obstacle's contact model, the estimators, the movement
primitives), then the RWG of ``make quick`` (float64, PyBullet hand-overs: also what the single-stage commands
and ``experiment=smoke`` run) and of ``make classic`` (the classic-control kernels); their other stages call the
kernels the first chain compiled, with the same argument types."""

TINY = ("rwg.policies=10", "rwg.episodes=8", "metrics.bins=1000", "metrics.resamples=20", "sac.enabled=false")
"""The overrides that shrink a study to seconds of work (SAC off). M = 8, not fewer: the k-NN estimator runs its
kernels only when its k = 3 neighbours are below M / 2 per policy (below, it hands the estimate to scikit-learn),
so a warm-up at fewer episodes would leave them to the first real run."""


def cache_location() -> str:
    """Where numba writes the compiled kernels: ``NUMBA_CACHE_DIR`` or ``__pycache__`` beside the sources."""
    import numba

    if numba.config.CACHE_DIR:
        return str(Path(numba.config.CACHE_DIR).resolve())
    return f"the __pycache__ folders of {Path(__file__).resolve().parents[1]}"


def kernel_set(module: str, sets: tuple[tuple[str, str], ...] = KERNEL_SETS) -> str:
    """The name of the kernel set of a kernel defined in ``module`` (see :data:`KERNEL_SETS`)."""
    for prefix, name in sets:
        if module == prefix or module.startswith(prefix + "."):
            return name
    return module.split(".")[0]


class CompilationLog:
    """numba's ``numba:compile`` events of one run, announced and timed per kernel set (:func:`announce_compilation`
    forwards them).

    Parameters
    ----------
    write : callable
        Prints one line (the announcements).
    sets : tuple of (str, str), optional
        (module prefix, set name) pairs, :data:`KERNEL_SETS` by default.
    settle : float, optional
        Seconds without a compilation that end a burst, :data:`SETTLE_SECONDS` by default.

    Attributes
    ----------
    kernels : int
        Compilations (outermost ones: the kernels a kernel pulls in count in its time).
    seconds : float
        Wall time spent compiling, s.
    per_set : dict of str to [int, float]
        Compilations and seconds of each set.
    """

    def __init__(self, write: Callable[[str], None], *, sets: tuple[tuple[str, str], ...] = KERNEL_SETS,
                 settle: float = SETTLE_SECONDS):
        self._write = write
        self._sets = sets
        self._settle = settle
        self._lock = threading.Lock()
        self._depth = 0
        self._started = 0.0
        self._open: str | None = None       # the set of the burst under way
        self._burst = 0.0                   # its seconds so far
        self._generation = 0                # bumped at every compilation: a timer of an older one does nothing
        self._timer: threading.Timer | None = None
        self.kernels = 0
        self.seconds = 0.0
        self.per_set: dict[str, list] = {}

    def on_start(self, event) -> None:
        """A compilation starts (numba calls this, under its compiler lock; nested ones too)."""
        lines = []
        with self._lock:
            if self._depth == 0:
                self._generation += 1
                name = kernel_set(event.data["dispatcher"].py_func.__module__, self._sets)
                if self._open is not None and self._open != name:
                    lines.append(self._end_burst())
                if self._open is None:
                    lines.append(self._announce(name))
                    self._open = name
                self._started = time.perf_counter()
            self._depth += 1
        for line in lines:
            self._write(line)

    def on_end(self, event) -> None:
        """A compilation ends."""
        with self._lock:
            self._depth -= 1
            if self._depth:
                return
            seconds = time.perf_counter() - self._started
            self.kernels += 1
            self.seconds += seconds
            self._burst += seconds
            totals = self.per_set.setdefault(self._open, [0, 0.0])
            totals[0] += 1
            totals[1] += seconds
            self._timer = threading.Timer(self._settle, self._settled, args=(self._generation,))
            self._timer.daemon = True
            self._timer.start()

    def _announce(self, name: str) -> str:
        if name in self.per_set:
            return f"compiling more of the {name} kernels (other argument types) …"
        where = "" if self.per_set else f" in {cache_location()}"
        return (f"compiling the {name} kernels: not in numba's cache yet (first use on this machine, or their "
                f"source changed); numba caches them{where} for later runs …")

    def _end_burst(self) -> str:
        line = f"compiled the {self._open} kernels in {self._burst:.1f} s"
        self._open, self._burst = None, 0.0
        return line

    def _settled(self, generation: int) -> None:
        with self._lock:
            if generation != self._generation or self._depth or self._open is None:
                return
            line = self._end_burst()
        self._write(line)

    def close(self) -> None:
        """End the burst under way, if any (the end of the run)."""
        with self._lock:
            self._generation += 1
            if self._timer is not None:
                self._timer.cancel()
            line = self._end_burst() if self._open is not None and not self._depth else None
        if line:
            self._write(line)

    def summary(self) -> str | None:
        """One line on what was compiled in the run (None if nothing was)."""
        from taskcomplexity.report.format import plural

        if not self.kernels:
            return None
        sets = ", ".join(f"{name} {n} in {s:.1f} s" for name, (n, s) in self.per_set.items())
        return (f"numba compiled {plural(self.kernels, 'kernel')} in {self.seconds:.1f} s ({sets}); "
                f"cached in {cache_location()} for later runs")


@contextmanager
def announce_compilation(write: Callable[[str], None] | None = None, *,
                         sets: tuple[tuple[str, str], ...] = KERNEL_SETS,
                         settle: float = SETTLE_SECONDS) -> Iterator[CompilationLog]:
    """Within the block, each kernel set's compilations are announced and timed; the totals go to the run log.

    ``write`` prints a line (default: ``tqdm.write``, which keeps open progress bars intact); ``sets`` and
    ``settle`` as :class:`CompilationLog` takes them.
    """
    def write_line(line: str) -> None:
        from tqdm.auto import tqdm

        tqdm.write(line)

    compiled = CompilationLog(write or write_line, sets=sets, settle=settle)
    installed = []

    def listen(numba) -> None:  # once numba is imported: a run that never imports it compiles nothing
        from numba.core import event

        class Forward(event.Listener):
            def on_start(self, event) -> None:
                compiled.on_start(event)

            def on_end(self, event) -> None:
                compiled.on_end(event)

        listener = Forward()
        event.register("numba:compile", listener)
        installed.append((event, listener))

    when_imported("numba", listen)
    try:
        yield compiled
    finally:
        cancel("numba", listen)
        for event, listener in installed:
            event.unregister("numba:compile", listener)
        compiled.close()
        line = compiled.summary()
        if line:
            log.debug(line)


def warm_up(write: Callable[[str], None] = print) -> CompilationLog:
    """Compile (or load from numba's cache) every kernel the studies of :data:`WARM_UP_RUNS` call.

    Each runs at :data:`TINY` size into a temporary cache (its whole chain: RWG, metrics, diagnostics, the
    movement primitives, the verdict, no SAC, no report; or only the RWG of two policies per task, in a batch of
    4 environments and, on a backend with a parallel kernel, in one of its ``parallel_from``
    (:class:`~taskcomplexity.rwg.backends.Backend`)), so its kernels are called with the
    argument types, and through the size-dependent paths, that a run at any size calls them with. Returns the
    log of what compiled.
    """
    from dataclasses import replace

    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from taskcomplexity.cli import CONF_DIR
    from taskcomplexity.rwg import simulate_chunk
    from taskcomplexity.rwg.backends import BACKENDS
    from taskcomplexity.study.chain import study_artefacts
    from taskcomplexity.study.plan import read_plan

    with tempfile.TemporaryDirectory(prefix="taskcomplexity-warm-up-") as outputs, \
            announce_compilation(write) as compiled:
        for overrides, chain in WARM_UP_RUNS:
            GlobalHydra.instance().clear()
            with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
                cfg = compose("config", overrides=[*overrides, *TINY, f"paths.outputs={outputs}"])
            plan = read_plan(cfg)
            if chain:
                study_artefacts(plan, progress=False, ahead=False)
                continue
            for request in plan.requests:
                # a batch of 4 environments, and on a backend with a parallel kernel one of its parallel_from: it
                # steps them with its serial and its parallel kernel, so each is compiled here
                parallel_from = BACKENDS[request.backend].parallel_from
                for policies, episodes in ((2, 2), *([(2, parallel_from // 2)] if parallel_from else [])):
                    simulate_chunk(request.task, request.network, request.prior,
                                   replace(request.settings, policies=policies, episodes=episodes), 0, policies,
                                   request.backend)
        GlobalHydra.instance().clear()
    return compiled


STAMP = "taskcomplexity-warm-up.json"
"""The record of a finished warm-up, in numba's cache (``NUMBA_CACHE_DIR``, else the package's ``__pycache__``):
what it was compiled from and for (:func:`warm_up_identity`) and how many index files the cache held after it."""


def stamp_path() -> Path:
    """Where :data:`STAMP` is written: beside numba's cache."""
    import numba

    package = Path(__file__).resolve().parents[1]
    return (Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else package / "__pycache__") / STAMP


def warm_up_identity() -> dict:
    """What decides the kernels a warm-up leaves in the cache: the digest of every source and config file of the
    package (a kernel's source, the warm-up's studies, the settings they compose), numba's version and the CPU it
    compiles for (``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES`` or the host's), and Python's version."""
    import hashlib
    import platform

    import numba
    from llvmlite import binding

    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(p for p in package.rglob("*") if p.suffix in (".py", ".yaml") and "__pycache__" not in p.parts):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    cpu = numba.config.CPU_NAME or binding.get_host_cpu_name()
    features = numba.config.CPU_FEATURES or binding.get_host_cpu_features().flatten()
    return {"sources": digest.hexdigest(), "numba": numba.__version__, "cpu": cpu, "features": features,
            "python": platform.python_version()}


def index_files() -> int:
    """The number of numba index files (``*.nbi``) where the warm-up's kernels are cached."""
    import numba

    if numba.config.CACHE_DIR:
        return sum(1 for _ in Path(numba.config.CACHE_DIR).rglob("*.nbi"))
    return sum(1 for _ in Path(__file__).resolve().parents[1].rglob("__pycache__/*.nbi"))


def warmed_up() -> bool:
    """Whether a finished warm-up of these sources, for this CPU, left the cache as it still is (its stamp matches
    and no index file it counted is gone): :func:`main` has nothing to compile then."""
    import json

    try:
        record = json.loads(stamp_path().read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return record.get("identity") == warm_up_identity() and index_files() >= int(record.get("index_files", 1 << 30))


def main() -> None:
    """``python -m taskcomplexity.commands.compilation``: :func:`warm_up` unless a finished one of these sources for
    this CPU stands (:func:`warmed_up`), then one line on what it did; a finished warm-up writes :data:`STAMP`."""
    import json
    import warnings

    from taskcomplexity.report.format import plural

    logging.basicConfig(level=logging.WARNING)
    if warmed_up():
        print(f"numba kernels: already compiled ahead for these sources on this CPU ({stamp_path()}); nothing to do")
        return
    # The classic-control protocol's CartPole-v0 is chosen, not stale (as in the tests' filter, pyproject.toml).
    # gymnasium puts a filter of its own first when it is imported: imported first, it leaves this one first.
    import gymnasium  # noqa: F401

    warnings.filterwarnings("ignore", message=".*The environment CartPole-v0 is out of date",
                            category=DeprecationWarning)
    started = time.perf_counter()
    compiled = warm_up()
    seconds = time.perf_counter() - started
    if compiled.kernels:
        print(f"numba kernels compiled ahead: {plural(compiled.kernels, 'compilation')} in {compiled.seconds:.0f} s "
              f"(warm-up {seconds:.0f} s in all); cached in {cache_location()}")
    else:
        print(f"numba kernels: every one already in the cache ({cache_location()}; warm-up {seconds:.0f} s)")
    stamp = stamp_path()
    stamp.parent.mkdir(parents=True, exist_ok=True)
    temporary = stamp.with_name(f".{stamp.name}.{os.getpid()}.tmp")
    temporary.write_text(json.dumps({"identity": warm_up_identity(), "index_files": index_files()}), encoding="utf-8")
    temporary.replace(stamp)


if __name__ == "__main__":
    main()
