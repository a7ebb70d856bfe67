"""Exceptions the library raises; entry points turn them into one readable line and a non-zero exit."""


class TaskComplexityError(Exception):
    """Base class of the library's own errors."""


class ConfigError(TaskComplexityError, ValueError):
    """A configuration value is invalid; the message names the key, the value and what is allowed."""


class ArtefactError(TaskComplexityError):
    """A cached artefact is missing, incomplete or corrupt."""


class EnvError(TaskComplexityError):
    """An environment raised while it was reset or stepped; the message names the env, where it raised (policy,
    episode, step) and its own exception, which is chained (``__cause__``) so its traceback reaches the run log."""


class WorkerLost(TaskComplexityError):
    """A worker process died while it held work (killed, out of memory); the message names the worker and says what
    is saved. Entry points print it in one line and exit with status 75 (a temporary failure: rerun to resume)."""
