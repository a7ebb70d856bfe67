"""What the SLURM launcher of ``hydra/launcher=cluster`` adds to hydra-submitit-launcher's: one line per failed job.

The launcher itself, ``ClusterLauncher``, lives in ``hydra_plugins.taskcomplexity_cluster`` (Hydra instantiates
launchers from that package only); its logic is here.

A multirun through it sends each job of the sweep (an RWG shard, a study task's SAC runs, a sweep cell) to SLURM as
one task of a job array. What it adds to hydra-submitit-launcher's ``SlurmLauncher``:

- **A failing job is one line.** Inside the job, an input error that the entry point turns into one line (exit 2)
  comes back to the submitting process as that line, with the job's id, node and log; a job that ends without a
  result (``scancel``, its time limit with no requeue left, the node lost) is named with its state and log. The
  submitting process prints one ``error:`` line per failed job and exits non-zero (2 for input errors, 1 else).
  A genuine bug in a job keeps its traceback, in the job's log and in the line's pointer to it.
- **Requeue on the time limit.** SLURM signals a job ``signal_delay_s`` before its limit; submitit then requeues
  it (``max_num_timeout`` times) and the requeued job resumes from the chunks its stage saved, so a shard longer
  than the limit finishes with nothing recomputed.

Every job's stage records which job computed it (:mod:`taskcomplexity.jobs`), so the report's Methods name the
scheduler, the job ids, the nodes and their CPU.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Sequence

from hydra.core.utils import JobReturn, JobStatus

from taskcomplexity.cli import EXIT_BAD_INPUT, EXIT_DISK_FULL, EXIT_OUT_OF_TIME, OutOfTime, last_error

RESULT_STATUSES = (EXIT_BAD_INPUT, EXIT_DISK_FULL, EXIT_OUT_OF_TIME)
"""Exit statuses of a job that come back as its result: the entry point's one-line input and disk-full errors, and
its last time limit."""


class JobFailed(Exception):
    """A job of the sweep ended with the project's one-line error (or another exit status); pickled back to the
    submitting process as the job's return value."""

    def __init__(self, line: str, status: int) -> None:
        super().__init__(line, status)  # both in args: an exception is pickled back by its args
        self.line = line
        self.status = status


def _where() -> str:
    """``job <id> on <node> (log: <path>)`` of the running submitit job."""
    import socket

    import submitit

    environment = submitit.JobEnvironment()
    return f"job {environment.job_id} on {environment.hostname or socket.gethostname()} " \
           f"(log: {environment.paths.stderr})"


def _unfinished(error: Exception) -> str:
    """One line for a job submitit could not collect a result of: its id, state and log (from submitit's message:
    ``Job <id> (task: <n>) with path <folder>/<id>_result.pkl`` then ``has not produced any output (state: S)``)."""
    text = str(error)
    job = re.search(r"Job (\S+) \(task: [^)]*\) with path (\S+)_result\.pkl", text)
    state = re.search(r"\(state: ([^)]*)\)", text)
    if job is None:
        return " ".join(text.split())[:300]
    log = f"{job.group(2)}_log.err"
    return (f"job {job.group(1)} ended without a result (state: {state.group(1) if state else 'unknown'}; log: "
            f"{log}); the work it saved is kept: rerun the same command to resume (the sweep's other jobs go on)")


def out_of_time_unwinds() -> None:
    """Make the job's last time limit unwind the stack as :class:`~taskcomplexity.cli.OutOfTime`.

    SLURM signals the job before its limit; submitit's handler requeues it, or, with no requeue left, raises its
    ``UncompletedJobError`` from the handler, that is from wherever the job is: inside an env's ``step`` the
    gym backend would report it as the env's own error. Wrapped, the handler raises ``OutOfTime`` instead (a
    BaseException, as Ctrl-C), which the entry point turns into one line (exit 124).
    """
    import signal

    from submitit.core.utils import UncompletedJobError
    from submitit.slurm.slurm import SlurmJobEnvironment

    number = getattr(signal, f"SIG{SlurmJobEnvironment.USR_SIG}")
    submitits = signal.getsignal(number)
    if not callable(submitits):
        return

    def handler(signum, frame) -> None:
        try:
            submitits(signum, frame)
        except UncompletedJobError as error:
            raise OutOfTime(f"the job reached its time limit and was not requeued ({error})") from None

    signal.signal(number, handler)


def time_limit_ignored() -> None:
    """Ignore SLURM's time-limit signal from here on: the job's work is over (its result, or its one line, is what
    submitit writes next).

    The signal can come after the work is done, while submitit writes the result or while Python shuts down. With
    submitit's handler still in place it would requeue a finished job; once Python has removed its handlers, it
    would kill the process, and SLURM would record the job FAILED although its result was delivered.
    """
    import signal

    from submitit.slurm.slurm import SlurmJobEnvironment

    signal.signal(getattr(signal, f"SIG{SlurmJobEnvironment.USR_SIG}"), signal.SIG_IGN)


def job_result(exit: SystemExit, overrides: list[str]) -> JobReturn:
    """The result of a job whose entry point exited: a failed JobReturn holding its one line (:class:`JobFailed`),
    or ``exit`` raised again when it is no one-line exit of the entry point.

    Any other exit leaves no result, so that SLURM's state tells the submitting process what happened: submitit's
    exit after it requeued the job (the requeued job delivers the result), or an interrupt (``scancel``'s SIGTERM:
    the job is CANCELLED).
    """
    line = last_error()
    if exit.code not in RESULT_STATUSES or line is None:
        raise exit
    failed = JobReturn(overrides=list(overrides), status=JobStatus.FAILED)
    failed.return_value = JobFailed(f"{line} [{_where()}]", int(exit.code))
    return failed


def collect(launch, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
    """Run ``launch`` (the SLURM launcher's own); print one ``error:`` line per failed job and exit non-zero (2 when
    every failure is an input error, else 1), or return the results."""
    from submitit.core.utils import UncompletedJobError

    try:
        results = launch(job_overrides, initial_job_idx)
    except UncompletedJobError as error:
        print(f"error: {_unfinished(error)}", file=sys.stderr, flush=True)
        raise SystemExit(1) from None
    failed = [r for r in results if r.status == JobStatus.FAILED and isinstance(r._return_value, JobFailed)]
    for result in failed:
        print(f"error: {' '.join(result.overrides)}: {result._return_value.line}", file=sys.stderr, flush=True)
    if failed:
        statuses = {r._return_value.status for r in failed}
        raise SystemExit(EXIT_BAD_INPUT if statuses == {EXIT_BAD_INPUT} else 1)
    return results
