"""How each verdict outcome is shown: its one-character mark, its colour class and its legend text.

:data:`OUTCOME_DISPLAY` is the one place that maps an outcome of the verdict artefact to what the report
shows; the matrices, their legends, the files' words and the page's colours all read it, so a new outcome
of the verdict stage needs one entry here and no other change.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass


@dataclass(frozen=True)
class OutcomeDisplay:
    """How one outcome is shown.

    Attributes
    ----------
    mark : str
        One character in the relation × metric matrices.
    css : str
        Colour class of its cells on the page.
    legend : str
        What the mark means, for a matrix's caption.
    """

    mark: str
    css: str
    legend: str


OUTCOME_DISPLAY = {
    "agree": OutcomeDisplay("✓", "agree", "the metric orders the pair as known and the difference is significant"),
    "contradict": OutcomeDisplay("✗", "contradict", "it orders them the other way, significantly"),
    "not significant": OutcomeDisplay("–", "ns", "not significant (or untested)"),
    "uninformative": OutcomeDisplay("○", "uninformative",
                                    "uninformative: a value equals its null or sits at its ceiling"),
    "undefined": OutcomeDisplay("?", "ns", "undefined (a value is missing or not finite)"),
}
"""Outcome of the verdict artefact → how the report shows it, in legend order."""

UNKNOWN_MARK = "·"
"""The mark of an outcome missing from :data:`OUTCOME_DISPLAY` (its legend is the outcome's name)."""


def display(outcome: str) -> OutcomeDisplay:
    """How ``outcome`` is shown (a neutral mark for an outcome not in :data:`OUTCOME_DISPLAY`)."""
    return OUTCOME_DISPLAY.get(outcome, OutcomeDisplay(UNKNOWN_MARK, "ns", str(outcome)))


def mark(outcome: str) -> str:
    """The matrix mark of ``outcome``."""
    return display(outcome).mark


UNINFORMATIVE_REASONS = {
    "null": "a value equals its permutation null",
    "ceiling": "a value sits at its ceiling ln N",
    "nulls": "most of the difference is the difference of the two tasks' permutation nulls",
}
"""Why a verdict is uninformative (:func:`uninformative_reasons`) → the words of its legend and tooltip."""


def uninformative_reasons(row, information: dict[tuple[str, str], str]) -> tuple[str, ...]:
    """The reasons (keys of :data:`UNINFORMATIVE_REASONS`) one verdict row is uninformative, () otherwise.

    Parameters
    ----------
    row : mapping
        A row of the verdict artefact (``metric``, ``easier``, ``harder``, ``outcome``,
        ``informative_easier``, ``informative_harder``).
    information : dict of (metric, task) to str
        The information check's ``reason`` of each checked value ("" when informative).
    """
    if row["outcome"] != "uninformative":
        return ()
    found = []
    for side in ("easier", "harder"):
        if not bool(row[f"informative_{side}"]):
            reason = information.get((row["metric"], row[side]), "")
            found += [key for key, cause in (("null", "permutation null"), ("ceiling", "ceiling")) if cause in reason]
    if bool(row["informative_easier"]) and bool(row["informative_harder"]):
        found.append("nulls")
    return tuple(key for key in UNINFORMATIVE_REASONS if key in found)


def legend(outcomes: Iterable[str], reasons: Iterable[str] = ()) -> str:
    """``✓ …; ✗ …`` for the outcomes given, in :data:`OUTCOME_DISPLAY` order (unknown ones last).

    ``reasons`` (keys of :data:`UNINFORMATIVE_REASONS`) are the reasons behind the ○ cells shown: the legend
    of ○ lists only those (all of them when none is given).
    """
    present = list(dict.fromkeys(outcomes))
    ordered = [o for o in OUTCOME_DISPLAY if o in present] + [o for o in present if o not in OUTCOME_DISPLAY]
    reasons = set(reasons)

    def words(outcome: str) -> str:
        if outcome != "uninformative" or not reasons:
            return display(outcome).legend
        return "uninformative: " + " or ".join(w for k, w in UNINFORMATIVE_REASONS.items() if k in reasons)

    return "; ".join(f"{mark(o)} {words(o)}" for o in ordered)
