"""SAC stage: SAC (or SAC + HER) on one task → curves.parquet (cached).

The entry point is :mod:`taskcomplexity.commands.sac` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-sac`` does from an installed package.
"""

from taskcomplexity.commands.sac import main

if __name__ == "__main__":
    main()
