"""The columns of a SAC learning curve (one row per evaluation of one seed), declared once for the training that
writes them and for everything that reads them; and the file of a run's trained actors. Light: reading a cached
run's artefact imports neither torch nor torchrl."""

ACTORS_FILE = "actors.npz"
"""The file of a SAC run's actor snapshots in its artefact (:class:`taskcomplexity.rl.snapshots.ActorSnapshots`)."""

WALL_CLOCK = "time/"
"""The prefix of the curve columns that hold wall-clock time (``time/seconds``): shown to the reader, never part of
a cache key (:func:`taskcomplexity.stages.verdict_stage.curves_digest`) nor of a comparison of numbers, since two
identical runs differ there."""

CURVE_COLUMNS = (
    "task",
    "variant",
    "seed",
    "env_step",
    "eval/return_mean",
    "eval/return_std",
    "eval/success_rate",
    "train/episode_return",
    f"{WALL_CLOCK}seconds",
)
