"""The stages a study runs before its verdict, one :class:`~taskcomplexity.stages.stage.Stage` record each, found
in the stage modules themselves (:func:`discover`), in the order they run: RWG → metrics → diagnostics → SAC →
occupancy → learning path → primitives.

Each module ``stages/<name>_stage.py`` declares its record as ``RECORD`` beside its settings, key, artefact and
function over the study's tasks; its ``run`` is a short adapter from the study's
:class:`~taskcomplexity.stages.stage.StudyWork` (the plan and what the stages before it returned) to that
function, its ``check`` what its settings must satisfy given the study's tasks (checked when the plan is read,
before any work), its ``order`` its place in the chain. A new stage is its module and its config group
(``conf/<name>/default.yaml``, chosen in ``conf/config.yaml``'s defaults): docs/how-to/add-a-stage.md.

The verdict (:data:`taskcomplexity.stages.verdict_stage.VERDICT`) closes the chain: it judges every record here
that says how (:class:`~taskcomplexity.stages.stage.Judged`), so it reads this module and is not among them.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Mapping

from taskcomplexity.errors import ConfigError
from taskcomplexity.stages.stage import Judged, Stage

SUFFIX = "_stage"
"""A stage module's name ends so: ``stages/<name>_stage.py``."""
CLOSING = "verdict_stage"
"""The module of the verdict, which reads these records (it closes the chain; it is not one of them)."""


def discover(package: str = __package__) -> tuple[Stage, ...]:
    """Every stage record (``RECORD``) of the modules ``<package>/*_stage.py`` but the verdict's, by ``order``.

    Raises ValueError when two records share a place, or a record runs before a stage it reads.
    """
    found = []
    for module in pkgutil.iter_modules(importlib.import_module(package).__path__):
        if module.name.endswith(SUFFIX) and module.name != CLOSING:
            record = getattr(importlib.import_module(f"{package}.{module.name}"), "RECORD", None)
            if record is not None:
                found.append(record)
    stages = tuple(sorted(found, key=lambda stage: stage.order))
    before: list[str] = []
    for stage in stages:
        if any(stage.order == other.order for other in stages if other is not stage):
            raise ValueError(f"stage {stage.name}: order={stage.order} is another stage's place too")
        late = [name for name in stage.inputs if name not in before]
        if late:
            raise ValueError(f"stage {stage.name} (order={stage.order}) reads {late}, which must run before it")
        before.append(stage.name)
    return stages


STAGES = discover()
"""Every stage before the verdict, in the order a study runs them."""


def judged_stages(stages: tuple[Stage, ...] = STAGES) -> Mapping[str, Judged]:
    """Stage name → how the verdict judges it, for every stage whose metrics it judges, in order."""
    return {stage.name: stage.judged for stage in stages if stage.judged is not None}


def check_registry(registry, stages: tuple[Stage, ...] = STAGES) -> None:
    """Refuse, in one line, a registry metric whose stage is no stage the verdict judges (a typo, or a stage
    that is not declared), naming the stages allowed."""
    judged = judged_stages(stages)
    for metric in registry:
        if metric.stage not in judged:
            raise ConfigError(f"metric {metric.name}: its stage must be one of {list(judged)} (the declared stages "
                              f"that estimate metrics), got {metric.stage!r}")
