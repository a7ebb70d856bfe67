"""What a study's RWG stage will cost, estimated from a pilot of each task before any work.

The entry point is :mod:`taskcomplexity.commands.cost` (usage in its docstring); this file runs it from a
checkout, as ``taskcomplexity-cost`` does from an installed package.
"""

from taskcomplexity.commands.cost import main

if __name__ == "__main__":
    main()
