"""The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → verdict → report.

The entry point is :mod:`taskcomplexity.commands.study` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-study`` does from an installed package.
"""

from taskcomplexity.commands.study import main

if __name__ == "__main__":
    main()
