"""The report of a study: figures, tables, the verdict in words, Markdown and one HTML page, read from artefacts only.

Modules
-------
beyond
    Beyond the paper: whether each metric the paper's conclusion proposes agrees where PIC and POIC do not.
budget
    The next budget: one (N, M, B) that the headline recommends and the full verdict table sizes.
build
    A study's report from its artefacts: ``index.html``, ``report.md``, ``figures/``, ``tables/``.
data
    Everything the report reads, loaded from the stages' artefacts (the report computes no metric).
figures
    The figures (seaborn on matplotlib), each saved as PNG and PDF.
format
    Number and text formatting shared by every table (one format per kind of number).
groups
    A study's ordered difficulty groups: the headline, the figure of every metric by group, the rank-agreement
    and group-relations tables.
headline
    The verdict in words: one or two sentences, then the details.
html
    One self-contained HTML page: the report's document model and its renderer.
labels
    How each task is shown: its name, colour, marker and group, from the study file.
markdown
    ``report.md``: the document's text in Markdown, figures linked and tables inline.
methods
    The methods box: sampling, estimators, tests, directions, diagnostics, SAC and software, from the manifests.
outcomes
    How each verdict outcome is shown: its mark, its colour class and its legend text.
runs
    Every report kept, one directory per run identity, and the index page that lists them.
sac_summary
    The SAC summary table: mean ± sd across seeds per (task, variant).
sections
    The report's sections in page order: random policies, SAC, estimator diagnostics, ablation, appendix.
sweep
    The report of a multirun sweep of a study: one cell per job, read from the jobs' artefacts.
tables
    The tables of metrics, and the one writer of every table (Markdown, LaTeX and CSV side by side).
verdict_tables
    Display tables of the verdict: the relation × metric matrix, the summary, survival, the full table.
writer
    Numbered figure and table blocks, each written once under ``figures/`` and ``tables/``.
"""
