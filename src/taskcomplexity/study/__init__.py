"""A study run from its configuration, in the order the data flows: the composed config read once into a
typed, checked plan (:mod:`~taskcomplexity.study.plan`; each study entry composed through Hydra by
:mod:`~taskcomplexity.study.compose`), the plan's stages run record by record (:mod:`~taskcomplexity.study.chain`),
then the report (:mod:`~taskcomplexity.study.run`, the one module that joins the chain and the report).

The study itself, as data (its tasks, relations, orders, references and budgets), is
:mod:`taskcomplexity.study_data`, beside this package rather than in it: the stages, the verdict and the
report read it, and this package imports them, so inside it those reads would be imports back up.
"""
