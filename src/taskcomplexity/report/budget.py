"""The next budget: one (N, M, B) that the headline recommends and the full verdict table's last column sizes.

Each relation a primary metric leaves open is sized by what would settle it, from the verdict's columns:

- **not significant** on values with information: the N at which Welch's test would resolve it, at this M and B
  (the verdict's ``policies_to_resolve``, :func:`~taskcomplexity.metrics.batches.policies_to_resolve`);
- **uninformative because its difference is mostly the nulls'** (both values informative, a binned estimator): the
  M at which the nulls' share of the difference falls to one half, at this B
  (:func:`~taskcomplexity.verdict.information.episodes_to_settle`); more policies do not settle it (under
  ``metrics.bins=auto`` B grows with N and the values approach their nulls);
- anything else (a value equal to its null or at its ceiling, excesses ordering the pair the other way, no
  difference to resolve) is not sized.

The next budget is the largest N and the largest M of the primary metrics' sized relations, with B held where a
binned estimator is judged: :func:`next_budget`. The headline states it (:func:`budget_sentences`) and the full
verdict table gives each relation's own size (:func:`to_resolve`), so the two read the same numbers.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from taskcomplexity.metrics.pic import RETURNS_PER_BIN, auto_bins
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import MISSING, and_list, plural, significant_int
from taskcomplexity.verdict.information import DIFFERENCE_NULL_SHARE, episodes_to_settle

OPEN = ("not significant", "uninformative")
"""The outcomes of a relation a metric leaves open."""


@dataclass(frozen=True)
class NextBudget:
    """The budget that settles the primary metrics' open relations, under the projections' assumptions.

    Attributes
    ----------
    policies, episodes : int
        N′ and M′: the largest N and M of the sized relations (N and M of this study where none needs more).
    bins : int or None
        B, held (None: no binned estimator is judged, or the metrics stage does not say).
    now : tuple of int
        This study's (N, M).
    by_policies, by_episodes : dict of metric label to int
        Per primary metric, its relations that N′ (at this M and B) and M′ (at this B) settle.
    unsized : dict of str to dict of metric label to int
        Per reason (a key of :data:`UNSIZED`), the open relations of each primary metric neither projection sizes.
    auto : bool
        The metrics stage used ``metrics.bins=auto`` (B = N·M/50), which would not hold B.
    """

    policies: int
    episodes: int
    bins: int | None
    now: tuple[int, int]
    by_policies: dict[str, int] = field(default_factory=dict)
    by_episodes: dict[str, int] = field(default_factory=dict)
    unsized: dict[str, dict[str, int]] = field(default_factory=dict)
    auto: bool = False
    sized: tuple[SizedRelation, ...] = ()

    @property
    def changes(self) -> bool:
        """Whether the budget differs from this study's."""
        return (self.policies, self.episodes) != self.now

    def overrides(self) -> str:
        """The command-line overrides that run it: "study.policies=5500 study.episodes=200 metrics.bins=400"."""
        parts = [f"study.policies={self.policies}", f"study.episodes={self.episodes}"]
        return " ".join(parts + ([f"metrics.bins={self.bins}"] if self.bins is not None else []))

    def record(self) -> dict:
        """What a report's ``summary.json`` keeps of it, for the run at this budget to re-check
        (:func:`recheck_sentences`)."""
        return {"policies": self.policies, "episodes": self.episodes, "bins": self.bins, "now": list(self.now),
                "sized": [{"metric": r.metric, "easier": r.easier, "harder": r.harder, "by": r.by, "size": r.size}
                          for r in self.sized]}


@dataclass(frozen=True)
class SizedRelation:
    """One open relation of a primary metric that the next budget sizes: ``by`` "policies" (N′, at this M and B) or
    "episodes" (M′, at this B), to ``size`` (rounded up as shown)."""

    metric: str
    easier: str
    harder: str
    by: str
    size: int


def to_resolve(data: StudyData) -> pd.Series:
    """Per row of the verdict: "N ≈ 5 500" (a test not significant, at this M and B), "M ≈ 200" (a difference that
    is mostly the nulls', at this B), "> 10⁹" (no difference to resolve) or missing (module docstring)."""
    verdict, registry = data.verdict["verdict"], data.registry
    episodes = _episodes(data)
    cells = []
    for _, row in verdict.iterrows():
        kind, size = _size(row, registry, episodes) if row["outcome"] in OPEN else (None, float("nan"))
        if kind == "policies":
            cells.append("> 10⁹" if size > 1e9 else f"N ≈ {shown_size(size)}")
        elif kind == "episodes":
            cells.append(f"M ≈ {shown_size(size)}")
        elif kind == "none" and row["policies_to_resolve"] == np.inf:
            cells.append("> 10⁹")
        else:
            cells.append(MISSING)
    return pd.Series(cells, index=verdict.index, dtype=object)


def next_budget(data: StudyData) -> NextBudget | None:
    """The next budget of the primary metrics (None without an open relation of theirs or a single (N, M))."""
    verdict, registry = data.verdict["verdict"], data.registry
    scale = _scale(data)
    if verdict.empty or scale is None:
        return None
    policies, episodes = scale
    primary = [m for m in registry if m.primary]
    open_ = verdict[verdict["metric"].isin([m.name for m in primary]) & verdict["outcome"].isin(OPEN)]
    if open_.empty:
        return None
    needs = {"policies": [policies], "episodes": [episodes]}
    counts: dict[str, dict[str, int]] = {kind: {} for kind in ("policies", "episodes", *UNSIZED)}
    sized = []
    for _, row in open_.iterrows():
        kind, size = _size(row, registry, episodes)
        if kind in needs:
            needs[kind].append(size)
            sized.append(SizedRelation(str(row["metric"]), str(row["easier"]), str(row["harder"]), kind,
                                       int(_round_up(size))))
        label = registry.label(row["metric"])
        counts[kind][label] = counts[kind].get(label, 0) + 1
    bins = _bins(data) if any(m.information is not None and m.information.binned for m in primary) else None
    return NextBudget(policies=int(_round_up(max(needs["policies"]))), episodes=int(_round_up(max(needs["episodes"]))),
                      bins=bins, now=scale, by_policies=counts["policies"], by_episodes=counts["episodes"],
                      unsized={why: counts[why] for why in UNSIZED if counts[why]},
                      auto=bins is not None and bins == auto_bins(*scale), sized=tuple(sized))


def budget_sentences(data: StudyData) -> list[str]:
    """The headline's recommendation: the next budget, what each of its numbers settles and under which
    assumptions, and what it leaves unsized (empty without an open relation of a primary metric)."""
    budget = next_budget(data)
    if budget is None:
        return []
    n, m = budget.now
    sentences = []
    if budget.changes:
        held = f", B = {budget.bins:,} held" if budget.bins is not None else ""
        sentences.append(f"Next budget: N = {shown_size(budget.policies)} policies × M = {shown_size(budget.episodes)} "
                         f"episodes{held} (now N = {n:,} × M = {m:,}; {budget.overrides()}).")
    if budget.by_policies:
        sentences.append(
            f"At N = {shown_size(budget.policies)} (this M and B) Welch's test would resolve "
            f"{_counted(budget.by_policies)} now not significant, assuming the batches' sd falls as N^-1/2 and the "
            "difference stays as measured; that projects the test alone: the permutation nulls move with N too, and "
            "the report does not predict them there.")
    if budget.by_episodes:
        why = (f" (under metrics.bins=auto, B = N·M/{RETURNS_PER_BIN} grows with N and the values approach their "
               f"nulls: hold B with metrics.bins={budget.bins})" if budget.auto else "")
        sentences.append(
            f"At M = {shown_size(budget.episodes)} (this B) the nulls' share of the difference falls to "
            f"{DIFFERENCE_NULL_SHARE * 100:g} % on {_counted(budget.by_episodes)} whose difference is now mostly "
            "the nulls', assuming each null falls at least as M^-1/2 and the excesses over the nulls stay; more "
            f"policies do not settle those{why}.")
    if budget.unsized:
        lead = "Not sized by either" if budget.changes else "Not sized by more policies or episodes"
        sentences.append(f"{lead}: " + "; ".join(f"{_counted(counts)} ({UNSIZED[why]})"
                                                   for why, counts in budget.unsized.items()) + ".")
    return sentences


@dataclass(frozen=True)
class Recommendation:
    """A next budget an earlier report of the same study recommended: when that report was built (as the page prints
    it), and its :meth:`NextBudget.record`."""

    built: str
    record: dict


def recheck_sentences(data: StudyData, earlier: Sequence[Recommendation]) -> list[str]:
    """The re-check of a recommendation: when this run reaches the next budget an earlier report of the study
    recommended (N and M at least N′ and M′, B the one it held), what became of each relation it sized.

    ``earlier`` is newest first; the newest one this run reaches is re-checked. Empty when this run reaches none.
    The sentences count the outcomes now of the relations sized by N′ and by M′ (a relation this run no longer
    judges is counted as missing), name those still open, and say that N′ is a median projection, so that about
    half of the relations sized by N′ alone resolve there.
    """
    scale = _scale(data)
    if scale is None:
        return []
    bins = _bins(data)
    chosen = next((r for r in earlier if _reaches(r.record, scale, bins)), None)
    if chosen is None:
        return []
    record, verdict = chosen.record, data.verdict["verdict"]
    outcomes = {(str(r.metric), str(r.easier), str(r.harder)): str(r.outcome) for r in verdict.itertuples()}
    now = {by: {} for by in ("policies", "episodes")}
    still_open = []
    for relation in record["sized"]:
        key = (relation["metric"], relation["easier"], relation["harder"])
        outcome = outcomes.get(key, "missing")
        now[relation["by"]][outcome] = now[relation["by"]].get(outcome, 0) + 1
        if outcome in OPEN:
            still_open.append(f"{data.registry.label(key[0])} on {data.name(key[1])} easier than "
                              f"{data.name(key[2])} ({outcome})")
    n0, m0 = record["now"]
    held = f", B = {record['bins']:,} held" if record.get("bins") is not None else ""
    parts = [f"of the {plural(sum(counts.values()), 'relation')} it sized by {'N' if by == 'policies' else 'M'}, "
             f"now {_counted_outcomes(counts)}" for by, counts in now.items() if counts]
    sentences = [f"This run reaches the next budget that the report of {chosen.built} (N = {n0:,} × M = {m0:,}) "
                 f"recommended, N = {shown_size(record['policies'])} × M = {shown_size(record['episodes'])}{held}: "
                 f"{'; '.join(parts)}."]
    if still_open:
        shown = still_open[:3] + ([f"{len(still_open) - 3} more"] if len(still_open) > 3 else [])
        sentences.append(f"Still open: {and_list(shown)}.")
    if now["policies"]:
        sentences.append("The N it gave a relation is a median projection from one noisy t statistic: about half of "
                         "the relations sized by N alone resolve there, the others need more.")
    return sentences


def _reaches(record: dict, scale: tuple[int, int], bins: int | None) -> bool:
    """Whether a run at ``scale`` (N, M) and ``bins`` reaches a recommended budget (a :meth:`NextBudget.record`)."""
    try:
        wanted = (int(record["policies"]), int(record["episodes"]))
        changed = wanted != tuple(record["now"])
        same_bins = record.get("bins") is None or record["bins"] == bins
        return changed and scale[0] >= wanted[0] and scale[1] >= wanted[1] and same_bins and bool(record["sized"])
    except (KeyError, TypeError, ValueError):
        return False


def _counted_outcomes(counts: dict[str, int]) -> str:
    """"2 agree, 1 not significant"."""
    return ", ".join(f"{n} {outcome}" for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]))


def _counted(counts: dict[str, int]) -> str:
    """"3 relations of PIC and 1 of POIC"."""
    parts = [f"{plural(n, 'relation') if i == 0 else n} of {label}" for i, (label, n) in enumerate(counts.items())]
    return and_list(parts)


UNSIZED = {
    "value": "a value equal to its null or at its ceiling",
    "turned": "excesses over the nulls that order the pair the other way",
    "estimator": "a difference mostly the nulls' of a non-histogram estimator, whose nulls' fall with M is not "
                 "measured",
    "none": "no difference to resolve",
}
"""Why an open relation is not sized, by kind (module docstring)."""


def _size(row, registry, episodes: int | None) -> tuple[str, float]:
    """What sizes a verdict row: ("policies", N′), ("episodes", M′), or (a key of :data:`UNSIZED`, NaN)."""
    if row["outcome"] == "not significant":
        needed = float(row["policies_to_resolve"])
        if np.isnan(needed):
            return "none", needed
        return ("policies", needed) if np.isfinite(needed) else ("none", float("nan"))
    metric = registry[row["metric"]] if row["metric"] in registry else None
    if not (bool(row["informative_easier"]) and bool(row["informative_harder"])):
        return "value", float("nan")
    if metric is None or metric.information is None or not metric.information.binned or episodes is None:
        return "estimator", float("nan")
    size = episodes_to_settle(float(row["null_share_of_difference"]), episodes)
    return ("episodes", size) if np.isfinite(size) else ("turned", float("nan"))


def shown_size(value: float) -> str:
    """A size as the table and the headline show it: rounded up to 2 significant digits, "5 500"."""
    return significant_int(_round_up(value))


def _round_up(value: float) -> float:
    """``value`` rounded up to 2 significant digits (5 430 → 5 500), as the cells show it."""
    if value < 100:
        return float(np.ceil(value))
    scale = 10 ** (int(np.floor(np.log10(value))) - 1)
    return float(np.ceil(value / scale) * scale)


def _scale(data: StudyData) -> tuple[int, int] | None:
    scales = {(int(p), int(e)) for p, e in zip(data.metrics["policies"], data.metrics["episodes"], strict=True)}
    return scales.pop() if len(scales) == 1 else None


def _episodes(data: StudyData) -> int | None:
    scale = _scale(data)
    return None if scale is None else scale[1]


def _bins(data: StudyData) -> int | None:
    found = {int(r.metrics.manifest.get("config", {}).get("bins", 0)) for r in data.results.values()
             if getattr(r, "metrics", None) is not None}
    return found.pop() if len(found) == 1 and 0 not in found else None
