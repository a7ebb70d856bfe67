"""Does a published correlation between a metric and a reference score hold here, and is it the task's or the
estimator's?

A study may declare the correlations a paper printed (``study.published.tables.<name>.correlations``: Pearson r and
p of a quantity with a reference score across the tasks, e.g. Furuta et al.'s r(POIC, Score(A)) = 0.807).
:func:`replications` sets ours beside each, from the verdict's correlations (:mod:`taskcomplexity.verdict.references`)
on three bases: every task's value, only the tasks whose value carries information, and the value net of its
permutation null. Our r *holds* on a basis when its two-sided p across tasks is below ``1 − CONFIDENCE`` and, when the
metric has bootstrap draws, its percentile interval over the policy resamples excludes 0, both on the published
side. The outcome of a published correlation that is significant (p < ``1 − CONFIDENCE``):

- ``reproduced``: ours holds on the values, on the informative tasks (at least 3), and net of the null (when the
  metric has one);
- ``estimator bias``: ours holds on the values but not on the informative tasks (or fewer than 3 carry
  information) or not net of the null: the correlation is the estimator's bias, which varies with the task's
  returns, not the information the metric measures;
- ``not reproduced``: ours does not hold and excludes the published r both over the policy resamples (its
  percentile interval) and across the tasks (Fisher's interval of r, ``tasks_low``/``tasks_high``), or without an
  interval, its r has the other sign at p below the level;
- ``unresolved at this budget``: ours does not hold and cannot exclude the published r on both counts, or fewer
  than 3 tasks carry information.

A published correlation that is not significant is ``reproduced`` when ours is not significant either (on the
values, with at least 3 tasks carrying information), and ``not reproduced`` when ours holds in either direction.

``reproduced`` is the finding: its sign and significance (or that neither is significant). Where ours excludes the
published r both over the policy resamples and across the tasks, the finding holds and the value does not; the report
shows that outcome as :data:`FINDING_ONLY` (:func:`shown_outcome`), from the columns here.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics.registry import Registry
from taskcomplexity.study_data import Study
from taskcomplexity.verdict.references import CONFIDENCE, INFORMATIVE, NET_OF_NULL, VALUE

MIN_TASKS = 3
"""Fewest tasks a correlation is computed over (Pearson r is undefined below)."""
MEANINGS = {
    "reproduced": "ours holds on the values, on the informative tasks and net of the null (or, where the published r "
                  "is not significant, neither is ours)",
    "estimator bias": "ours holds on the values but not on the tasks where the metric carries information (or too few "
                      "do) or not net of the null",
    "not reproduced": "ours excludes the published r over resampled policies and across the tasks, or is "
                      "significant where it is not",
    "unresolved at this budget": f"ours cannot tell the published r from 0, or cannot exclude it on both counts, or "
                                 f"fewer than {MIN_TASKS} tasks carry information",
}
"""Every outcome of :func:`replications`, in the order the report lists them, with what it means."""
REPLICATION_OUTCOMES = tuple(MEANINGS)
FINDING_ONLY = "finding reproduced, value not"
"""How :func:`shown_outcome` shows a ``reproduced`` correlation whose published r ours excludes over resampled
policies and across the tasks."""
FINDING_ONLY_MEANING = ("as reproduced, but ours excludes the published r over resampled policies and across the "
                        "tasks: the finding holds, the value does not")
REPLICATION_COLUMNS = ("table", "reference", "quantity", "metric", "published_r", "published_p", "tasks", "pearson_r",
                       "pearson_p", "pearson_low", "pearson_high", "tasks_low", "tasks_high", "informative_tasks",
                       "informative_r", "informative_p", "net_r", "net_p", "net_low", "net_high", "outcome", "why")
"""Columns of :func:`replications` (``pearson_low``/``_high``: the interval of our r over the policy resamples;
``tasks_low``/``_high``: Fisher's interval of r across the tasks; ``informative_*``, ``net_*``: the same correlation
on the informative tasks and net of the null; NaN where that basis does not exist)."""


def replications(correlated: pd.DataFrame, study: Study, *, registry: Registry) -> pd.DataFrame:
    """Every correlation the study's published tables print, beside ours, with its outcome.

    Parameters
    ----------
    correlated : pandas.DataFrame
        The verdict's :func:`~taskcomplexity.verdict.references.correlations` (every basis).
    study : Study
        Its ``published.tables`` (none: an empty table).
    registry : Registry
        The metrics' directions: a published r on a metric's value is turned to its easiness (the sign flips
        where lower is easier), as ours is.

    Returns
    -------
    pandas.DataFrame, columns :data:`REPLICATION_COLUMNS`
        One row per (table, reference, quantity) the study publishes and the verdict correlated.
    """
    tables = study.published.tables if study.published is not None else {}
    rows = []
    for name, table in tables.items():
        for reference, printed in table.correlations.items():
            for quantity, (r_pub, p_pub) in printed.items():
                mine = correlated[(correlated["reference"] == reference) & (correlated["quantity"] == quantity)]
                if mine.empty:
                    continue
                bases = mine.set_index("basis")
                metric = str(mine["metric"].iloc[0])
                sign = -1.0 if quantity == metric and metric in registry and not registry[metric].higher_is_easier \
                    else 1.0
                row = {"table": name, "reference": reference, "quantity": quantity, "metric": metric,
                       "published_r": sign * r_pub, "published_p": p_pub}
                row.update(_basis(bases, VALUE, ("tasks", "pearson_r", "pearson_p", "pearson_low", "pearson_high"),
                                  ("tasks", "pearson_r", "pearson_p", "pearson_low", "pearson_high")))
                row["tasks_low"], row["tasks_high"] = fisher_interval(row["pearson_r"], row["tasks"])
                row.update(_basis(bases, INFORMATIVE, ("tasks", "pearson_r", "pearson_p"),
                                  ("informative_tasks", "informative_r", "informative_p")))
                row.update(_basis(bases, NET_OF_NULL, ("pearson_r", "pearson_p", "pearson_low", "pearson_high"),
                                  ("net_r", "net_p", "net_low", "net_high")))
                row["outcome"], row["why"] = outcome(row, checked=INFORMATIVE in bases.index,
                                                     has_null=NET_OF_NULL in bases.index)
                rows.append(row)
    return pd.DataFrame(rows, columns=list(REPLICATION_COLUMNS))


def _basis(bases: pd.DataFrame, basis: str, columns: tuple[str, ...], names: tuple[str, ...]) -> dict:
    if basis not in bases.index:
        return dict.fromkeys(names, float("nan"))
    found = bases.loc[basis]
    found = found.iloc[0] if isinstance(found, pd.DataFrame) else found
    return {name: float(found[column]) for column, name in zip(columns, names, strict=True)}


def fisher_interval(r: float, tasks: float) -> tuple[float, float]:
    """The :data:`CONFIDENCE` interval of a Pearson r over ``tasks`` tasks from Fisher's z (the tasks a sample of
    tasks): tanh(artanh r ± z / √(n − 3)); NaN with 3 tasks or fewer."""
    if not (np.isfinite(r) and np.isfinite(tasks)) or tasks <= 3:
        return float("nan"), float("nan")
    half = scipy.stats.norm.ppf((1 + CONFIDENCE) / 2) / np.sqrt(tasks - 3)
    centre = np.arctanh(np.clip(r, -1 + 1e-15, 1 - 1e-15))
    return float(np.tanh(centre - half)), float(np.tanh(centre + half))


def holds(r: float, p: float, low: float, high: float, side: float) -> bool:
    """Whether a correlation is significant on ``side`` (+1 or −1): p below the level and, when the bootstrap gave
    an interval, the interval clear of 0 on that side."""
    if not (np.isfinite(r) and np.isfinite(p)) or p >= 1 - CONFIDENCE or np.sign(r) != side:
        return False
    if np.isfinite(low) and np.isfinite(high):
        return bool(low > 0) if side > 0 else bool(high < 0)
    return True


def outcome(row: dict, *, checked: bool, has_null: bool) -> tuple[str, str]:
    """(outcome, why) of one published correlation beside ours (module docstring)."""
    level = 1 - CONFIDENCE
    side = float(np.sign(row["published_r"])) or 1.0
    values = holds(row["pearson_r"], row["pearson_p"], row["pearson_low"], row["pearson_high"], side)
    informative = int(row["informative_tasks"]) if np.isfinite(row["informative_tasks"]) else 0
    if checked and informative < MIN_TASKS and not values:
        return "unresolved at this budget", f"the metric carries information on only {_tasks(informative)}"
    if row["published_p"] >= level:
        either = values or holds(row["pearson_r"], row["pearson_p"], row["pearson_low"], row["pearson_high"], -side)
        if either:
            return "not reproduced", "the published correlation is not significant and ours is"
        return "reproduced", "neither the published correlation nor ours is significant"
    if values:
        if checked and informative < MIN_TASKS:
            return "estimator bias", f"the metric carries information on only {_tasks(informative)}"
        if checked and not holds(row["informative_r"], row["informative_p"], np.nan, np.nan, side):
            return "estimator bias", "it does not hold on the tasks where the metric carries information"
        if has_null and not holds(row["net_r"], row["net_p"], row["net_low"], row["net_high"], side):
            return "estimator bias", "it does not hold on the values net of their permutation nulls"
        if not checked:
            return "reproduced", "not checked against the nulls (the diagnostics stage did not run)"
        return "reproduced", "it holds on the values, on the informative tasks and net of the nulls"
    low, high = row["pearson_low"], row["pearson_high"]
    if np.isfinite(low) and np.isfinite(high):
        if not low <= row["published_r"] <= high:
            across = row.get("tasks_low", np.nan), row.get("tasks_high", np.nan)
            if np.isfinite(across[0]) and not across[0] <= row["published_r"] <= across[1]:
                return "not reproduced", (f"ours excludes the published r over resampled policies and across the tasks "
                                          f"(Fisher's interval {across[0]:.2f} to {across[1]:.2f})")
            return "unresolved at this budget", ("ours excludes the published r over resampled policies but not across "
                                                 "the tasks")
        if low <= 0 <= high:
            return "unresolved at this budget", "our interval spans both 0 and the published r"
        return "unresolved at this budget", "our interval holds the published r, but r is not significant across " \
                                            "the tasks"
    if holds(row["pearson_r"], row["pearson_p"], np.nan, np.nan, -side):
        return "not reproduced", "ours is significant on the other side"
    return "unresolved at this budget", "ours is not significant"


def value_excluded(row) -> bool:
    """Whether ours excludes the published r both over the policy resamples (``pearson_low``/``_high``) and across
    the tasks (``tasks_low``/``_high``); False where either interval is missing."""
    r = row["published_r"]
    intervals = [(row["pearson_low"], row["pearson_high"]),
                 (row.get("tasks_low", np.nan), row.get("tasks_high", np.nan))]
    return all(np.isfinite(low) and np.isfinite(high) and not low <= r <= high for low, high in intervals)


def shown_outcome(row) -> str:
    """The outcome as the report shows it: :data:`FINDING_ONLY` for a ``reproduced`` correlation whose value ours
    excludes (:func:`value_excluded`), else the row's ``outcome``."""
    return FINDING_ONLY if row["outcome"] == "reproduced" and value_excluded(row) else str(row["outcome"])


def _tasks(count: int) -> str:
    return f"{count} task" if count == 1 else f"{count} tasks"
