"""What a stage is: one record naming its settings, config group, inputs, files, numerics, how the verdict
judges it, what to do when it is missing, and how it runs over a study (:class:`Stage`).

Each stage before the verdict declares its record in its own module (``RECORD`` in ``stages/<name>_stage.py``);
:mod:`taskcomplexity.stages.declared` finds them and orders them as a study runs them; the verdict's own
record (:data:`taskcomplexity.stages.verdict_stage.VERDICT`) reads them, and the chain
(:data:`taskcomplexity.study.chain.CHAIN`) is both. Everything that lists stages reads the records: the plan
(every stage's settings read and checked before any work), the chain (it runs each record in turn), the
verdict (it judges every record with a :class:`Judged`, from the files that record names), the
``rwg`` command (it refuses the other stages' groups) and the report (what to say when a stage is missing).

Why the records sit here, in ``stages/``, and the layers below read no table of stages: a record holds its
run function, so it lives with the stage's module, and the modules below the stages (the metric registry,
the verdict's gathering, the report) must not import upwards. Those lower modules take what they need of
the records as arguments instead (the files a verdict gathers, the sentence a report says when a stage is
missing), and the metric registry checks only the form of a metric's stage name: that the name is a
stage the verdict judges is checked when the plan is read (:func:`~taskcomplexity.stages.declared.check_registry`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from taskcomplexity.config import build
from taskcomplexity.stages.keys import Numerics

POLICIES = "policies"
SEEDS = "seeds"


@dataclass(frozen=True)
class Judged:
    """How the verdict judges the metrics a stage estimates.

    Attributes
    ----------
    values : str
        The artefact's file of each metric's value on the whole sample (one row).
    samples : str
        The artefact's file of the samples of each metric's Welch tests.
    on : str
        What those samples are: ``"policies"``, each batched metric on consecutive policy batches; or
        ``"seeds"``, one value per training seed, from the per-seed summary of learning curves (SAC's).
    """

    values: str
    samples: str = "batches.parquet"
    on: str = POLICIES

    def __post_init__(self) -> None:
        if self.on not in (POLICIES, SEEDS):
            raise ValueError(f"Judged.on must be {POLICIES!r} or {SEEDS!r}, got {self.on!r}")


@dataclass(frozen=True)
class StudyWork:
    """What a stage's run reads: the study's plan and the outputs of the stages run before it.

    Attributes
    ----------
    plan : StudyPlan
        The study, its tasks' RWG requests, every stage's typed settings, the cache, ``force``
        (:class:`taskcomplexity.study.plan.StudyPlan`).
    registry : Registry
        The metrics estimated and judged.
    done : dict of stage name to output
        What each stage run so far returned (per-task artefacts, SAC's curves, the verdict's artefact);
        the chain fills it, stage by stage.
    progress : bool
        Show each stage's bar.
    """

    plan: Any
    registry: Any
    done: dict[str, Any] = field(default_factory=dict)
    progress: bool = True

    def settings(self, stage: str) -> Any:
        """The typed settings of ``stage``."""
        return self.plan.settings[stage]


@dataclass(frozen=True)
class Stage:
    """One stage of a study, declared once.

    Attributes
    ----------
    name : str
        Its cache directory (``<cache>/<name>/<key>/``), its log lines and the ``stage`` of its metrics.
    numerics : Numerics
        The version and modules of its numbers (:mod:`taskcomplexity.stages.keys`); its key holds the
        version, its settings' identity and its inputs' keys.
    files : tuple of str
        What its artefact holds.
    run : callable
        ``run(work) -> output``: compute or reuse its artefacts over the study (:class:`StudyWork`), e.g.
        task id → artefact.
    inputs : tuple of str
        The stages whose keys its key holds (their outputs are in ``work.done`` when it runs).
    group : str or None
        Its config group (``conf/<group>/``); None: it has no settings of its own.
    settings : type or None
        The dataclass of its settings, read from ``group``.
    read : callable or None
        ``read(node, study) -> settings``: its settings from its config node, for settings that depend on the
        study or need more than their dataclass (None: the dataclass built from the node, :meth:`settings_from`).
    check : callable or None
        ``check(settings, study, requests, typed)``: what its settings must satisfy given the study's tasks
        (``requests``: their RWG requests; ``typed``: the overrides typed on the command line); raises a
        ConfigError naming the key, before any work.
    judged : Judged or None
        How the verdict judges its metrics (None: it estimates none).
    missing : str
        For a stage beyond the paper: what it needs, said by the report when none of its values was computed
        ("" for the paper's own stages).
    order : int
        Its place in a study's chain: the stages run, and the verdict and the report list them, in this order
        (each after the stages it reads; :func:`taskcomplexity.stages.declared.discover` checks it).
    """

    name: str
    numerics: Numerics
    files: tuple[str, ...]
    run: Callable[[StudyWork], Any]
    inputs: tuple[str, ...] = ()
    group: str | None = None
    settings: type | None = None
    read: Callable[[Any, Any], Any] | None = None
    check: Callable[[Any, Any, tuple, list[str]], None] | None = None
    judged: Judged | None = None
    missing: str = ""
    order: int = 0

    def __post_init__(self) -> None:
        if (self.group is None) != (self.settings is None):
            raise ValueError(f"stage {self.name}: a config group and a settings type go together, got "
                             f"group={self.group!r}, settings={self.settings!r}")


    def settings_from(self, node: Any, study: Any = None) -> Any:
        """Its typed settings from its config node (keys and types checked, then ``validate()``); ``study`` for
        stages whose settings depend on it (the metrics' pinned published protocol)."""
        if self.read is not None:
            return self.read(node, study)
        return build(self.settings, node, self.group)

