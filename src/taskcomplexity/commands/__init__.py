"""The entry points: one Hydra app per stage plus ``study`` for the whole chain.

Each module's ``main()`` is a console script of the installed package (``taskcomplexity-rwg``,
``-metrics``, ``-sac``, ``-verdict``, ``-study``) and the body of its shim under the repository's
``pipelines/`` (``python pipelines/study.py …``); both read the packaged configs
(:data:`taskcomplexity.cli.CONF_DIR`), so they run from any directory. ``main()`` refuses a bad override
in one line before Hydra parses the command line, then runs the app; the work itself is the module's
``run(cfg)`` (or a library function), which tests call directly.

Importing this package configures the process, before any of its modules loads torch or NumPy:
OpenMP threads that spin-wait after a parallel region would steal the cores from numba's kernels
(2x slower RWG on 2 cores). The process is the entry point's to configure; ``import taskcomplexity``
itself sets nothing.

Modules
-------
cluster
    What the SLURM launcher of ``hydra/launcher=cluster`` adds: one ``error:`` line per failed job, the last time
    limit as one line (the launcher itself is ``hydra_plugins.taskcomplexity_cluster.ClusterLauncher``).
compilation
    Says when numba compiles a set of kernels and how long it took; compiles them all ahead (``make install``).
cost
    What a study's RWG stage will cost: a pilot of each task on this machine, extrapolated to its N × M.
metrics
    The metrics stage's entry point: every registered metric of a task, its bootstrap and batch estimates.
rwg
    The RWG stage's entry point: N random policies × M episodes of one task → ``returns.parquet``.
sac
    The SAC stage's entry point: SAC (and SAC + HER) on one task → ``curves.parquet``.
study
    The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → verdict → report.
study_tasks
    Prints a study's task ids, comma-separated: the values of a sweep over ``sac.entry`` (``make paper-jobs``).
sweep
    The Hydra callback that writes a multirun's sweep report.
verdict
    The verdict stage's entry point: every registered metric against every known relation of the study.
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# torchrl logs through a colour console handler of its own, set up at its import from this variable:
# its INFO lines (buffers, collectors) are not for the console; its warnings still are.
os.environ.setdefault("RL_LOGGING_LEVEL", "WARNING")
# Inside a SLURM job, OpenMP's and the BLAS's thread pools default to the job's cores, not the node's: a cluster that
# does not bind jobs to cores shows each job the whole node. (numba's: :func:`job_threads`, at run time, since numba
# refuses a NUMBA_NUM_THREADS that differs from the one its pool started with.)
if os.environ.get("SLURM_CPUS_PER_TASK", "").isdigit():
    for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, os.environ["SLURM_CPUS_PER_TASK"])


def job_threads() -> None:
    """Inside a SLURM job, run numba's parallel regions on the job's cores (``numba.set_num_threads``), not the
    node's; elsewhere leave numba as it is."""
    cores = os.environ.get("SLURM_CPUS_PER_TASK", "")
    if cores.isdigit() and int(cores) > 0:
        import numba

        numba.set_num_threads(min(int(cores), numba.config.NUMBA_NUM_THREADS))


def entry_point(run):
    """The ``main()`` of an entry point whose work is ``run(cfg)``, a function of the composed config.

    ``main()`` refuses a bad ``group=option`` override in one line (before Hydra parses the command
    line), then runs ``run`` as a Hydra app over the packaged configs, announcing numba's compilations
    (:mod:`taskcomplexity.commands.compilation`); an error of Hydra composing the config is one line too
    (:func:`taskcomplexity.cli.composition_errors`), Hydra composes it once, not twice
    (:func:`taskcomplexity.cli.one_composition`), and ``--help`` is Hydra's help from one composition
    (:func:`taskcomplexity.cli.app_help`). Hydra names the job (and its
    log file) after ``run``'s module: ``rwg``, ``metrics``, ``sac``, ``verdict``, ``study``.
    """
    import functools
    import sys

    import hydra

    from taskcomplexity.cli import (
        CONF_DIR,
        HELP_FLAGS,
        app_help,
        check_overrides,
        composition_errors,
        one_composition,
        typed_full_error,
    )

    @hydra.main(version_base="1.3", config_path=str(CONF_DIR), config_name="config")
    @functools.wraps(run)
    def app(cfg) -> None:
        from taskcomplexity.commands.compilation import announce_compilation

        typed_full_error()  # the task's own errors are reported as the user asked
        job_threads()
        with announce_compilation():
            run(cfg)

    def main() -> None:
        if any(flag in sys.argv[1:] for flag in HELP_FLAGS):
            text = app_help(sys.argv, run.__module__.rpartition(".")[2])
            if text is not None:
                print(text)
                return
        check_overrides(sys.argv, compose=False)
        with composition_errors(sys.argv), one_composition(sys.argv):
            app()

    main.__doc__ = f"The console script of :mod:`{run.__module__}` (and its shim under ``pipelines/``)."
    main.hydra_app = app  # Hydra's own app, as `main` runs it after its checks (tests compare the two)
    return main
