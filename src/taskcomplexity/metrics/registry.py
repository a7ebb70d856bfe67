"""The registry of complexity metrics: every metric declared once, with its direction.

Each :class:`Metric` names its function, display labels, unit, direction, family and the stage that
estimates it, and whether it has a bootstrap distribution and per-batch estimates for Welch's
test. The metrics and diagnostics stages, the verdict and the report iterate over a
:class:`Registry`; nothing else lists metric names. :data:`DEFAULT_REGISTRY` is immutable; a study
with a metric of its own passes an extended copy to the stages::

    from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Metric

    best = Metric("best_mean", "best policy mean", "best Mₙ", "sum of rewards", higher_is_easier=True,
                  family="random policies", stage="metrics", batched=True,
                  compute=lambda sample: float(sample.returns.mean(axis=1).max()))
    registry = DEFAULT_REGISTRY.with_metrics(best)   # pass registry=... to the stages

A stage's cache key includes :meth:`Registry.signature` of its metrics, so adding, removing or
re-versioning a metric never serves a stale artefact (bump ``version`` when a function changes).

Functions by stage:

- ``metrics`` and ``diagnostics``: ``compute(sample) -> float`` on a
  :class:`~taskcomplexity.metrics.sample.Sample` (the whole return matrix, or one policy batch);
- ``sac``: ``compute(per_seed) -> array`` of one value per seed, from one task's rows of
  :func:`~taskcomplexity.metrics.sac.seed_summary`;
- ``occupancy``: ``compute(sample) -> float`` on an
  :class:`~taskcomplexity.metrics.occupancy.OccupancySample` (K policies' distances, or a batch);
- ``learning_path``: ``compute(path) -> float`` on a
  :class:`~taskcomplexity.metrics.learning_path.LearningPath` (one return matrix per snapshot);
- ``primitives``: as ``metrics``, on the movement-primitive family's return matrix.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

BEYOND = "beyond the paper"
"""The family of the metrics the paper's conclusion proposes (the report answers its open question with them)."""

NAME = re.compile(r"[a-z][a-z0-9_]*")
"""The form of a metric's name and of its stage's name."""


@dataclass(frozen=True)
class Detail:
    """A further quantity a metric's estimate yields, stored beside it (e.g. H(R) of PIC).

    Attributes
    ----------
    name : str
        Column name in ``metrics.parquet``.
    label, unit : str
        Display name and unit.
    compute : callable
        ``compute(sample) -> float``.
    shown : bool
        Plotted against the normalised score with the metrics (False: stored only).
    """

    name: str
    label: str
    unit: str
    compute: Callable[[Any], float]
    shown: bool = True


@dataclass(frozen=True)
class Information:
    """How the verdict tells whether a metric's value carries information about the task
    (:mod:`taskcomplexity.verdict.information`).

    Attributes
    ----------
    null : str or None
        The permutation null of the diagnostics stage that applies to the value: a column of its
        ``null.parquet`` (``"pic"``, ``"poic"``, ``"pic_miller_madow"``, ``"pic_knn"``: the estimator on the
        returns shuffled across policies, where the true information is 0). The value carries information
        when it exceeds that null significantly.
    ceiling : bool
        The value is an information about the policy index, at most ln N (N: the policies of the sample
        it was estimated on); near that ceiling it cannot rank tasks.
    net_of_null : bool
        The value is already net of the null (e.g. PIC − null): its null share is not reported.
    binned : bool
        The estimator is the plug-in one on B histogram bins, so its value and its null move with B (and,
        under ``metrics.bins=auto``, with N): what the report says about more sampling. Not hashed: it
        changes no number.
    no_null : str
        Why an information estimate has no permutation null ("" when it has one, or is not an information):
        the verdict then judges it without the null check. Not hashed: it changes no number.
    """

    null: str | None = None
    ceiling: bool = False
    net_of_null: bool = False
    binned: bool = False
    no_null: str = ""

    def identity(self) -> dict:
        return {"null": self.null, "ceiling": self.ceiling, "net_of_null": self.net_of_null}


@dataclass(frozen=True)
class Metric:
    """One complexity metric.

    Attributes
    ----------
    name : str
        Stable column name (letters, digits, underscores) in every tidy table.
    label : str
        Name shown in figures and tables.
    short : str
        Compact name for matrix headers.
    unit : str
        Unit of its values.
    higher_is_easier : bool
        Direction: True when a higher value means an easier task.
    family : str
        Display grouping, e.g. "random policies", "estimator", "SAC".
    stage : str
        The name of the stage that estimates it: ``metrics``, ``diagnostics`` or ``primitives`` on return
        matrices, ``sac`` on learning curves, ``occupancy`` on the occupancy distances of sampled policies to
        SAC's trained actor, ``learning_path`` on the return matrices of policies around SAC's actor along
        training. The stages are declared above this layer (:mod:`taskcomplexity.stages.declared`); that a
        metric's stage is one the verdict judges is checked when a study's plan is read.
    compute : callable
        Its function (see the module docstring for the signature per stage).
    bootstrapped : bool
        Has a bootstrap distribution over policies (``bootstrap.parquet``, mean ± sd, intervals).
    batched : bool
        Estimated on each consecutive policy batch, the samples of its Welch tests (stages
        ``metrics``/``diagnostics``; a SAC metric's samples are its seeds).
    draws : callable, optional
        ``draws(sample) -> array (resamples,)``: a fast bootstrap; None estimates ``compute`` on each
        resample of :func:`~taskcomplexity.metrics.bootstrap.bootstrap_indices`.
    details : tuple of Detail
        Further quantities its estimate yields.
    primary : bool
        A main metric: Table 1, the Welch matrices and the first sentence of the report's verdict.
    quantity : str
        What it estimates; metrics of one quantity are compared in the report's survival table.
    why : str
        Why its direction is what it is (shown in the report's methods).
    version : int
        Bump when ``compute`` changes, so that cached artefacts are recomputed.
    information : Information or None
        Its null and ceiling, which the verdict checks before it judges a relation on its values
        (None: no check; every finite value is judged).
    comparable_across_tasks : bool
        Its values are on one scale whatever the task (False for values in each task's own reward
        units, e.g. the raw mean return): the report never ranks it across tasks as a complexity measure.
    definition : str
        What it is, as a formula of the returns, where its label does not say (the report gives it where it first
        names the metric); empty for a label that names a published quantity (PIC, POIC).
    """

    name: str
    label: str
    short: str
    unit: str
    higher_is_easier: bool
    family: str
    stage: str
    compute: Callable[[Any], Any]
    bootstrapped: bool = False
    batched: bool = False
    draws: Callable[[Any], np.ndarray] | None = None
    details: tuple[Detail, ...] = ()
    primary: bool = False
    quantity: str = ""
    why: str = ""
    version: int = 1
    information: Information | None = None
    comparable_across_tasks: bool = True
    definition: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not NAME.fullmatch(self.name):
            raise ValueError(f"Metric.name must be lower-case letters, digits and '_', got {self.name!r}")
        if not isinstance(self.stage, str) or not NAME.fullmatch(self.stage):
            raise ValueError(f"Metric {self.name}: stage must be a stage's name (lower-case letters, digits and "
                             f"'_'), got {self.stage!r}")
        if not callable(self.compute):
            raise ValueError(f"Metric {self.name}: compute must be callable, got {self.compute!r}")
        if self.stage == "sac" and (self.bootstrapped or self.batched):
            raise ValueError(f"Metric {self.name}: a SAC metric has seeds, not bootstrap draws or policy batches")

    def identity(self) -> dict:
        """What a cache key hashes of this metric."""
        return {"name": self.name, "version": self.version, "bootstrapped": self.bootstrapped,
                "batched": self.batched, "higher_is_easier": self.higher_is_easier,
                "details": [d.name for d in self.details]}


@dataclass(frozen=True)
class Registry:
    """An immutable, ordered set of metrics (the order of every table)."""

    metrics: tuple[Metric, ...]

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for metric in self.metrics:
            for name in (metric.name, *(d.name for d in metric.details)):
                if name in seen:
                    raise ValueError(f"Registry: the name {name!r} is declared twice")
                seen.add(name)

    def __iter__(self) -> Iterator[Metric]:
        return iter(self.metrics)

    def __len__(self) -> int:
        return len(self.metrics)

    def __contains__(self, name: object) -> bool:
        return any(m.name == name for m in self.metrics)

    def __getitem__(self, name: str) -> Metric:
        for metric in self.metrics:
            if metric.name == name:
                return metric
        raise KeyError(f"{name!r} is not a registered metric (registered: {', '.join(self.names)})")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.metrics)

    def of_stage(self, stage: str) -> tuple[Metric, ...]:
        """The metrics a stage estimates, in registry order (none for a stage that estimates none)."""
        return tuple(m for m in self.metrics if m.stage == stage)

    def label(self, name: str) -> str:
        """Display name (the name itself when not registered)."""
        return self[name].label if name in self else name

    def short(self, name: str) -> str:
        """Compact display name (the name itself when not registered)."""
        return self[name].short if name in self else name

    def order(self, names) -> list[str]:
        """``names`` in registry order, unregistered names last in their given order."""
        names = list(dict.fromkeys(names))
        return [n for n in self.names if n in names] + [n for n in names if n not in self]

    def with_metrics(self, *metrics: Metric) -> Registry:
        """A new registry with ``metrics`` appended (this one is unchanged)."""
        return Registry((*self.metrics, *metrics))

    def nulls(self) -> tuple[str, ...]:
        """The permutation nulls its metrics' information checks read (columns of the diagnostics'
        ``null.parquet``), each once, in registry order."""
        named = (m.information.null for m in self.metrics if m.information is not None and m.information.null)
        return tuple(dict.fromkeys(named))

    def signature(self, stage: str | None = None) -> list[dict]:
        """Identity of the metrics of ``stage`` (all when None), for cache keys."""
        chosen = self.metrics if stage is None else self.of_stage(stage)
        return [m.identity() for m in chosen]


# The default metrics ---------------------------------------------------------------------------


def _sac(variant: str, column: str) -> Callable[[Any], np.ndarray]:
    """Per-seed values of ``column`` for ``variant`` from one task's seed summary."""

    def per_seed(table) -> np.ndarray:
        return table.loc[table["variant"] == variant, column].to_numpy(dtype=np.float64)

    return per_seed


_I = "I(Θ; R)"
_OTHER_ESTIMATOR = ("another estimator of the same mutual information I(Θ; R) as PIC, so it inherits PIC's "
                    "direction; only the estimator changes")
_SAC_WHY = ("by definition of the empirical order: a higher normalised final return, or a larger area under the "
            "normalised learning curve (faster convergence to a higher return), means an easier task")

DEFAULT_REGISTRY = Registry((
    Metric("pic", "PIC", "PIC", "nats", True, "random policies", "metrics",
           compute=lambda s: s.pic.pic, bootstrapped=True, batched=True,
           draws=lambda s: s.bootstrap["pic"].to_numpy(), primary=True, quantity=_I,
           information=Information(null="pic", ceiling=True, binned=True),
           details=(Detail("h_r", "H(R)", "nats", lambda s: s.pic.h_r),
                    Detail("h_r_given_theta", "H(R|Θ)", "nats", lambda s: s.pic.h_r_given_theta)),
           why="the paper's claim: more information between the policy parameters and the return means that the "
               "choice of parameters matters, which is what optimisation exploits"),
    Metric("poic", "POIC", "POIC", "nats", True, "random policies", "metrics",
           compute=lambda s: s.poic.poic, bootstrapped=True, batched=True,
           draws=lambda s: s.bootstrap["poic"].to_numpy(), primary=True, information=Information(null="poic"),
           details=(Detail("temperature", "λ*", "return units", lambda s: s.poic.temperature, shown=False),
                    Detail("temperature_at_boundary", "λ* on a boundary", "", lambda s: s.poic.at_boundary,
                           shown=False),
                    Detail("h_o", "H(O)", "nats", lambda s: s.poic.h_o),
                    Detail("h_o_given_theta", "H(O|Θ)", "nats", lambda s: s.poic.h_o_given_theta)),
           why="the paper's claim, for the optimality of an episode instead of its return"),
    Metric("score", "score_R", "score_R", "fraction of range", True, "random policies", "metrics",
           compute=lambda s: s.score.score, batched=True,
           details=(Detail("r_min", "r_min", "sum of rewards", lambda s: s.score.r_min, shown=False),
                    Detail("r_max", "r_max", "sum of rewards", lambda s: s.score.r_max, shown=False)),
           why="the mean return of random policies sits closer to the best return found, so good behaviour is "
               "common under the prior and cheap to find",
           definition="(r_mean − r_min)/(r_max − r_min), with r_mean the mean of all N·M episode returns, r_min the "
                      "worst policy's mean return and r_max the best episode return"),
    Metric("r_mean", "mean return", "mean R", "sum of rewards", True, "random policies", "metrics",
           compute=lambda s: s.score.r_mean, batched=True, comparable_across_tasks=False,
           why="rewards are what the agent maximises, so a prior whose average behaviour already earns more "
               "starts closer to the goal (returns are in task units: a crude baseline across tasks)",
           definition="r_mean, the mean of all N·M episode returns (every policy's every episode)"),
    Metric("variance", "variance", "var.", "sum of rewards", True, "random policies", "metrics",
           compute=lambda s: s.score.variance, batched=True, comparable_across_tasks=False,
           why="the spread of returns across random behaviour is the signal random search and policy gradients "
               "follow; a task where every policy earns the same return gives no direction to improve",
           definition="Var(R)/(r_max − r_min), the variance of all N·M episode returns pooled over policies and "
                      "episodes (not of the policies' means), over the span from the worst policy's mean return to "
                      "the best episode return; in return units"),
    Metric("pic_miller_madow", "PIC (Miller–Madow)", "PIC MM", "nats", True, "estimator", "diagnostics",
           compute=lambda s: s.pic_miller_madow.pic, batched=True, quantity=_I, why=_OTHER_ESTIMATOR,
           information=Information(null="pic_miller_madow", ceiling=True, binned=True)),
    Metric("pic_knn", "PIC (k-NN)", "PIC kNN", "nats", True, "estimator", "diagnostics",
           compute=lambda s: s.knn.mi, batched=True, quantity=_I, why=_OTHER_ESTIMATOR,
           information=Information(null="pic_knn"),
           details=(Detail("knn_policies", "k-NN policies", "policies", lambda s: s.knn.policies, shown=False),
                    Detail("knn_episodes", "k-NN episodes", "episodes", lambda s: s.knn.episodes, shown=False))),
    Metric("pic_minus_null", "PIC − null", "PIC − null", "nats", True, "estimator", "diagnostics",
           compute=lambda s: float(s.pic.pic - s.null_pic.mean()), batched=True, quantity=_I,
           information=Information(null="pic", net_of_null=True, binned=True),
           why=_OTHER_ESTIMATOR + " (net of its permutation null)"),
    Metric("ot_distance", "W₂ to SAC's policy", "W₂ to SAC", "pooled sd", False, BEYOND, "occupancy",
           compute=lambda s: s.mean, bootstrapped=True, batched=True,
           details=(Detail("ot_distance_variance", "var. of W₂ over policies", "pooled sd²", lambda s: s.variance,
                           shown=False),),
           why="the paper's third proposal: random policies whose state–action occupancy lies far (optimal "
               "transport, W₂) from the trained policy's rarely behave well, so good behaviour is rare under the "
               "prior"),
    Metric("path_pic", "learning-path PIC", "path PIC", "nats", True, BEYOND, "learning_path",
           compute=lambda p: p.pic, bootstrapped=True, batched=True, draws=lambda p: p.draws("pic"),
           information=Information(ceiling=True, no_null=(
               "its samples are policies perturbed around each of SAC's snapshots, which the learning-path stage "
               "does not permute; a null there would need the perturbed policies' returns shuffled per snapshot")),
           why="the paper's second proposal: PIC measured around the parameters SAC passes through while it "
               "learns, where the choice of parameters matters to an optimiser, instead of around the prior's"),
    Metric("path_poic", "learning-path POIC", "path POIC", "nats", True, BEYOND, "learning_path",
           compute=lambda p: p.poic, bootstrapped=True, batched=True, draws=lambda p: p.draws("poic"),
           why="the paper's second proposal, for POIC: the optimality information around SAC's learning path"),
    Metric("dmp_pic", "PIC under DMPs", "DMP PIC", "nats", True, BEYOND, "primitives",
           compute=lambda s: s.pic.pic, bootstrapped=True, batched=True,
           draws=lambda s: s.bootstrap["pic"].to_numpy(), information=Information(ceiling=True, no_null=(
               "its returns are the movement-primitive family's, which the primitives stage estimates and the "
               "diagnostics stage, which permutes the MLP family's returns, does not")),
           details=(Detail("dmp_h_r", "H(R) under DMPs", "nats", lambda s: s.pic.h_r, shown=False),
                    Detail("dmp_h_r_given_theta", "H(R|Θ) under DMPs", "nats", lambda s: s.pic.h_r_given_theta,
                           shown=False)),
           why="the paper's first proposal: PIC over a policy family with an inductive bias for reaching (a "
               "movement primitive per joint, aimed at the target), whose parameters shape how the arm gets there "
               "rather than whether it moves sensibly at all"),
    Metric("dmp_poic", "POIC under DMPs", "DMP POIC", "nats", True, BEYOND, "primitives",
           compute=lambda s: s.poic.poic, bootstrapped=True, batched=True,
           draws=lambda s: s.bootstrap["poic"].to_numpy(),
           why="the paper's first proposal, for POIC: the optimality information under movement primitives"),
    Metric("sac_final", "SAC final", "SAC final", "normalised return", True, "SAC", "sac",
           compute=_sac("sac", "final_normalised"), why=_SAC_WHY),
    Metric("sac_auc", "SAC AUC", "SAC AUC", "normalised return", True, "SAC", "sac",
           compute=_sac("sac", "auc_normalised"), why=_SAC_WHY),
    Metric("sac_her_final", "SAC+HER final", "HER final", "normalised return", True, "SAC", "sac",
           compute=_sac("sac+her", "final_normalised"), why=_SAC_WHY),
    Metric("sac_her_auc", "SAC+HER AUC", "HER AUC", "normalised return", True, "SAC", "sac",
           compute=_sac("sac+her", "auc_normalised"), why=_SAC_WHY),
))
"""The metrics of ``docs/explanation/estimators.md``: random-policy metrics, other estimators of PIC's quantity,
and SAC's order."""
