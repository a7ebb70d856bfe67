"""The stages of a study from its plan: every declared stage in turn, then the verdict.

The chain is the declarations (:data:`CHAIN`): RWG → metrics → diagnostics → SAC → occupancy → learning
path → primitives → verdict, each run over the study by its record's ``run``, reading the plan and what the
stages before it returned. The report reads what these produce (:func:`study_artefacts`); it is written by
:func:`taskcomplexity.study.run.run_study`, so that the chain never imports the report. The plan is read
from the config above it (:func:`taskcomplexity.study.plan.read_plan`): nothing here reads the config.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.ahead import computing_ahead
from taskcomplexity.stages.cache import Artefact, check_writable
from taskcomplexity.stages.declared import STAGES
from taskcomplexity.stages.diagnostics_stage import STAGE as DIAGNOSTICS
from taskcomplexity.stages.metrics_stage import STAGE as METRICS
from taskcomplexity.stages.rwg_stage import STAGE as RWG
from taskcomplexity.stages.sac_stage import STAGE as SAC
from taskcomplexity.stages.stage import StudyWork
from taskcomplexity.stages.task_artefacts import TaskMetrics, task_metrics
from taskcomplexity.stages.verdict_stage import VERDICT
from taskcomplexity.study.plan import StudyPlan
from taskcomplexity.study_data import Study

CHAIN = (*STAGES, VERDICT)
"""Every stage of a study, in the order it runs them: the declared stages, then the verdict that judges them."""


@dataclass(frozen=True)
class StudyArtefacts:
    """Every artefact of a study, in study order.

    Attributes
    ----------
    study : Study
        The study (tasks, relations, orders, reference scores).
    name : str
        Run name (``<study.name>-<tag>``): the report's directory.
    results : list of TaskMetrics
        Each task's RWG and metrics artefacts.
    diagnostics : dict of task id to Artefact
        Each task's diagnostics artefact.
    sac_curves : pandas.DataFrame or None
        Tidy SAC curves (None: SAC off, or a study of variants).
    verdict : Artefact
        The verdict stage's artefact.
    alpha : float
        Significance cut-off.
    further : dict of stage to dict of task id to Artefact
        The artefacts of the stages beyond the paper (those whose record says what they need when missing):
        built on SAC's trained actor (``occupancy``, ``learning_path``) and the movement-primitive family's
        (``primitives``).
    """

    study: Study
    name: str
    results: list[TaskMetrics]
    diagnostics: dict[str, Artefact]
    sac_curves: pd.DataFrame | None
    verdict: Artefact
    alpha: float
    further: dict[str, dict[str, Artefact]] | None = None


def study_artefacts(plan: StudyPlan, *, registry: Registry = DEFAULT_REGISTRY, progress: bool = True,
                    ahead: bool | None = None) -> StudyArtefacts:
    """Compute or reuse every artefact of the study of ``plan``, stage by stage (each logs its cache hits), after
    checking that the cache and the outputs can be written.

    ``ahead``: compute the stages that read only a task's returns in a background process as the returns
    come (:mod:`taskcomplexity.stages.ahead`; None: when the study is large enough). The artefacts are
    the same either way.
    """
    check_writable(plan.outputs, plan.cache)
    work = StudyWork(plan, registry, progress=progress)
    with computing_ahead(plan, STAGES, RWG, registry=registry, start=ahead):
        for stage in CHAIN:
            work.done[stage.name] = stage.run(work)
    done = work.done
    return StudyArtefacts(plan.study, plan.name, task_metrics(plan.tasks, done[RWG], done[METRICS]),
                          done[DIAGNOSTICS], done[SAC], done[VERDICT.name], plan.settings[METRICS].alpha,
                          {stage.name: done[stage.name] for stage in STAGES if stage.missing})
