"""The command line's glue, beside :mod:`taskcomplexity.commands`: what is typed, checked before Hydra parses
it, and errors → one line and an exit status.

Entry points call :func:`check_overrides` before Hydra parses the command line (so an unknown config
group option is reported in one line, not a traceback) and wrap their task function with
:func:`one_line_errors`. What the composed config means (the study's plan, every stage's typed settings)
is read once, by :mod:`taskcomplexity.study.plan`.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import logging
import os
import re
import shlex
import signal
import sys
import threading
from importlib import resources
from pathlib import Path

import yaml
from omegaconf import OmegaConf
from omegaconf.errors import InterpolationKeyError

from taskcomplexity.errors import ConfigError, TaskComplexityError, WorkerLost
from taskcomplexity.processes import quiet_tracker

CONF_DIR = Path(str(resources.files("taskcomplexity") / "conf"))
"""The packaged Hydra configs (``taskcomplexity/conf``, shipped as package data): every entry point's
primary config directory, in a source checkout and in an installed package alike."""
NOT_GROUPS = ("hydra",)
"""Directories of the packaged configs that are no group a user chooses an option of."""
EXIT_BAD_INPUT = 2
EXIT_DISK_FULL = 3
EXIT_WORKER_LOST = 75   # sysexits' EX_TEMPFAIL: a temporary failure, the rerun resumes
EXIT_OUT_OF_TIME = 124
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 128 + signal.SIGTERM

log = logging.getLogger("taskcomplexity")


_LAST_ERROR: list[str] = []


def last_error() -> str | None:
    """The last ``error:`` line this process printed (without the prefix), or None: what a cluster job that
    exits with it reports back to the process that submitted it."""
    return _LAST_ERROR[-1] if _LAST_ERROR else None


def say_error(message: str) -> None:
    """Print ``error: message`` on one line to stderr (and keep it for :func:`last_error`)."""
    _LAST_ERROR.append(message)
    print(f"error: {message}", file=sys.stderr, flush=True)


def fail(message: str) -> None:
    """Print ``error: message`` on one line to stderr and exit with status 2."""
    say_error(message)
    raise SystemExit(EXIT_BAD_INPUT)


def config_groups(conf_dir: Path = CONF_DIR) -> tuple[str, ...]:
    """The config groups: every directory of the packaged configs (``task``, ``arm``, …, each stage's group,
    ``study``, ``experiment``), sorted."""
    return tuple(sorted(p.name for p in conf_dir.iterdir() if p.is_dir() and p.name not in NOT_GROUPS))


def search_dirs(argv: list[str], conf_dir: Path = CONF_DIR) -> list[Path]:
    """The packaged config directory and every ``file://`` directory of a ``hydra.searchpath`` override."""
    dirs = [conf_dir]
    for arg in argv[1:]:
        name, _, value = arg.partition("=")
        if name.lstrip("+~") == "hydra.searchpath":
            for item in value.strip("[]").split(","):
                item = item.strip().strip("'\"")
                if item.startswith("file://"):
                    dirs.append(Path(item[len("file://"):]))
    return dirs


def check_overrides(argv: list[str], conf_dir: Path = CONF_DIR, *, compose: bool = True) -> None:
    """Refuse ``group=option`` overrides whose option file does not exist, naming the allowed ones.

    Options are looked up in the packaged configs and in the directories a ``hydra.searchpath``
    override adds (a researcher's own studies and task presets). ``compose``: also compose the config
    (:func:`unknown_keys`); an entry point leaves that to Hydra's own composition instead
    (:func:`composition_errors`), so that a command composes its config no more often than Hydra does.
    """
    dirs = search_dirs(argv, conf_dir)
    groups = config_groups(conf_dir)
    check_config_name(argv, dirs)
    check_output_paths(argv)
    for arg in argv[1:]:
        if arg.startswith("-") or "=" not in arg:
            continue
        name, _, value = arg.partition("=")
        name = name.lstrip("+~")
        if name not in groups:
            continue
        allowed = sorted({p.stem for d in dirs for p in (d / name).glob("*.yaml")})
        for option in value.split(","):
            if option in ("", "null") and name == "experiment":
                continue
            if option.startswith(("glob(", "range(", "choice(")):
                continue
            if option not in allowed:
                fail(f"{name}={option} is not a known option (allowed: {', '.join(allowed)})")
    problem = unknown_keys(argv, dirs) if compose else refused_additions(argv)
    if problem:
        fail(problem)


FULL_ERROR = "HYDRA_FULL_ERROR"
"""Hydra's switch: set to ``1``, Hydra raises the errors it would print (and so does :func:`one_line_errors`)."""
TYPED_FULL_ERROR = "TASKCOMPLEXITY_TYPED_HYDRA_FULL_ERROR"
"""Where :func:`composition_errors` keeps the user's own ``HYDRA_FULL_ERROR`` while Hydra composes (inherited by a
multirun's job processes, which give it back with :func:`typed_full_error`)."""


@contextlib.contextmanager
def composition_errors(argv: list[str], conf_dir: Path = CONF_DIR):
    """Hydra's app inside the block: an error of Hydra composing the config ends in one line and exit 2.

    While Hydra composes, ``HYDRA_FULL_ERROR=1`` makes it raise the error instead of printing it over several
    lines; the line is :func:`unknown_keys`' (the key no stage reads, with the keys allowed beside it), else the
    error's own message. The task function gives the user's own value back first (:func:`typed_full_error`), so
    what it raises is reported as before; a user's ``HYDRA_FULL_ERROR=1`` keeps every traceback.
    """
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    typed = os.environ.get(FULL_ERROR)
    os.environ[TYPED_FULL_ERROR] = typed or ""
    os.environ[FULL_ERROR] = "1"
    try:
        yield
    except (HydraException, OmegaConfBaseException, yaml.YAMLError) as err:
        typed_full_error()
        if typed == "1":
            raise
        if isinstance(err, yaml.YAMLError) or isinstance(err.__cause__, yaml.YAMLError):
            fail(invalid_yaml(err if isinstance(err, yaml.YAMLError) else err.__cause__))
        fail(unknown_keys(argv, search_dirs(argv, conf_dir)) or " ".join(str(err).split()))
    finally:
        typed_full_error()


@contextlib.contextmanager
def one_composition(argv: list[str]):
    """Hydra's app inside the block composes its config once, not twice.

    Before it runs a command, Hydra composes the whole config once only to read ``hydra.mode`` (whether a command
    without ``-m`` is a multirun), then composes it again to run: ~0.3 CPU-s of every command's start. No packaged
    config sets ``hydra.mode`` (``tests/commands/test_startup.py`` reads it with Hydra's own ``get_mode`` for every
    experiment and launcher), so where every config comes from the packaged directory and no override names
    ``hydra.mode``, Hydra is told that nothing sets it (``Hydra.get_mode`` returns None, as it does for an unset
    mode) and the mode follows ``-m`` as it would. Anything else (``--config-dir``, ``--config-path``, a
    ``hydra.searchpath`` directory, a ``hydra.mode`` override) keeps Hydra's own reading.
    """
    from hydra._internal.hydra import Hydra

    words = argv[1:]
    own = any(word.startswith(("--config-dir", "-cd", "--config-path", "-cp")) for word in words)
    own = own or len(search_dirs(argv)) > 1
    if own or any(word.partition("=")[0].lstrip("+~") == "hydra.mode" for word in words):
        yield
        return
    read = Hydra.get_mode
    Hydra.get_mode = _mode_unset
    try:
        yield
    finally:
        Hydra.get_mode = read


def _mode_unset(hydra, config_name, overrides) -> None:
    """``Hydra.get_mode`` where no config sets ``hydra.mode`` (:func:`one_composition`)."""
    return None


def typed_full_error() -> None:
    """Give ``HYDRA_FULL_ERROR`` back the value the user typed (:func:`composition_errors` set it while Hydra
    composed); nothing outside that block."""
    if TYPED_FULL_ERROR not in os.environ:
        return
    typed = os.environ.pop(TYPED_FULL_ERROR)
    if typed:
        os.environ[FULL_ERROR] = typed
    else:
        os.environ.pop(FULL_ERROR, None)


CONFIG_FLAGS = {"--config-name": "name", "-cn": "name", "--config-path": "path", "-cp": "path",
                "--config-dir": "dir", "-cd": "dir"}
"""Hydra's flags that choose the primary config (its name, its directory) or add a directory to the search path."""


def config_flags(argv: list[str]) -> dict[str, tuple[str, str]]:
    """Hydra's config flags typed in ``argv`` (``--config-name=x``, ``--config-name x``, ``-cn x``): what each
    chooses (``name``, ``path``, ``dir``) → (the flag as typed, its value)."""
    found = {}
    for i, arg in enumerate(argv[1:], start=1):
        flag, equals, value = arg.partition("=")
        if flag in CONFIG_FLAGS:
            if not equals:
                value = argv[i + 1] if i + 1 < len(argv) else ""
            found[CONFIG_FLAGS[flag]] = (flag, value)
    return found


def check_config_name(argv: list[str], dirs: list[Path]) -> None:
    """Refuse, in one line naming the configs allowed, a ``--config-name`` (``-cn``) that names no primary config:
    a YAML file at the top of the packaged configs, of ``--config-path`` or of ``--config-dir``."""
    flags = config_flags(argv)
    if "name" not in flags:
        return
    flag, name = flags["name"]
    roots = list(dirs)
    for kind in ("path", "dir"):
        if kind in flags:
            given = flags[kind][1]
            if "://" in given:  # a pkg:// or file:// source: Hydra resolves it, and reports a missing name itself
                return
            # --config-path is relative to the app's module (taskcomplexity.commands), --config-dir to the caller
            root = Path(given)
            roots.append(root if root.is_absolute() or kind == "dir" else Path(__file__).parent / "commands" / root)
    allowed = sorted({p.stem for root in roots for p in root.glob("*.yaml")})
    if name.removesuffix(".yaml") not in allowed:
        fail(f"{flag}={name} is not a config (allowed: {', '.join(allowed)})")


def check_output_paths(argv: list[str]) -> None:
    """Refuse, in one line, output and cache paths that are empty or cannot be written, however they are given
    (``paths.outputs=…``, ``paths.cache=…`` or ``TASKCOMPLEXITY_OUTPUTS``), and a full disk under them, before
    Hydra creates its run directory there. An existing cache that is read-only is accepted: it serves what it
    holds (:meth:`~taskcomplexity.stages.cache.Cache.require_writable` refuses anything it lacks)."""
    from taskcomplexity.stages.cache import ensure_writable, read_only
    from taskcomplexity.stages.resources import check_free_space

    given = dict(arg.lstrip("+~").split("=", 1) for arg in argv[1:] if "=" in arg and not arg.startswith("-"))
    for key in ("paths.outputs", "paths.cache"):
        if key in given and not given[key].strip():
            fail(f"{key} is empty (allowed: a directory path; the default is outputs, or $TASKCOMPLEXITY_OUTPUTS)")
    outputs = given.get("paths.outputs") or os.environ.get("TASKCOMPLEXITY_OUTPUTS") or "outputs"
    checks = [("paths.outputs", outputs)]
    if "paths.cache" in given:
        checks.append(("paths.cache", given["paths.cache"]))
    for key, value in checks:
        if "," in value or "$" in value:  # a sweep or an interpolation: Hydra resolves it per job
            continue
        try:
            if key == "paths.cache" and read_only(Path(value)):
                continue
            ensure_writable(Path(value), key=key)
            check_free_space(Path(value))
        except TaskComplexityError as err:
            fail(str(err))
        except OSError as err:
            disk_full(err)
            raise


FREE_FORM = ("task.kwargs", "study.reference", "study.algorithm_scores", "study.orders")
"""Config nodes whose keys are the user's own (``+task.kwargs.noise=0.3``, ``+study.reference.pend=1``): the
study checks its own (every id must be a task of the study)."""


HELP_FLAGS = ("--help", "-h")
"""Hydra's flags for an app's help (``--hydra-help`` is Hydra's own, and Hydra answers it)."""


def app_help(argv: list[str], job_name: str, conf_dir: Path = CONF_DIR) -> str | None:
    """An entry point's ``--help`` as Hydra writes it, from one composition of the config, or None when Hydra should
    answer (the help template asks for Hydra's flags or its own config groups).

    Hydra fills its help template (``hydra.help``: the app's config groups and options, then the config composed
    with the typed overrides) by listing every group through a fresh copy of its config repository, about a second
    of CPU for this package's configs; the groups here are the directories of the search path Hydra starts with
    (the packaged configs and ``--config-dir``; a ``hydra.searchpath`` override reaches the config, not the list),
    their options the YAML files in them, as Hydra lists them. ``--config-name`` and ``--resolve`` are honoured.
    """
    import copy
    import string

    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException
    from omegaconf import flag_override
    from omegaconf.errors import OmegaConfBaseException

    flags = config_flags(argv)
    if "path" in flags:  # another primary config directory: Hydra resolves it
        return None
    added = [Path(flags["dir"][1]).resolve()] if "dir" in flags else []
    dirs = search_dirs(argv, conf_dir) + added
    chosen = typed_overrides(argv)
    if isinstance(chosen, str):
        fail(chosen)
    name = flags["name"][1] if "name" in flags else "config"
    try:
        with initialize_config_dir(config_dir=str(dirs[0]), job_name=job_name, version_base="1.3"):
            cfg = compose(name, overrides=[o.input_line for o in chosen], return_hydra_config=True)
        template = str(cfg.hydra.help.template)
    except yaml.YAMLError as err:
        fail(invalid_yaml(err))
    except (HydraException, OmegaConfBaseException) as err:
        cause = err.__cause__ if isinstance(err.__cause__, yaml.YAMLError) else None
        fail(invalid_yaml(cause) if cause else unknown_keys(argv, dirs) or " ".join(str(err).split()))
    if any(f"${key}" in template or f"${{{key}}}" in template for key in ("FLAGS_HELP", "HYDRA_CONFIG_GROUPS")):
        return None
    job = copy.deepcopy(cfg)
    with flag_override(job, ["struct", "readonly"], [False, False]):
        del job["hydra"]
    return string.Template(template).substitute(
        APP_CONFIG_GROUPS=app_config_groups([conf_dir, *added]),  # Hydra lists its search path as it started
        CONFIG=OmegaConf.to_yaml(job, resolve="--resolve" in argv),
    )


def app_config_groups(dirs: list[Path]) -> str:
    """The app's config groups, one line each (``group: option, option, …``, sorted), as Hydra's help lists them:
    every directory of the search path that holds a YAML file, nested ones as ``group/sub``, but Hydra's own."""
    groups: dict[str, set[str]] = {}
    for root in dirs:
        for path in root.rglob("*.yaml"):
            group = path.parent.relative_to(root).as_posix()
            if group != "." and group.split("/")[0] != "hydra":
                groups.setdefault(group, set()).add(path.stem)
    return "".join(f"{group}: {', '.join(sorted(groups[group]))}\n" for group in sorted(groups))


def typed_overrides(argv: list[str]):
    """The overrides of ``argv`` as Hydra parses them, but its sweeps; or the one line of a parse error."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    lines = [a for a in argv[1:] if "=" in a and not a.startswith("-")]
    try:
        parsed = OverridesParser.create().parse_overrides(lines)
    except HydraException as err:
        return " ".join(str(err).split())
    return [o for o in parsed if not o.is_sweep_override()]


def refused_additions(argv: list[str]) -> str | None:
    """One line for an override that does not parse, or for a ``+key`` outside the free-form nodes
    (:data:`FREE_FORM`: Hydra would add a key no stage reads), else None; composes nothing."""
    chosen = typed_overrides(argv)
    if isinstance(chosen, str):
        return chosen
    for override in chosen:
        key = override.key_or_group
        if override.is_add() and not any(key.startswith(f"{node}.") for node in FREE_FORM):
            return (f"{override.input_line}: {key} is not a key any stage reads ('+' adds keys only to "
                    f"{', '.join(FREE_FORM)}; remove it or check its spelling)")
    return None


def unknown_keys(argv: list[str], dirs: list[Path]) -> str | None:
    """One line naming the first override that sets a key no stage reads, or None.

    Composes the config with every non-sweep override (what Hydra will do), so an unknown key
    (``rwg.polices=10``) is named with the keys allowed beside it; a ``+key`` that adds a key is
    accepted only inside a free-form node (:data:`FREE_FORM`).
    """
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    problem = refused_additions(argv)
    if problem:
        return problem
    chosen = typed_overrides(argv)
    searchpath = [o.input_line for o in chosen if o.key_or_group == "hydra.searchpath"]
    settings = [o.input_line for o in chosen if not o.key_or_group.startswith("hydra")]
    if GlobalHydra.instance().is_initialized():
        return None
    try:
        with initialize_config_dir(config_dir=str(dirs[0]), version_base="1.3"):
            compose("config", overrides=searchpath + settings)
    except yaml.YAMLError as err:
        return invalid_yaml(err)
    except (HydraException, OmegaConfBaseException) as err:
        cause = err.__cause__ if err.__cause__ is not None else err
        full_key = getattr(cause, "full_key", None)
        if full_key and "not in struct" in str(cause):
            parent = full_key.rpartition(".")[0]
            try:
                with initialize_config_dir(config_dir=str(dirs[0]), version_base="1.3"):
                    dotted = re.sub(r"\[(\d+)\]", r".\1", full_key)
                    kept = [o.input_line for o in chosen if not o.key_or_group.startswith("hydra")
                            and o.key_or_group != dotted]
                    base = compose("config", overrides=searchpath + kept)
                node = OmegaConf.select(base, parent) if parent else base
                allowed = ", ".join(sorted(str(k) for k in node.keys()))
            except Exception:  # noqa: BLE001 - the message stays useful without the list
                base, allowed = None, "see the config group's file"
            if full_key == "task.kwargs" or full_key.startswith("task.kwargs."):
                typed = next((o.key_or_group for o in chosen if o.key_or_group.startswith(full_key)), full_key)
                return task_kwargs_problem(typed, base)
            return f"{full_key} is not a known key (allowed: {allowed})"
        return " ".join(str(cause).split())
    return None


def task_kwargs_problem(full_key: str, base) -> str:
    """One line for a ``task.kwargs.<name>`` override that sets no key of the composed ``base`` config: the
    reaching arms take no keyword arguments; a gymnasium task's env takes the ones its constructor names, each
    added with ``+`` (:func:`~taskcomplexity.tasks.gym_task.keywords_taken`)."""
    task = OmegaConf.select(base, "task") if base is not None else None
    env_id = OmegaConf.select(task, "env_id") if task is not None else None
    if task is None or task.get("kind") != "gym" or not env_id:
        kind = task.get("kind") if task is not None else None
        return (f"{full_key}: task={kind or 'reaching'} takes no keyword arguments (task.kwargs is a gymnasium "
                "task's: task=gym task.env_id=<id> +task.kwargs.<name>=<value>; an arm's settings are arm.*, reward.*)")
    from taskcomplexity.tasks.gym_task import env_keywords, keywords_taken

    try:
        names = env_keywords(str(env_id))
    except TaskComplexityError as err:
        return str(err)
    if names is None or full_key.removeprefix("task.kwargs.") in names:
        return f"{full_key}: a keyword argument of {env_id} is added to task.kwargs with '+': +{full_key}=<value>"
    return f"{full_key}: {keywords_taken(str(env_id))}"


def invalid_yaml(err: yaml.YAMLError) -> str:
    """One line for a config file that is not valid YAML: the file, the line and column, what is wrong."""
    mark = getattr(err, "problem_mark", None)
    where = f"{mark.name}, line {mark.line + 1}, column {mark.column + 1}" if mark is not None else "a config file"
    what = " ".join(str(getattr(err, "problem", None) or err).split())
    context = getattr(err, "context", None)
    return f"{where} is not valid YAML: {what}" + (f" ({' '.join(context.split())})" if context else "")


def missing_interpolation(err: InterpolationKeyError) -> str:
    """One line for a ``${key}`` the composed config does not hold (the key that asked, what it wanted)."""
    wanted = str(err.msg).split("'")[1] if "'" in str(err.msg) else str(err.msg)
    line = f"{err.full_key} = ${{{wanted}}}, but the config has no {wanted}"
    if wanted.startswith("study.published."):
        line += (" (experiment=published runs at the scale of the study's published table: give the study a "
                 "`published: {policies, episodes, bins}` block, or set rwg.policies, rwg.episodes and metrics.bins)")
    return line


class Terminated(BaseException):
    """SIGTERM arrived (``kill``, a cluster's time limit, ``docker stop``): unwinds like Ctrl-C."""


class OutOfTime(BaseException):
    """A cluster job reached its time limit with no requeue left (:mod:`taskcomplexity.commands.cluster`): unwinds
    like Ctrl-C, so that no code on the way (an env's error handling) takes it for an error of its own."""


def _terminated(signum, frame) -> None:
    raise Terminated


def _interrupt_again(unraisable) -> None:
    """``sys.unraisablehook`` of an entry point: Ctrl-C or ``SIGTERM`` that arrived inside a finaliser (an env's
    ``__del__``), where Python can only print it and go on, is delivered again, so it ends the run with its one
    line; anything else goes to the previous hook."""
    stop = {KeyboardInterrupt: signal.SIGINT, Terminated: signal.SIGTERM}.get(type(unraisable.exc_value))
    if stop is not None:  # sent from a thread a moment later: sent from here, it would land in this hook again
        threading.Timer(0.05, os.kill, (os.getpid(), stop)).start()
        return
    _UNRAISABLE(unraisable)


_UNRAISABLE = sys.unraisablehook


def disk_full(err: OSError, where: str | None = None) -> None:
    """Exit with the disk-full line (status 3) if ``err`` is a full disk; return otherwise."""
    if err.errno != errno.ENOSPC and "No space left on device" not in str(err):
        return
    where = err.filename or where or "the outputs directory"
    say_error(f"disk full while writing {where}; free some space and rerun the same command to resume")
    raise SystemExit(EXIT_DISK_FULL) from None


def one_line_errors(fn):
    """Entry points only: the project's input errors become one line and exit status 2.

    Only :class:`~taskcomplexity.errors.TaskComplexityError` (bad config values, unknown ids, damaged
    artefacts) is shortened; anything else is a bug and keeps its traceback (exit status 1).
    ``HYDRA_FULL_ERROR=1`` shows the traceback of input errors too. Three faults are not bugs and end
    in one line too, with the finished work kept for the rerun: Ctrl-C (exit 130), SIGTERM (exit 143),
    a full disk (exit 3), a worker process that died (exit 75) and a cluster job's last time limit (exit 124).
    ``kill -INT`` stops a run started in the background by a script too (which starts it with SIGINT ignored),
    and an interrupt that lands in a finaliser is delivered again rather than lost.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        logging.captureWarnings(True)  # warnings go to the run log (conf/hydra/job_logging), not the console
        main_thread = threading.current_thread() is threading.main_thread()  # signals reach the main thread only
        previous = signal.signal(signal.SIGTERM, _terminated) if main_thread else None
        if main_thread and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
            # started in the background by a script (``cmd &``), which ignores SIGINT: ``kill -INT`` still stops it
            signal.signal(signal.SIGINT, signal.default_int_handler)
        sys.unraisablehook = _interrupt_again
        quiet_tracker()
        try:
            return fn(*args, **kwargs)
        except WorkerLost as err:
            say_error(str(err))
            raise SystemExit(EXIT_WORKER_LOST) from None
        except TaskComplexityError as err:
            if os.environ.get("HYDRA_FULL_ERROR") == "1":
                raise
            fail(str(err))
        except InterpolationKeyError as err:  # a ${…} of the composed config names a key it does not have
            if os.environ.get("HYDRA_FULL_ERROR") == "1":
                raise
            fail(missing_interpolation(err))
        except KeyboardInterrupt:
            print("interrupted; rerun the same command to resume", file=sys.stderr, flush=True)
            raise SystemExit(EXIT_INTERRUPTED) from None
        except Terminated:
            print("terminated (SIGTERM); rerun the same command to resume", file=sys.stderr, flush=True)
            raise SystemExit(EXIT_TERMINATED) from None
        except OutOfTime as reason:
            say_error(f"{reason}; the work it saved is kept: rerun the same command to resume, with a longer "
                      "hydra.launcher.timeout_min or more rwg.shards")
            raise SystemExit(EXIT_OUT_OF_TIME) from None
        except OSError as err:
            disk_full(err, f"the outputs directory {_outputs_of(args)}")
            raise
        finally:
            sys.unraisablehook = _UNRAISABLE
            if main_thread:
                signal.signal(signal.SIGTERM, previous)

    return wrapper


def _outputs_of(args: tuple) -> str:
    """The absolute ``paths.outputs`` of an entry point's config (its first argument), for messages."""
    try:
        return os.path.abspath(str(OmegaConf.select(args[0], "paths.outputs", throw_on_missing=True)))
    except Exception:  # noqa: BLE001 - no config, or one without a resolvable paths.outputs
        return os.path.abspath(os.environ.get("TASKCOMPLEXITY_OUTPUTS", "outputs"))


def user_overrides() -> list[str]:
    """The overrides typed on the command line of the running Hydra app (none outside an app)."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return []
    overrides = HydraConfig.get().overrides
    return [*overrides.task, *(o for o in overrides.hydra if o.lstrip("+~").startswith("hydra.searchpath"))]


def sac_command() -> str:
    """The command that trains the SAC curves a run without SAC lacks: its own overrides + sac.enabled=true.

    ``make paper`` is that command for ``make run`` (``experiment=published``). Otherwise it is this run's own
    command, so that pasted into a shell it finds what this run found: the ``PYTHONPATH`` it ran with (a user's
    env module), this interpreter (``.venv/bin/python`` in a checkout, else the console script) and every
    override typed, search path included, quoted for the shell.
    """
    kept = [o for o in user_overrides() if o.split("=", 1)[0].lstrip("+~") not in ("sac.enabled", "force")]
    if kept == ["experiment=published"]:
        return f"make paper ({rerun_command([*kept, 'sac.enabled=true'])})"
    return rerun_command([*kept, "sac.enabled=true"])


def rerun_command(overrides: list[str]) -> str:
    """This process's study command with ``overrides``, in its environment, as a shell line."""
    checkout = Path(sys.argv[0]).parent.name == "pipelines"
    if checkout:
        interpreter = os.path.relpath(sys.executable)
        program = [interpreter if not interpreter.startswith("..") else sys.executable, "pipelines/study.py"]
    else:
        program = ["taskcomplexity-study"]
    path = os.environ.get("PYTHONPATH", "")
    prefix = [f"PYTHONPATH={shlex.quote(path)}"] if path else []
    return " ".join([*prefix, *program, *(shlex.quote(o) for o in overrides)])


def refuse_unread_groups(typed: list[str], unread: tuple[str, ...], command: str, instead: str) -> None:
    """Refuse, in one line, a typed override of a config node ``command`` does not read (e.g. ``study.…``
    for the RWG stage of one task), naming the command that reads it."""
    for override in typed:
        key = override.partition("=")[0].lstrip("+~")
        if any(key == node or key.startswith(f"{node}.") for node in unread):
            raise ConfigError(f"{override} is not read by {command} ({instead} reads it)")


def sweep_job_dir() -> Path | None:
    """The Hydra job directory of this process when it is a job of a multirun (None otherwise)."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    if not HydraConfig.initialized() or HydraConfig.get().mode != RunMode.MULTIRUN:
        return None
    return Path(HydraConfig.get().runtime.output_dir)


def job_overrides() -> tuple[str, ...]:
    """The overrides of the running Hydra job (a sweep's cell: its own values; none outside an app)."""
    from hydra.core.hydra_config import HydraConfig

    return tuple(HydraConfig.get().overrides.task) if HydraConfig.initialized() else ()
