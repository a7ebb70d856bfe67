"""taskcomplexity's SLURM launcher (``hydra/launcher=cluster``), here because Hydra instantiates launchers only from
the ``hydra_plugins`` package; what it adds lives in :mod:`taskcomplexity.commands.cluster`."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from hydra.core.utils import JobReturn
from hydra_plugins.hydra_submitit_launcher.submitit_launcher import SlurmLauncher


class ClusterLauncher(SlurmLauncher):
    """hydra-submitit-launcher's SLURM launcher whose failed jobs come back as one ``error:`` line each."""

    def __call__(self, sweep_overrides: list[str], job_dir_key: str, job_num: int, job_id: str,
                 singleton_state: dict[type, Any]) -> JobReturn:
        """Run the job in its SLURM allocation; an entry point's one-line exit becomes a failed result."""
        from taskcomplexity.commands.cluster import job_result, out_of_time_unwinds, time_limit_ignored

        out_of_time_unwinds()
        try:
            return super().__call__(sweep_overrides, job_dir_key, job_num, job_id, singleton_state)
        except SystemExit as exit:
            return job_result(exit, sweep_overrides)
        finally:
            time_limit_ignored()

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
        """Send the jobs as one array, wait for them, and turn failed jobs into one line each."""
        from taskcomplexity.commands.cluster import collect

        return collect(super().launch, job_overrides, initial_job_idx)
