"""Verdict stage: every registered metric against every known relation of the study (cached).

The entry point is :mod:`taskcomplexity.commands.verdict` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-verdict`` does from an installed package.
"""

from taskcomplexity.commands.verdict import main

if __name__ == "__main__":
    main()
