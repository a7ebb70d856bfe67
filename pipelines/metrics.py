"""Metrics stage: every registered metric of each study task (or one task), cached.

The entry point is :mod:`taskcomplexity.commands.metrics` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-metrics`` does from an installed package.
"""

from taskcomplexity.commands.metrics import main

if __name__ == "__main__":
    main()
