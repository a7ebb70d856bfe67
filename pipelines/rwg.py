"""RWG stage: N random policies × M episodes of one task → returns.parquet (cached).

The entry point is :mod:`taskcomplexity.commands.rwg` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-rwg`` does from an installed package.
"""

from taskcomplexity.commands.rwg import main

if __name__ == "__main__":
    main()
