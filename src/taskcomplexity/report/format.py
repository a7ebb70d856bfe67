"""Number and text formatting shared by every table of the report (one format per kind of number)."""

from __future__ import annotations

import re

import numpy as np

MISSING = "–"
"""What a missing or non-finite number shows as."""


def decimals(reference: float, digits: int = 3) -> int:
    """Decimals showing ``digits`` significant digits of a small ``reference``, else ``digits`` decimals."""
    if not np.isfinite(reference) or abs(reference) >= 0.1 or reference == 0:
        return digits
    return int(min(8, digits - 1 - np.floor(np.log10(abs(reference)))))


def num(value: float, digits: int = 3, *, like: float | None = None) -> str:
    """A number for a table: 3 decimals, or 3 significant digits below 0.1 (decimals of ``like`` if given)."""
    if value is None or not np.isfinite(value):
        return MISSING
    if abs(value) >= 1e5:
        return f"{value:.{digits}g}"
    return f"{value:.{decimals(value if like is None else like, digits)}f}"


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def pvalue(value: float) -> str:
    """A p-value to 2 significant digits, small ones as ``5.6×10⁻¹⁰`` (no break inside)."""
    if value is None or not np.isfinite(value):
        return MISSING
    if value < 1e-10:
        return "<\u00a010⁻¹⁰"
    if value >= 1e-3:
        return f"{value:.2g}"
    mantissa, exponent = f"{value:.1e}".split("e")
    return f"{mantissa}×10{str(int(exponent)).translate(_SUPERSCRIPTS)}"


def statistic(value: float) -> str:
    """A test statistic to 3 significant digits, without exponent notation, with a true minus sign."""
    if value is None or np.isnan(value):
        return MISSING
    text = f"{value:.0f}" if abs(value) >= 1000 else f"{value:.3g}"
    return text.replace("-", "−")


def mean_sd(mean: float, sd: float, digits: int = 3) -> str:
    """``mean ± sd`` with the same number of decimals on both sides."""
    if mean is None or not np.isfinite(mean):
        return MISSING
    places = decimals(mean, digits)
    return f"{mean:.{places}f} ± {sd:.{places}f}" if np.isfinite(sd) else f"{mean:.{places}f}"


def plural(count: int, noun: str, many: str | None = None) -> str:
    """``count`` and ``noun`` in the number it needs: "1 relation", "0 relations", "3 tasks".

    ``many``: the plural when it is not ``noun + "s"`` (e.g. ``plural(n, "policy", "policies")``).
    """
    count = int(count)
    return f"{count} {noun if count == 1 else (many or noun + 's')}"


def of_total(part: int, total: int, noun: str, many: str | None = None) -> str:
    """``part`` of ``total`` things in words that read right at every count.

    "2 of the 7 known relations", "none of the 7 known relations", "all 7 known relations", "both known
    relations", and with one thing "the one known relation" (part 1) or "no known relation" (part 0): never
    "0 of 1".
    """
    part, total = int(part), int(total)
    if total == 1:
        return f"the one {noun}" if part == 1 else f"no {noun}"
    things = many or noun + "s"
    if part == 0:
        return f"none of the {total} {things}"
    if part == total:
        return f"both {things}" if total == 2 else f"all {total} {things}"
    return f"{part} of the {total} {things}"


def joined(values) -> str:
    """Distinct values in order, comma-separated."""
    return ", ".join(dict.fromkeys(str(v) for v in values))


_LATEX = {
    "−": "$-$", "×": "$\\times$", "✓": "$\\surd$", "✗": "$\\times$", "Θ": "$\\Theta$", "λ": "$\\lambda$",
    "τ": "$\\tau$", "Δ": "$\\Delta$", "√": "$\\surd$", "ₙ": "$_n$", "′": "$'$", "·": "$\\cdot$", "\u00a0": "~",
    "<": "$<$", ">": "$>$", "|": "$|$", "○": "$\\circ$", "≈": "$\\approx$", "\u2009": "\\,",
}
_SUPERSCRIPT_RUN = re.compile("[⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+")


def latex_text(text: str) -> str:
    """Replace the report's non-ASCII symbols by LaTeX that compiles with pdflatex (``10⁻⁴`` → ``10$^{-4}$``)."""
    digits = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")
    text = _SUPERSCRIPT_RUN.sub(lambda m: "$^{" + m.group(0).translate(digits) + "}$", text)
    for symbol, macro in _LATEX.items():
        text = text.replace(symbol, macro)
    return text


def slug(text: str) -> str:
    """A file-name-safe version of ``text``."""
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_") or "ablation"


def percent(share: float) -> str:
    """A share as a percentage ("99.8 %"), or the missing mark."""
    return MISSING if not np.isfinite(share) else f"{100 * share:.1f} %"


def significant_int(value: float, digits: int = 2) -> str:
    """An integer rounded to ``digits`` significant digits, with thin-space thousands (1 700, 25 000)."""
    rounded = int(float(f"{value:.{digits}g}")) if value >= 10 ** digits else int(np.ceil(value))
    return f"{rounded:,}".replace(",", " ")



def and_list(items) -> str:
    """Items joined as a sentence lists them: "A", "A and B", "A, B and C" ("" when there are none)."""
    items = [str(i) for i in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + f" and {items[-1]}" if items else ""


def naming(items, noun: str, many: str | None = None, *, at_most: int = 3) -> tuple[str, str]:
    """The subject naming ``items``, and a trailing example for when they are too many to name.

    Up to ``at_most`` by name ("A", "A and B", "A, B and C"; no example), more by count with the first
    two as the example ("5 measures", ", e.g. A and B"), none as "no " + ``noun``.
    """
    items = [str(i) for i in items]
    if not items:
        return f"no {noun}", ""
    if len(items) <= at_most:
        return and_list(items), ""
    return plural(len(items), noun, many), f", e.g. {and_list(items[:2])}"
