"""``batch``: ``simplify`` over many assets on Ray, the way studios run LOD generation over a
library on a farm.

Each asset is one Ray task (``simplify_task``) that asks for the CPUs it uses and sets its
torch and Numba thread pools to them, so that N tasks on a machine do not oversubscribe its
cores. Its outputs go to ``OUTROOT/<name>/`` and its log to ``OUTROOT/logs/<name>.log``. A task
whose worker dies (a killed process, a lost node) is retried by Ray and resumes from the
asset's checkpoint. Running the same batch again skips finished assets (their ``metrics.json``
says so) and resumes unfinished ones. ``OUTROOT/index.html`` links every report with a sortable
table of triangles, time and scores (``lookalike.report.index``).

Ray is an optional extra (``pip install 'lookalike[batch]'``): a local instance is started and
stopped by the batch, or an existing cluster is used (``address``, e.g. ``ray://head:10001``).
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass
from pathlib import Path

from .. import io
from ..errors import ConfigError, LookalikeError
from ..report.index import write_index
from ..threads import available_cores, set_threads
from .outdir import CHECKPOINT_NAME
from .outputs import METRICS_NAME

LOGS = "logs"
RETRIES = 3
"""Times Ray retries a task whose worker died."""


@dataclass(frozen=True)
class BatchItem:
    """One asset of a batch: its file, its name (unique in the batch) and its output folder."""

    input: Path
    name: str
    outdir: Path


def batch_items(inputs: list[str | Path], outroot: Path) -> list[BatchItem]:
    """The assets of ``inputs`` (files, or folders whose readable files are taken, recursively,
    in sorted order), each with a unique name (its stem, with ``-2``, ``-3`` ... on a clash) and
    ``outroot/<name>`` as its folder. ``ConfigError`` for a missing path or an empty batch."""
    readable = set(io.readable_extensions())
    files: list[Path] = []
    for entry in map(Path, inputs):
        if entry.is_dir():
            files += sorted(p for p in entry.rglob("*") if p.is_file() and p.suffix.lower() in readable)
        elif entry.is_file():
            files.append(entry)
        else:
            raise ConfigError(f"{entry}: no such file or folder")
    if not files:
        raise ConfigError(f"no readable assets ({', '.join(sorted(readable))}) in {', '.join(map(str, inputs))}")
    items, seen = [], {}
    for path in files:
        seen[path.stem] = seen.get(path.stem, 0) + 1
        name = path.stem if seen[path.stem] == 1 else f"{path.stem}-{seen[path.stem]}"
        items.append(BatchItem(input=path.resolve(), name=name, outdir=outroot / name))
    return items


def state_of(item: BatchItem) -> str:
    """``"done"`` (a finished run's ``metrics.json`` and no checkpoint), ``"partial"`` (a
    checkpoint to resume from) or ``"new"``."""
    if (item.outdir / CHECKPOINT_NAME).is_file():
        return "partial"
    metrics = item.outdir / METRICS_NAME
    if metrics.is_file() and not json.loads(metrics.read_text(encoding="utf-8")).get("interrupted"):
        return "done"
    return "new"


def simplify_task(item: BatchItem, options: dict, threads: int, log_folder: Path) -> dict:
    """Simplify one asset in a Ray worker with ``threads`` threads: a fresh run, or the resumed
    one where a checkpoint is left. Returns ``{"name", "status", "error"}``; the figures are in
    the asset's ``metrics.json``."""
    from .simplify import simplify

    set_threads(threads)
    log_folder.mkdir(parents=True, exist_ok=True)
    (log_folder / f"{item.name}.pid").write_text(str(os.getpid()))
    handler = logging.FileHandler(log_folder / f"{item.name}.log", encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    logger = logging.getLogger("lookalike")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        resume = state_of(item) == "partial"
        logger.info("%s: %s %s", item.name, "resuming" if resume else "simplifying", item.input)
        given = {k: v for k, v in options.items() if k == "time_budget"} if resume else options
        result = simplify(item.input, item.outdir, resume=resume, force=not resume, progress=False, **given)
        logger.info("%s", result.summary())
        return {"name": item.name, "status": "interrupted" if result.interrupted else "done", "error": None}
    except LookalikeError as e:
        logger.error("%s", e)
        return {"name": item.name, "status": "failed", "error": str(e)}
    finally:
        logger.removeHandler(handler)
        handler.close()


@dataclass
class BatchResult:
    """What a batch did: the index page, and per asset (in input order) its state before the
    batch (``"done"`` ones were skipped) and its status after."""

    index: Path
    skipped: list[str]
    statuses: dict[str, str]
    errors: dict[str, str]

    def summary(self) -> str:
        done = sum(s == "done" for s in self.statuses.values())
        lines = [f"{done} of {len(self.statuses)} assets done ({len(self.skipped)} were already)"]
        lines += [f"{name}: {error}" for name, error in self.errors.items()]
        lines.append(f"index: {self.index}")
        return "\n".join(lines)


def batch(inputs: list[str | Path], outroot: str | Path, *, workers: int | None = None, address: str | None = None,
          cpus_per_task: int | None = None, progress: bool = True, **options) -> BatchResult:
    """Simplify every asset of ``inputs`` (see ``batch_items``) into ``outroot/<name>``.

    Args:
        inputs: files and folders.
        outroot: the batch's folder: one folder per asset, ``logs/``, ``index.html``.
        workers: tasks at once on a local instance (default: one per two cores, at least one).
        address: an existing Ray cluster (``ray://host:port`` or ``auto``); default: a local
            instance started and stopped here.
        cpus_per_task: CPUs (and threads) per task (default: the local cores / ``workers``, or
            2 on a cluster).
        progress: a progress bar over assets.
        options: ``simplify``'s keyword arguments for every asset (``triangles``, ``ratio``,
            ``texture_size``, ``resolution``, ``time_budget``, ``iterations``, ``init``,
            ``seed``, ``config``, ``export_obj``, ``compress``).
    """
    outroot = Path(outroot)
    items = batch_items(inputs, outroot)
    states = {item.name: state_of(item) for item in items}
    todo = [item for item in items if states[item.name] != "done"]
    statuses = {name: "done" for name, state in states.items() if state == "done"}
    errors: dict[str, str] = {}
    if todo:
        outroot.mkdir(parents=True, exist_ok=True)
        for outcome in _run_on_ray(todo, options, outroot / LOGS, workers, address, cpus_per_task, progress):
            statuses[outcome["name"]] = outcome["status"]
            if outcome["error"]:
                errors[outcome["name"]] = outcome["error"]
    outroot.mkdir(parents=True, exist_ok=True)
    index = write_index(outroot, [(item.name, item.input, item.outdir, statuses.get(item.name, "failed"))
                                  for item in items])
    return BatchResult(index=index, skipped=[n for n, s in states.items() if s == "done"],
                       statuses={item.name: statuses.get(item.name, "failed") for item in items}, errors=errors)


def _run_on_ray(items: list[BatchItem], options: dict, log_folder: Path, workers: int | None, address: str | None,
                cpus_per_task: int | None, progress: bool):
    """Yield each task's outcome as it completes."""
    try:
        import ray
    except ImportError:
        raise ConfigError("lookalike batch runs on Ray: pip install 'lookalike[batch]'") from None
    from tqdm import tqdm

    cores = available_cores()
    if address is None:
        workers = workers or max(1, cores // 2)
        cpus_per_task = cpus_per_task or max(1, cores // workers)
        ray.init(num_cpus=workers * cpus_per_task, include_dashboard=False, log_to_driver=False,
                 logging_level=logging.WARNING, configure_logging=False)
    else:
        cpus_per_task = cpus_per_task or 2
        ray.init(address=address, log_to_driver=False, logging_level=logging.WARNING, configure_logging=False)
    try:
        task = ray.remote(num_cpus=cpus_per_task, max_retries=RETRIES)(simplify_task)
        pending = {task.remote(item, options, cpus_per_task, log_folder): item for item in items}
        with tqdm(total=len(items), unit="asset", desc="batch", disable=not progress) as bar:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                item = pending.pop(ready[0])
                try:
                    outcome = ray.get(ready[0])
                except ray.exceptions.RayError as e:
                    outcome = {"name": item.name, "status": "failed", "error": f"{type(e).__name__}: {e}".splitlines()[0]}
                bar.update(1)
                bar.set_postfix_str(f"{item.name}: {outcome['status']}", refresh=True)
                yield outcome
    finally:
        ray.shutdown()
