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


def legend(outcomes: Iterable[str]) -> str:
    """``✓ …; ✗ …`` for the outcomes given, in :data:`OUTCOME_DISPLAY` order (unknown ones last)."""
    present = list(dict.fromkeys(outcomes))
    ordered = [o for o in OUTCOME_DISPLAY if o in present] + [o for o in present if o not in OUTCOME_DISPLAY]
    return "; ".join(f"{mark(o)} {display(o).legend}" for o in ordered)
