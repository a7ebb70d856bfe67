"""The headline's sentences as functions of plain verdict tables: ties name every tied measure, counts are the
table's, and survival counts only significant verdicts of informative estimators."""

from __future__ import annotations

import re

import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from taskcomplexity.report.format import and_list, naming
from taskcomplexity.report.headline import measure_sentence, primary_sentence, survival_sentence
from taskcomplexity.report.verdict_tables import RELATION
from taskcomplexity.verdict.judge import survival as survival_of

OUTCOMES = ("agree", "contradict", "not significant", "undefined", "uninformative")
COUNTS = {"agreements": "agree", "contradictions": "contradict", "not_significant": "not significant",
          "uninformative": "uninformative", "undefined": "undefined"}


def tables(outcomes: dict[str, list[str]]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(summary, verdict) of metric → one outcome per relation (relation i: task ``t{i}`` easier than ``u{i}``)."""
    verdict = pd.DataFrame([{"metric": m, "easier": f"t{i}", "harder": f"u{i}", "outcome": o}
                            for m, row in outcomes.items() for i, o in enumerate(row)])
    summary = pd.DataFrame([{"metric": m, "relations": len(row), **{c: row.count(o) for c, o in COUNTS.items()}}
                            for m, row in outcomes.items()])
    return summary, verdict


def label(metric: str) -> str:
    return metric.upper()


def name(task: str) -> str:
    return f"Task {task}"


def sentence(outcomes, comparable=lambda m: True):
    summary, verdict = tables(outcomes)
    return measure_sentence(summary, verdict, label=label, name=name, comparable=comparable)


def test_and_list_and_naming_read_right_at_every_count():
    assert [and_list(x) for x in ([], ["A"], ["A", "B"], ["A", "B", "C"])] == ["", "A", "A and B", "A, B and C"]
    assert naming([], "measure") == ("no measure", "")
    assert naming(["A", "B", "C"], "measure") == ("A, B and C", "")
    assert naming(list("ABCDE"), "measure") == ("5 measures", ", e.g. A and B")


def test_two_measures_tied_at_the_top_are_both_named():
    agree9 = ["agree"] * 9 + ["not significant"]
    text = sentence({"a": agree9, "b": agree9, "c": ["agree"] * 5 + ["not significant"] * 5})
    assert text.startswith("Of the 3 measures on one scale across tasks, A and B agree with the known relations "
                           "most often (9 of 10 each); no measure contradicts them significantly.")


def test_three_tied_measures_are_listed_and_more_are_counted_with_an_example():
    agree9 = ["agree"] * 9 + ["not significant"]
    three = sentence({"a": agree9, "b": agree9, "c": agree9, "d": ["not significant"] * 10})
    assert "A, B and C agree with the known relations most often (9 of 10 each);" in three
    five = sentence({**{m: agree9 for m in "abcde"}, "f": ["agree"] + ["not significant"] * 9})
    assert "5 measures agree with the known relations most often (9 of 10 each), e.g. A and B;" in five


def test_when_every_measure_agrees_with_every_relation_the_sentence_says_all_of_them():
    text = sentence({m: ["agree"] * 4 for m in "abcdefgh"})
    assert text == ("Of the 8 measures on one scale across tasks, all 8 agree with every known relation; "
                    "no measure contradicts them significantly.")


def test_tied_contradicting_measures_are_all_named():
    row = ["contradict"] * 3 + ["not significant"] * 7
    text = sentence({"a": ["agree"] * 4 + ["not significant"] * 6, "b": row, "c": row})
    assert ("; B and C contradict them most often (3 of 10 each): for example, B rates Task u0 easier than "
            "Task t0.") in text


def test_none_agrees_more_often_than_it_contradicts_when_the_best_net_has_no_agreement():
    text = sentence({"a": ["not significant"] * 4, "b": ["agree", "contradict", "contradict", "contradict"]})
    assert "none agrees with the known relations more often than it contradicts them" in text


def primary(outcomes, metrics, alpha=0.05):
    summary, verdict = tables(outcomes)
    return primary_sentence(summary, verdict, metrics, label=label, alpha=alpha)


def test_the_primary_sentence_says_none_is_significant_and_counts_the_rest():
    text = primary({"pic": ["not significant"] * 4 + ["undefined"], "poic": ["not significant"] * 5},
                   ["pic", "poic"])
    assert text == ("Against the 5 known complexity relations, none of the 10 verdicts of PIC and POIC is significant "
                    "(Welch's test, p < 0.05): 9 are not significant and 1 undefined.")


def test_the_primary_sentence_counts_each_kind_of_the_other_verdicts():
    mixed = primary({"pic": ["agree", "not significant", "undefined"], "poic": ["contradict", "agree", "agree"]},
                    ["pic", "poic"])
    assert mixed == ("Against the 3 known complexity relations, PIC agrees with 1 and contradicts 0; POIC agrees "
                     "with 2 and contradicts 1 (Welch's test, p < 0.05; of the other 2 verdicts, 1 is not "
                     "significant and 1 undefined).")
    one = primary({"pic": ["agree", "not significant"], "poic": ["agree", "contradict"]}, ["pic", "poic"])
    assert one.endswith("(Welch's test, p < 0.05; the other verdict is not significant).")
    single = primary({"pic": ["undefined"], "poic": ["not significant"]}, ["pic", "poic"])
    assert single == ("Against the known complexity relation, PIC is undefined on it; POIC is not significant on it "
                      "(none significant at p < 0.05, Welch's test).")


def test_the_primary_sentence_cites_the_test_only_where_a_verdict_reached_its_cut_off():
    blank = primary({"pic": ["uninformative"] * 3, "poic": ["uninformative"] * 3}, ["pic", "poic"])
    assert blank == ("Against the 3 known complexity relations, PIC is uninformative on every one; POIC is "
                     "uninformative on every one.")
    untested = primary({"pic": ["uninformative"] * 3, "poic": ["uninformative", "uninformative", "undefined"]},
                       ["pic", "poic"])
    assert untested.endswith("POIC agrees with 0 and contradicts 0 and is uninformative on 2 (the other verdict is "
                             "undefined).")
    open_ = primary({"pic": ["uninformative"] * 3, "poic": ["uninformative", "not significant", "not significant"]},
                    ["pic", "poic"])
    assert open_.endswith("(none significant at p < 0.05, Welch's test; the other 2 verdicts are not significant).")


def survival(rows: list[list[str]], estimators=("PIC", "PIC (MM)", "kNN")) -> pd.DataFrame:
    table = pd.DataFrame(rows, columns=list(estimators))
    table.insert(0, "Kind", "k")
    table.insert(0, RELATION, [f"r{i}" for i in range(len(rows))])
    table["Survives"] = [survival_of(r) for r in rows]
    return table


def test_survival_leaves_out_uninformative_estimators_and_names_them():
    table = survival([["uninformative", "agree", "agree"], ["agree", "agree", "agree"],
                      ["not significant", "not significant", "not significant"]])
    assert survival_sentence("I(Θ; R)", table) == (
        "2 of the 3 relations have a significant verdict on I(Θ; R); of those, both survive a change of estimator "
        "(PIC, PIC (MM), kNN; left out where uninformative: PIC on 1 of the 3 relations).")


def test_survival_is_never_claimed_of_verdicts_that_are_all_not_significant():
    table = survival([["not significant"] * 3, ["uninformative", "not significant", "not significant"]])
    text = survival_sentence("I(Θ; R)", table)
    assert "surviv" not in text and text.startswith("No informative estimator gives a significant verdict on I(Θ; R)")
    assert survival_sentence("I(Θ; R)", survival([["not significant"] * 3])).startswith("No informative estimator")


def test_survival_counts_a_disagreement_between_informative_estimators():
    table = survival([["agree", "not significant", "agree"], ["agree", "agree", "agree"]])
    assert survival_sentence("I(Θ; R)", table) == (
        "Both relations have a significant verdict on I(Θ; R); of those, 1 survives a change of estimator (PIC, "
        "PIC (MM), kNN).")
    lone = survival([["agree", "uninformative", "uninformative"]])
    assert "no other informative estimator" in survival_sentence("I(Θ; R)", lone)
    assert survival_sentence("I(Θ; R)", survival([["agree", "agree", "uninformative"]])) == (
        "The significant verdict on I(Θ; R) survives a change of estimator (PIC, PIC (MM), kNN; left out where "
        "uninformative: kNN).")


# Properties over random verdict tables.

@st.composite
def outcome_tables(draw):
    metrics = [f"m{i:02d}" for i in range(draw(st.integers(2, 17)))]
    relations = draw(st.integers(1, 12))
    kind = draw(st.sampled_from(("random", "all not significant", "all uninformative", "tied")))
    row = st.lists(st.sampled_from(OUTCOMES), min_size=relations, max_size=relations)
    if kind == "all not significant":
        table = {m: ["not significant"] * relations for m in metrics}
    elif kind == "all uninformative":
        table = {m: ["uninformative"] * relations for m in metrics}
    elif kind == "tied":
        base = draw(row)
        table = {m: base if draw(st.booleans()) else draw(row) for m in metrics}
    else:
        table = {m: draw(row) for m in metrics}
    comparable = set(draw(st.lists(st.sampled_from(metrics), unique=True, min_size=0, max_size=len(metrics))))
    if draw(st.booleans()):
        comparable = set(metrics)
    chosen = draw(st.integers(1, min(3, len(metrics))))
    return table, comparable, metrics[:chosen]


NAMED = re.compile(r"M\d\d")


@settings(max_examples=500, deadline=None)
@given(outcome_tables())
def test_the_best_measure_sentence_states_the_tables_counts_and_names_only_the_tied_best(drawn):
    table, comparable, _ = drawn
    text = sentence(table, comparable=lambda m: m in comparable)
    assert set(NAMED.findall(text)) <= {label(m) for m in comparable}
    if not comparable:
        assert text.startswith("No measure is on one scale across tasks")
        return
    summary = tables({m: r for m, r in table.items() if m in comparable})[0]
    summary = summary.assign(net=summary["agreements"] - summary["contradictions"])
    relations = len(next(iter(table.values())))
    top = summary[summary["net"] == summary["net"].max()]
    top = top[top["agreements"] == top["agreements"].max()]
    bottom = summary[summary["contradictions"] == summary["contradictions"].max()]
    bottom = bottom[bottom["net"] == bottom["net"].min()]
    assert text.startswith(f"Of the {len(summary)} measure")
    agreeing, contradicting = text.split("; ", 1)
    assert set(NAMED.findall(agreeing)) <= {label(m) for m in top["metric"]}
    if "none agrees significantly" in agreeing:
        assert summary["agreements"].max() == 0
    elif "more often than it contradicts" in agreeing:
        assert summary["net"].max() <= 0 and top["agreements"].max() == 0
    else:
        assert top["agreements"].iloc[0] > 0
        counted = re.search(r"(\d+) measures agree", agreeing)
        named = NAMED.findall(agreeing.split(", e.g.")[0])
        if counted:
            assert int(counted.group(1)) == len(top) > 3
        elif re.search(r"(both|all \d+) agree", agreeing):
            assert len(top) == len(summary)
            everyone = re.search(r"all (\d+) agree", agreeing)
            assert everyone is None or int(everyone.group(1)) == len(summary)
        else:
            assert set(named) == {label(m) for m in top["metric"]}
        share = re.search(r"\((\d+) of (\d+)( each)?\)", agreeing)
        if share:
            assert (int(share.group(1)), int(share.group(2))) == (top["agreements"].iloc[0], relations)
            assert bool(share.group(3)) == (len(top) > 1)
        if "every known relation" in agreeing:
            assert (summary["agreements"] == relations).all()
    if "no measure contradicts" in contradicting:
        assert summary["contradictions"].max() == 0
    else:
        subject = contradicting.split(" contradict")[0]
        counted = re.match(r"(\d+) measures", subject)
        if counted:
            assert int(counted.group(1)) == len(bottom) > 3
        elif subject not in ("both",) and not subject.startswith("all "):
            assert set(NAMED.findall(subject)) == {label(m) for m in bottom["metric"]}
        else:
            assert len(bottom) == len(summary)
        share = re.search(r"\((\d+) of (\d+)( each)?\)", contradicting)
        if share:
            assert (int(share.group(1)), int(share.group(2))) == (bottom["contradictions"].iloc[0], relations)
        example = NAMED.findall(contradicting.split("for example, ")[1])
        assert set(example) <= {label(m) for m in bottom["metric"]}


@settings(max_examples=500, deadline=None)
@given(outcome_tables())
def test_the_primary_sentence_states_the_tables_counts(drawn):
    table, _, chosen = drawn
    text = primary(table, chosen)
    relations = len(next(iter(table.values())))
    outcomes = [o for m in chosen for o in table[m]]
    assert set(NAMED.findall(text)) <= {label(m) for m in chosen}
    if relations > 1:
        assert text.startswith(f"Against the {relations} known complexity relations, ")
    none = re.search(r"none of the (\d+) verdicts of .* is significant", text)
    if none:
        assert int(none.group(1)) == len(outcomes)
        assert not set(outcomes) & {"agree", "contradict", "uninformative"}
        for o in ("not significant", "undefined"):
            stated = re.search(rf"(\d+) (?:is |are )?{o}", text)
            assert (int(stated.group(1)) if stated else 0) == outcomes.count(o)
        return
    for m in chosen:
        row = table[m]
        if relations == 1:
            word = {"agree": "agrees with it", "contradict": "contradicts it", "uninformative": "is uninformative on it",
                    "not significant": "is not significant on it", "undefined": "is undefined on it"}[row[0]]
            assert f"{label(m)} {word}" in text
        elif row.count("uninformative") == relations:
            assert f"{label(m)} is uninformative on every one" in text
        else:
            part = f"{label(m)} agrees with {row.count('agree')} and contradicts {row.count('contradict')}"
            if row.count("uninformative"):
                part += f" and is uninformative on {row.count('uninformative')}"
            assert part + ";" in text or part + " (" in text
    if relations > 1:
        counts = {o: outcomes.count(o) for o in ("not significant", "undefined")}
        rest = sum(counts.values())
        if not {"agree", "contradict"} & set(outcomes):  # no verdict reached the cut-off: the test is not cited
            cut = "none significant at p < 0.05, Welch's test" if "not significant" in outcomes else ""
            assert "Welch's test, p < 0.05" not in text
            tail = text.split(f"({cut}", 1)[1] if cut or "(" in text else ")."
            if not cut and tail != ").":
                tail = "; " + tail
        else:
            tail = text.split("(Welch's test, p < 0.05", 1)[1]
        if rest == 0:
            assert tail == ")."
        elif all(counts.values()):
            ns = counts["not significant"]
            assert tail == (f"; of the other {rest} verdicts, {ns} {'is' if ns == 1 else 'are'} not significant and "
                            f"{counts['undefined']} undefined).")
        else:
            o = next(o for o, n in counts.items() if n)
            assert tail == (f"; the other verdict is {o})." if rest == 1 else f"; the other {rest} verdicts are {o}).")


SURVIVAL_OUTCOMES = ("agree", "contradict", "not significant", "uninformative")
ESTIMATORS = ("PIC", "PIC (MM)", "kNN", "E4", "E5")


def counted(phrase: str) -> int:
    """The count in of_total's words: "2 of the 3 relations", "all 3 relations", "both relations", "the one …"."""
    found = re.match(r"(\d+) of the|all (\d+)|(both)|the one", phrase)
    return int(found.group(1) or found.group(2) or 0) or (2 if found.group(3) else 1)


@st.composite
def survival_tables(draw):
    estimators = draw(st.integers(2, 5))
    relations = draw(st.integers(1, 12))
    rows = draw(st.lists(st.lists(st.sampled_from(SURVIVAL_OUTCOMES), min_size=estimators, max_size=estimators),
                         min_size=relations, max_size=relations))
    return rows


@settings(max_examples=500, deadline=None)
@given(survival_tables())
def test_the_survival_sentence_counts_what_the_table_holds(rows):
    text = survival_sentence("I(Θ; R)", survival(rows, ESTIMATORS[:len(rows[0])]))
    # Counted independently of the composer: a relation is judged when an informative estimator is significant;
    # it survives when at least two estimators are informative and all of those reach one outcome.
    informative = [[o for o in row if o != "uninformative"] for row in rows]
    judged = [any(o in ("agree", "contradict") for o in row) for row in informative]
    survives = [j and len(row) >= 2 and len(set(row)) == 1 for j, row in zip(judged, informative, strict=True)]
    if not any(judged):
        assert "surviv" not in text and text.startswith("No informative estimator gives a significant verdict")
        return
    if len(rows) == 1:
        alone = len(informative[0]) < 2
        assert ("no other informative estimator" in text) == alone
        if not alone:
            assert ("does not survive" in text) == (not survives[0])
        return
    assert re.match(r"[^;]* relations? ha(?:s|ve) a significant verdict on I\(Θ; R\); of those, ", text)
    assert counted(text.split(" ha", 1)[0].lower()) == sum(judged)
    kept = re.search(r"of those, (none|\d+|it|both|all) surviv", text).group(1)
    expected = {"none": 0, "it": 1, "both": 2, "all": sum(judged)}.get(kept)
    assert (int(kept) if expected is None else expected) == sum(survives)
    # Exactly the estimators uninformative somewhere are named as left out, each on as many relations as it has.
    left = text.split("left out where uninformative: ")[1] if "left out where" in text else ""
    left = left[:left.rfind(")")]
    named = {}
    for item in re.split(r", | and ", left) if left else []:
        estimator, phrase = item.split(" on ", 1)
        named[estimator] = counted(phrase)
    blank = {e: sum(row[i] == "uninformative" for row in rows) for i, e in enumerate(ESTIMATORS[:len(rows[0])])}
    assert named == {e: n for e, n in blank.items() if n}


# --- more sampling ----------------------------------------------------------------------------------------------


def sampling_data(bins: int, policies: int = 1000, episodes: int = 50):
    """A study's artefacts as resolve_sentences reads them: PIC and POIC not significant on relation t0 > u0 (Welch
    would resolve them at N ≈ 5,000 and 8,000), PIC's difference on t1 > u1 80 % the nulls' (M′ = 50·(0.8/0.25)² =
    800 settles it, at a held B), where PIC − null agrees, and PIC uninformative on t2 > u2 with a value equal to its
    null (not sized)."""
    from types import SimpleNamespace

    from taskcomplexity.metrics import DEFAULT_REGISTRY

    def row(metric, i, outcome, resolve=float("nan"), informative=True, share=float("nan")):
        return {"metric": metric, "easier": f"t{i}", "harder": f"u{i}", "outcome": outcome, "policies": policies,
                "policies_to_resolve": resolve, "informative_easier": informative, "informative_harder": informative,
                "null_share_of_difference": share}

    verdict = pd.DataFrame([row("pic", 0, "not significant", 5000.0), row("poic", 0, "not significant", 8000.0),
                            row("pic", 1, "uninformative", share=0.8), row("pic_minus_null", 1, "agree"),
                            row("pic", 2, "uninformative", informative=False, share=0.3)])
    manifest = SimpleNamespace(manifest={"config": {"bins": bins}})
    return SimpleNamespace(verdict={"verdict": verdict}, registry=DEFAULT_REGISTRY,
                           metrics=pd.DataFrame({"policies": [policies] * 2, "episodes": [episodes] * 2}),
                           results={t: SimpleNamespace(metrics=manifest) for t in ("a", "b")})


def test_the_next_budget_is_one_n_m_b_that_the_headline_and_the_verdict_table_read_alike():
    from taskcomplexity.metrics.pic import auto_bins
    from taskcomplexity.report.budget import next_budget, to_resolve
    from taskcomplexity.report.headline import resolve_sentences

    data = sampling_data(bins=auto_bins(1000, 50))
    budget = next_budget(data)
    # N: the larger of the two projections (8 000); M: the nulls' share 0.8 → 0.5 needs the nulls scaled by
    # f = 0.5·0.2/(0.8·0.5) = 0.25, so M′ = 50/0.25² = 800; B held at its value now
    assert (budget.policies, budget.episodes, budget.bins) == (8000, 800, 1000)
    assert budget.overrides() == "study.policies=8000 study.episodes=800 metrics.bins=1000"
    thin = "\u2009"  # the thousands separator of a size
    assert list(to_resolve(data)) == [f"N ≈ 5{thin}000", f"N ≈ 8{thin}000", "M ≈ 800", "–", "–"]
    lead, by_n, by_m, unsized, net = resolve_sentences(data)
    assert lead.replace(thin, " ") == ("Next budget: N = 8 000 policies × M = 800 episodes, B = 1,000 held (now N = 1,000 × M = 50; "
                    "study.policies=8000 study.episodes=800 metrics.bins=1000).")
    assert by_n.replace(thin, " ").startswith("At N = 8 000 (this M and B) Welch's test would resolve 1 relation of PIC and 1 of POIC "
                           "now not significant, assuming the batches' sd falls as N^-1/2")
    assert "the permutation nulls move with N too, and the report does not predict them there." in by_n
    assert by_m == ("At M = 800 (this B) the nulls' share of the difference falls to 50 % on 1 relation of PIC whose "
                    "difference is now mostly the nulls', assuming each null falls at least as M^-1/2 and the excesses "
                    "over the nulls stay; more policies do not settle those (under metrics.bins=auto, B = N·M/50 "
                    "grows with N and the values approach their nulls: hold B with metrics.bins=1000).")
    assert unsized == "Not sized by either: 1 relation of PIC (a value equal to its null or at its ceiling)."
    assert net == ("On the 1 relation where PIC's difference is mostly the nulls', PIC − null, net of its nulls, "
                   "agrees on 1 of them.")


def test_with_a_b_off_the_auto_rule_the_next_budget_says_nothing_of_auto():
    from taskcomplexity.report.headline import resolve_sentences

    text = " ".join(resolve_sentences(sampling_data(bins=100_000)))
    assert "B = 100,000 held" in text and "metrics.bins=auto" not in text


def test_a_run_at_the_recommended_budget_re_checks_the_relations_it_sized():
    from taskcomplexity.report.budget import Recommendation, next_budget, recheck_sentences

    before = sampling_data(bins=1000)
    record = next_budget(before).record()
    assert [(r["metric"], r["by"], r["size"]) for r in record["sized"]] == [
        ("pic", "policies", 5000), ("poic", "policies", 8000), ("pic", "episodes", 800)]
    after = sampling_data(bins=1000, policies=8000, episodes=800)
    after.verdict["verdict"]["outcome"] = ["agree", "not significant", "contradict", "agree", "uninformative"]
    after.name = lambda task: task.upper()
    earlier = [Recommendation("2026-01-02 10:00", record)]
    first, still, median = recheck_sentences(after, earlier)
    assert first == ("This run reaches the next budget that the report of 2026-01-02 10:00 (N = 1,000 × M = 50) "
                     "recommended, N = 8\u2009000 × M = 800, B = 1,000 held: of the 2 relations it sized by N, now "
                     "1 agree, 1 not significant; of the 1 relation it sized by M, now 1 contradict.")
    assert still == "Still open: POIC on T0 easier than U0 (not significant)."
    assert median.startswith("The N it gave a relation is a median projection")
    # a run short of the budget, or at another B, re-checks nothing; a newer recommendation it reaches wins
    assert recheck_sentences(sampling_data(bins=1000, policies=5000, episodes=800), earlier) == []
    assert recheck_sentences(sampling_data(bins=500, policies=8000, episodes=800), earlier) == []
    newer = Recommendation("2026-01-03 10:00", {**record, "sized": record["sized"][:1], "policies": 5000})
    assert "of the 1 relation it sized by N, now 1 agree." in recheck_sentences(after, [newer, *earlier])[0]
