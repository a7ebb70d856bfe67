"""A study as data: its tasks (with display labels, groups, colours and SAC budgets), the known
complexity relations between them, optional total orders and reference scores.

Studies live in ``taskcomplexity/conf/study/*.yaml`` (or a researcher's own directory on Hydra's search path); the
verdict judges the study's relations, the report takes its labels, table order and colours from
here. Nothing about a particular task is hard-coded elsewhere.

This module stands below the stages, the verdict and the report, which read it; the study's plan, chain and
run (:mod:`taskcomplexity.study`) stand above them.

Example::

    name: mine
    tasks:
      - {id: pend, task: gym, env_id: Pendulum-v1, label: "Pendulum"}
      - {id: cart, task: cartpole}
    relations:
      - {easier: cart, harder: pend, kind: "swing-up"}
    orders: {}            # optional: name -> list of ids, easiest first (Kendall's tau)
    groups: null          # optional: {order: [easy, …, hardest], source: "…"}: the entries' `group`s are ordered
                          # difficulty groups (rank agreement across tasks, and the relations between groups)
    reference: {}         # optional: id -> a reference score (higher = easier; Pearson/Spearman r)
    reference_source: null  # optional: where the reference scores come from (the report cites it)
    algorithm_scores: {}  # optional: id -> {max: A_max, average: A_avg} of a learning algorithm
                          # (Score(A) and Score(R) of Furuta et al. 2021, correlated with every metric)
    network: null         # optional: the policy family of entries that choose none (the command line's
    prior: null           # network=/prior= still wins), e.g. the original PIC/POIC family
"""

from __future__ import annotations

import graphlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from taskcomplexity.errors import ConfigError

SELECTION_KEYS = ("task", "env_id", "kwargs", "max_steps", "arm", "reward", "prior", "network")
"""Keys of a study task entry that choose what is simulated (config groups and task fields)."""
DISPLAY_KEYS = ("id", "label", "group", "color", "sac_steps", "solved_return")
"""Keys of a study task entry that describe it (never change the returns)."""
KINDS = ("tasks", "variants")


@dataclass(frozen=True)
class Relation:
    """A known difficulty relation: ``easier`` is easier than ``harder``, for the reason ``kind``."""

    easier: str
    harder: str
    kind: str


@dataclass(frozen=True)
class StudyTask:
    """One entry of ``study.tasks``.

    Attributes
    ----------
    id : str
        The name relations, orders, tables and figure files use.
    label : str
        Display name (tables, figures).
    group : str or None
        Optional grouping of the tables' rows (e.g. the reward type of the paper's Table 1).
    color : str or None
        Matplotlib colour of the task in every figure (None: the study palette by position).
    sac_steps : int or None
        SAC budget, environment steps per seed (None: ``sac.total_steps`` must be set).
    solved_return : float or None
        An episode whose return reaches this counts as solved (for envs whose info reports no success).
    selection : dict
        The entry's selection keys (:data:`SELECTION_KEYS`) as given.
    """

    id: str
    label: str
    group: str | None = None
    color: str | None = None
    sac_steps: int | None = None
    solved_return: float | None = None
    selection: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class DifficultyGroups:
    """Ordered difficulty groups of a study's tasks (e.g. Meta-World's easy, medium, hard, very hard).

    Each task's group is its entry's ``group``; every task has one of :attr:`order`.

    Attributes
    ----------
    order : tuple of str
        The groups, easiest first.
    source : str
        Who grouped the tasks (the report cites it).
    """

    order: tuple[str, ...]
    source: str

    def rank(self, group: str) -> int:
        """The group's position, 0 = easiest."""
        return self.order.index(group)


@dataclass(frozen=True)
class AlgorithmScore:
    """A learning algorithm's scores on one task (Furuta et al. 2021): the reference of Score(A).

    Attributes
    ----------
    max : float
        A_max, the best return the algorithm reached (return units).
    average : float
        A_avg, its average final return (return units).
    """

    max: float
    average: float


@dataclass(frozen=True)
class PublishedTable:
    """Numbers a paper printed for a study's tasks, which the report sets beside ours.

    Attributes
    ----------
    source : str
        Where they were printed and under which protocol (e.g. "supplement Table 11, a bag of 56 architectures").
    values : mapping of task id to mapping of quantity to float
        Per task, the printed value of each quantity: a registered metric (``pic``, ``poic``, ``variance``), one
        of its details (``h_r``, ``h_o_given_theta``) or a reference score (``score_a``, ``score_r``); the names
        are checked against the registry when the study is planned.
    correlations : mapping of reference to mapping of quantity to (r, p)
        Printed Pearson r (and its p-value) of each quantity's value with a reference score across the tasks.
    """

    source: str
    values: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    correlations: Mapping[str, Mapping[str, tuple[float, float]]] = field(default_factory=dict)

    @property
    def quantities(self) -> tuple[str, ...]:
        """Every quantity the table names, in first-seen order (values, then correlations)."""
        names = [q for row in self.values.values() for q in row]
        names += [q for row in self.correlations.values() for q in row]
        return tuple(dict.fromkeys(names))


@dataclass(frozen=True)
class PublishedScale:
    """N, M and B of a published table: PIC's histogram estimator depends on all three.

    Attributes
    ----------
    policies, episodes : int
        N policies × M episodes per task.
    bins : int
        B, PIC's equal-width bins.
    source : str
        Where the table was published (e.g. "Table 1 of the paper").
    tables : mapping of str to PublishedTable
        The published numbers at this scale, by a short name (e.g. ``bag``, ``single``): the report sets ours
        beside them.
    """

    policies: int
    episodes: int
    bins: int
    source: str = "the published table"
    tables: Mapping[str, PublishedTable] = field(default_factory=dict)

    def differs(self, policies: int, episodes: int, bins: int) -> bool:
        return (policies, episodes, bins) != (self.policies, self.episodes, self.bins)


PAPER_SCALE = PublishedScale(policies=10_000, episodes=500, bins=100_000, source="Table 1 of the paper")
"""N, M and B of the AAMAS paper's Table 1: the scale a study without a ``published`` block of its own is
compared with (``study/seven_tasks.yaml`` declares the same block; a test holds the two together)."""


@dataclass(frozen=True)
class Study:
    """A study: tasks, known relations, total orders and reference scores.

    Attributes
    ----------
    name : str
        Directory name of its tables and report (with the run tag).
    tasks : tuple of StudyTask
        In table order.
    relations : tuple of Relation
        Known relations the verdict judges (may be empty).
    orders : mapping of str to tuple of str
        Named total orders of task ids, easiest first (Kendall's τ per order).
    reference : mapping of str to float
        Optional reference scores per task id, higher = easier.
    reference_source : str or None
        Where the reference scores come from (the report cites it).
    algorithm_scores : mapping of str to AlgorithmScore
        Optional scores of a learning algorithm per task id, from which the verdict derives Score(A)
        and Score(R) (:mod:`taskcomplexity.verdict.references`).
    network, prior : str or None
        Config options (``network/<name>.yaml``, ``prior/<name>.yaml``) of every entry that chooses
        none, unless the command line chooses one (None: the composed config's).
    kind : {'tasks', 'variants'}
        ``variants``: the entries are prior/network variants of one task (an ablation), compared by
        their return distributions rather than judged by relations.
    policies, episodes : int or None
        N and M for every entry (None: ``rwg.policies`` / ``rwg.episodes``).
    published : PublishedScale or None
        The scale of the study's published table, if it has one: ``experiment=published`` runs at it,
        and a report at another scale says that its PIC is not comparable with that table.
    groups : DifficultyGroups or None
        Whether the entries' ``group``s are ordered difficulty groups, and their order (None: a ``group`` only
        groups the tables' rows).
    """

    name: str
    tasks: tuple[StudyTask, ...]
    relations: tuple[Relation, ...] = ()
    orders: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    reference: Mapping[str, float] = field(default_factory=dict)
    algorithm_scores: Mapping[str, AlgorithmScore] = field(default_factory=dict)
    network: str | None = None
    prior: str | None = None
    kind: str = "tasks"
    policies: int | None = None
    episodes: int | None = None
    published: PublishedScale | None = None
    groups: DifficultyGroups | None = None
    reference_source: str | None = None

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(t.id for t in self.tasks)

    def task(self, task_id: str) -> StudyTask:
        for entry in self.tasks:
            if entry.id == task_id:
                return entry
        raise KeyError(task_id)

    def label(self, task_id: str) -> str:
        """Display label of a task id (the id itself when the study does not list it)."""
        try:
            return self.task(task_id).label
        except KeyError:
            return task_id

    @property
    def has_sac_budgets(self) -> bool:
        """Whether any task gives a SAC budget: a study without any has no SAC reference (its reference is
        e.g. ``algorithm_scores``), and SAC runs on it only with ``sac.total_steps``."""
        return any(t.sac_steps is not None for t in self.tasks)

    def difficulty(self) -> dict[str, int]:
        """Each task's difficulty group as its rank (0 = the easiest group), by task id; empty without ``groups``."""
        if self.groups is None:
            return {}
        return {t.id: self.groups.rank(t.group) for t in self.tasks}

    def relations_among(self, ids) -> tuple[Relation, ...]:
        """The relations whose two tasks are both in ``ids``, in study order."""
        present = set(ids)
        return tuple(r for r in self.relations if r.easier in present and r.harder in present)


PLAIN_NAME = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9_.\-]*")
"""A name that is one directory of its own: letters, digits, '_', '.', '-', not starting with '.' (so never ``.``,
``..`` or a hidden directory)."""


def plain_name(key: str, value: Any) -> str:
    """``value`` if it is a plain name (:data:`PLAIN_NAME`: a study's name and a run's tag name directories under
    ``paths.outputs``), else a ConfigError naming ``key``, the value and what is allowed."""
    if not isinstance(value, str) or not PLAIN_NAME.fullmatch(value):
        raise ConfigError(f"{key} must be a plain name of letters, digits, '_', '.', '-' that does not start with '.' "
                          f"(it names a directory under paths.outputs), got {value!r}")
    return value


def study_from_config(node: Any) -> Study:
    """Build and check a :class:`Study` from its config as plain data (``cfg.study`` read into dicts and lists,
    :func:`taskcomplexity.study.plan.study_from`)."""
    if not isinstance(node, Mapping):
        raise ConfigError(f"study must be a mapping (name, tasks, relations, …), got {node!r}")
    allowed = {"name", "tasks", "relations", "orders", "reference", "algorithm_scores", "network", "prior", "kind",
               "policies", "episodes", "published", "groups",
               "reference_source"}
    unknown = sorted(set(node) - allowed)
    if unknown:
        raise ConfigError(f"study.{unknown[0]} is not a known key (allowed: {', '.join(sorted(allowed))})")
    name = plain_name("study.name", node.get("name"))
    kind = node.get("kind") or "tasks"
    if kind not in KINDS:
        raise ConfigError(f"study.kind must be one of {list(KINDS)}, got {kind!r}")
    entries = node.get("tasks") or []
    if not isinstance(entries, list) or not entries:
        raise ConfigError(f"study.tasks must be a non-empty list of task entries, got {entries!r}")
    tasks = tuple(_task_entry(entry, i) for i, entry in enumerate(entries))
    ids = [t.id for t in tasks]
    for i, task_id in enumerate(ids):
        if task_id in ids[:i]:
            raise ConfigError(f"study.tasks[{i}].id={task_id} is used twice (give each entry its own id)")
    relations = tuple(_relation(r, i, ids) for i, r in enumerate(node.get("relations") or []))
    _refuse_cycles(relations)
    orders = {}
    for order_name, order in (node.get("orders") or {}).items():
        if not isinstance(order, list) or len(order) < 2:
            raise ConfigError(f"study.orders.{order_name} must be a list of at least 2 task ids, got {order!r}")
        for task_id in order:
            _known(f"study.orders.{order_name}", task_id, ids)
        orders[str(order_name)] = tuple(order)
    reference = {}
    for task_id, score in (node.get("reference") or {}).items():
        _known("study.reference", task_id, ids)
        if isinstance(score, bool) or not isinstance(score, (int, float)):
            raise ConfigError(f"study.reference.{task_id} must be a number, got {score!r}")
        reference[str(task_id)] = float(score)
    source = node.get("reference_source")
    if source is not None and (not isinstance(source, str) or not source or not reference):
        raise ConfigError(f"study.reference_source must be a non-empty string beside study.reference, got {source!r}")
    algorithm_scores = {str(task_id): _algorithm_score(score, task_id, ids)
                        for task_id, score in (node.get("algorithm_scores") or {}).items()}
    family = {}
    for key in ("network", "prior"):
        value = node.get(key)
        if value is not None and (not isinstance(value, str) or not re.fullmatch(r"[A-Za-z0-9_.\-]+", value)):
            raise ConfigError(f"study.{key} must be the name of a {key}/ config option or null, got {value!r}")
        family[key] = value
    counts = {}
    for key in ("policies", "episodes"):
        value = node.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 2):
            raise ConfigError(f"study.{key} must be an integer >= 2 or null, got {value!r}")
        counts[key] = value
    return Study(name=name, tasks=tasks, relations=relations, orders=orders, reference=reference,
                 algorithm_scores=algorithm_scores, kind=kind, published=_published(node.get("published"), ids),
                 groups=_groups(node.get("groups"), tasks), reference_source=source, **family, **counts)


def _groups(node: Any, tasks: tuple[StudyTask, ...]) -> DifficultyGroups | None:
    if node is None:
        return None
    if not isinstance(node, Mapping) or set(node) != {"order", "source"}:
        raise ConfigError(f"study.groups must be {{order: [easiest, …, hardest], source: \"who grouped them\"}}, "
                          f"got {node!r}")
    order = node["order"]
    if (not isinstance(order, list) or len(order) < 2 or len(set(map(str, order))) != len(order)
            or not all(isinstance(g, str) and g for g in order)):
        raise ConfigError(f"study.groups.order must be a list of at least 2 distinct group names, easiest first, "
                          f"got {order!r}")
    if not isinstance(node["source"], str) or not node["source"]:
        raise ConfigError(f"study.groups.source must be a non-empty string (who grouped the tasks), "
                          f"got {node['source']!r}")
    for i, task in enumerate(tasks):
        if task.group not in order:
            raise ConfigError(f"study.tasks[{i}].group={task.group!r} is not one of study.groups.order "
                              f"(allowed: {', '.join(order)})")
    return DifficultyGroups(order=tuple(order), source=node["source"])


def _algorithm_score(node: Any, task_id: Any, ids: list[str]) -> AlgorithmScore:
    where = f"study.algorithm_scores.{task_id}"
    _known("study.algorithm_scores", task_id, ids)
    if not isinstance(node, Mapping) or set(node) != {"max", "average"}:
        raise ConfigError(f"{where} must be {{max: A_max, average: A_avg}} (returns), got {node!r}")
    for key in ("max", "average"):
        value = node[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{where}.{key} must be a finite number, got {value!r}")
    if node["average"] > node["max"]:
        raise ConfigError(f"{where}: average {node['average']} exceeds max {node['max']} (A_avg <= A_max)")
    return AlgorithmScore(max=float(node["max"]), average=float(node["average"]))


def _published(node: Any, ids: list[str]) -> PublishedScale | None:
    if node is None:
        return None
    fields = ("policies", "episodes", "bins")
    if not isinstance(node, Mapping) or set(node) - {*fields, "source", "tables"} or set(fields) - set(node):
        raise ConfigError(f"study.published must be a mapping with policies, episodes, bins (and optionally "
                          f"source, tables), got {node!r}")
    for key in fields:
        value = node[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < 2:
            raise ConfigError(f"study.published.{key} must be an integer >= 2, got {value!r}")
    source = node.get("source", PublishedScale.source)
    if not isinstance(source, str):
        raise ConfigError(f"study.published.source must be a string, got {source!r}")
    tables = node.get("tables") or {}
    if not isinstance(tables, Mapping):
        raise ConfigError(f"study.published.tables must be a mapping of name to {{source, values, correlations}}, "
                          f"got {tables!r}")
    return PublishedScale(policies=node["policies"], episodes=node["episodes"], bins=node["bins"], source=source,
                          tables={str(name): _published_table(table, f"study.published.tables.{name}", ids)
                                  for name, table in tables.items()})


def _published_table(node: Any, where: str, ids: list[str]) -> PublishedTable:
    if not isinstance(node, Mapping) or "source" not in node or set(node) - {"source", "values", "correlations"}:
        raise ConfigError(f"{where} must be a mapping with source (and values, correlations), got {node!r}")
    if not isinstance(node["source"], str) or not node["source"]:
        raise ConfigError(f"{where}.source must be a non-empty string, got {node['source']!r}")
    values = {}
    for task_id, row in (node.get("values") or {}).items():
        _known(f"{where}.values", task_id, ids)
        if not isinstance(row, Mapping) or not row:
            raise ConfigError(f"{where}.values.{task_id} must be a mapping of quantity to number, got {row!r}")
        values[str(task_id)] = {str(q): _finite(v, f"{where}.values.{task_id}.{q}") for q, v in row.items()}
    correlations = {}
    for reference, row in (node.get("correlations") or {}).items():
        if not isinstance(row, Mapping) or not row:
            raise ConfigError(f"{where}.correlations.{reference} must be a mapping of quantity to [r, p], "
                              f"got {row!r}")
        pairs = {}
        for quantity, pair in row.items():
            at = f"{where}.correlations.{reference}.{quantity}"
            if not isinstance(pair, (list, tuple)) or len(pair) != 2:
                raise ConfigError(f"{at} must be [r, p], got {pair!r}")
            r, p = _finite(pair[0], at), _finite(pair[1], at)
            if not (-1 <= r <= 1 and 0 <= p <= 1):
                raise ConfigError(f"{at} must be [r, p] with -1 <= r <= 1 and 0 <= p <= 1, got {list(pair)}")
            pairs[str(quantity)] = (r, p)
        correlations[str(reference)] = pairs
    return PublishedTable(source=node["source"], values=values, correlations=correlations)


def _finite(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def load_study_file(path) -> Study:
    """A study YAML file (e.g. ``taskcomplexity/conf/study/seven_tasks.yaml``) as a :class:`Study`."""
    from omegaconf import OmegaConf

    return study_from_config(OmegaConf.to_container(OmegaConf.load(path), resolve=True))


def _task_entry(entry: Any, i: int) -> StudyTask:
    where = f"study.tasks[{i}]"
    if not isinstance(entry, Mapping):
        raise ConfigError(f"{where} must be a mapping (e.g. {{task: cartpole}}), got {entry!r}")
    unknown = sorted(set(entry) - set(SELECTION_KEYS) - set(DISPLAY_KEYS))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]} is not a known key "
                          f"(allowed: {', '.join(sorted(SELECTION_KEYS + DISPLAY_KEYS))})")
    selection = {k: entry[k] for k in SELECTION_KEYS if entry.get(k) is not None}
    if "task" not in selection and "arm" not in selection and "env_id" not in selection:
        raise ConfigError(f"{where} must choose a task: task (a task/ preset), env_id, or arm and reward")
    task_id = entry.get("id") or default_id(selection)
    if not isinstance(task_id, str) or not re.fullmatch(r"[A-Za-z0-9_.:\-]+", task_id):
        raise ConfigError(f"{where}.id must be a name of letters, digits, '_', '.', ':', '-', got {task_id!r}")
    sac_steps = entry.get("sac_steps")
    if sac_steps is not None and (isinstance(sac_steps, bool) or not isinstance(sac_steps, int) or sac_steps < 1):
        raise ConfigError(f"{where}.sac_steps must be an integer >= 1 or null, got {sac_steps!r}")
    solved = entry.get("solved_return")
    if solved is not None and (isinstance(solved, bool) or not isinstance(solved, (int, float))):
        raise ConfigError(f"{where}.solved_return must be a number or null, got {solved!r}")
    return StudyTask(
        id=task_id,
        label=str(entry.get("label") or task_id),
        group=None if entry.get("group") is None else str(entry["group"]),
        color=None if entry.get("color") is None else str(entry["color"]),
        sac_steps=sac_steps,
        solved_return=None if solved is None else float(solved),
        selection=selection,
    )


def default_id(selection: Mapping[str, Any]) -> str:
    """The id of an entry without one: ``<arm>-<reward>``, the env id, or the task preset's name."""
    if "arm" in selection:
        return f"{selection['arm']}-{selection.get('reward', 'dense')}"
    if "env_id" in selection:
        return str(selection["env_id"]).rpartition(":")[2]
    return str(selection["task"])


def _relation(node: Any, i: int, ids: list[str]) -> Relation:
    where = f"study.relations[{i}]"
    keys = set(node) if isinstance(node, Mapping) else set()
    if not isinstance(node, Mapping) or keys - {"easier", "harder", "kind"} or not {"easier", "harder"} <= keys:
        raise ConfigError(f"{where} must be {{easier: <id>, harder: <id>, kind: <reason>}}, got {node!r}")
    _known(f"{where}.easier", node["easier"], ids)
    _known(f"{where}.harder", node["harder"], ids)
    if node["easier"] == node["harder"]:
        raise ConfigError(f"{where} relates task {node['easier']} to itself")
    kind = node.get("kind")
    if not isinstance(kind, str) or not kind.strip():
        raise ConfigError(f"{where}.kind must say why the relation is known (a non-empty string, e.g. reward or "
                          f"degrees_of_freedom: the verdict's tables group relations by it), got {kind!r}")
    return Relation(str(node["easier"]), str(node["harder"]), kind)


def _refuse_cycles(relations: tuple[Relation, ...]) -> None:
    """Refuse relations that contradict each other: a chain of "easier than" that returns to its start."""
    graph: dict[str, set[str]] = {}
    for relation in relations:
        graph.setdefault(relation.harder, set()).add(relation.easier)
    try:
        tuple(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as err:
        cycle = err.args[1]
        raise ConfigError(f"study.relations contradict each other: {' < '.join(cycle)} (a task cannot be "
                          "easier than itself; remove or reverse one of these relations)") from None


def _known(where: str, task_id: Any, ids: list[str]) -> None:
    if task_id not in ids:
        raise ConfigError(f"{where}={task_id} is not a task of the study (its ids: {', '.join(ids)})")
