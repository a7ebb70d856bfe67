"""The backends' reference page, read from their registry (``taskcomplexity.rwg.backends.BACKENDS``) at build time:
the page cannot disagree with the declarations, and a new backend appears on it without an edit."""

from __future__ import annotations

import inspect
import re
from pkgutil import resolve_name

PAGE = "reference/backends.md"


def _said(entry: str | None) -> str:
    """The first sentence of the docstring of the object an entry point names (or a dash)."""
    if entry is None:
        return "–"
    doc = (inspect.getdoc(resolve_name(entry)) or entry).split("\n\n")[0].replace("\n", " ")
    doc = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", doc).replace("``", "`")  # Sphinx roles and literals as Markdown code
    return doc.replace("|", "\\|")


def _chunks(backend) -> str:
    if backend.steps_at_once:
        return "`rwg.chunk_memory_mb`: every episode of a chunk at once"
    if backend.chunk_policies:
        return f"{backend.chunk_policies} policies"
    return f"the policies that fill {backend.in_flight} environments in flight"


def pages() -> dict[str, str]:
    from taskcomplexity.rwg.backends import BACKENDS

    rows = ["| backend | simulates | calls | returns | chunks | `rwg.workers` | own-env check | the key adds | "
            "`rwg.precision` | `sac.backend` |", "|---|---|---|---|---|---|---|---|---|---|"]
    for b in BACKENDS.values():
        kind = "specialised" if b.specialised else "general"
        rows.append(f"| `{b.name}` | {_said(b.simulates)} ({kind}) | {b.calls} | "
                    f"{'exact' if b.exact else 'another sample'} | {_chunks(b)} | "
                    f"{'processes' if b.worker_processes else 'refused'} | {'yes' if b.check else '–'} | "
                    f"{f'`{b.simulator}`' if b.simulator else '–'} | {', '.join(b.precisions)} | "
                    f"{'yes' if b.sac_env else '–'} |")
    text = f"""# Backends

What simulates RWG's episodes, as the registry declares each backend (`taskcomplexity.rwg.backends.BACKENDS`; this
page is generated from it). `backend=auto` takes, for each task, the first specialised backend that simulates it,
else the first general one, among those the policy family runs on; a family runs on the backends whose calls its
batch answers (`acting`: `act`/`unit_outputs`; `stepped`: `begin`/`respond`).
[Add a backend](../how-to/add-a-backend.md) adds one; [the pipeline](../explanation/pipeline.md#backends) says how
each computes.

{chr(10).join(rows)}

- **returns**: *exact* backends give the returns of the task's reference episodes (gymnasium's or PyBullet's env,
  reset by seed), to the tolerance of their equivalence tests; *another sample* is drawn from the same distribution
  and keyed apart (the key adds what the named function returns: the simulator's version).
- **`rwg.workers`**: the number of processes that step a backend's Python environments (0: one per usable core);
  on the other backends, which run in one process, it is refused.
- **own-env check**: a researcher's env is replayed before any return is computed (resets reproducible, spaces and
  rewards as declared).
"""
    return {PAGE: text}
