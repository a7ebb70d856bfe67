"""TorchRL's :class:`Collector`, imported with TorchRL's own import-time deprecation warning silenced.

torchrl 0.14.1 warns about its own deprecated weight-updater classes while it defines them, on the import of
``torchrl.collectors``; nothing here uses them. The modules that collect experience import it from here.
"""

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings(
        "ignore", message=r"Creating \w+ which inherits from WeightUpdaterBase", category=DeprecationWarning
    )
    from torchrl.collectors import Collector

__all__ = ["Collector"]
