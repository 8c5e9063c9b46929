"""The one skeleton of every data stage: plan -> store writer -> chunk tasks (dask) -> finalize.

A stage module (sample, blend, stress, render) only says what it writes: the store kind, sample count, chunk
length, array specs, the configuration that must match for a resume, attributes, and a picklable chunk task
``task(c, threads, *, partial, **task_kw) -> units`` that makes and writes chunk ``c``. :class:`Stage` does
the rest the same way for all of them: create or resume the ``.partial`` store, skip finished chunks, show one
progress bar in the stage's units, and move the store into place when every chunk is written.

The data-safety checks live here and in :class:`~storage.store.StoreWriter`, so every stage gets them: an output
inside one of the stage's inputs is refused, the store must fit in memory per chunk task and on disk
(:mod:`storage.bounds`), the local workers must fit in memory, and input paths are recorded relative to the
output (attributes given as a function of the output path), never in the configuration hash.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Union

from svcore.log import get_logger

from storage.objstore import is_object_url, local_path
from storage.store import ArraySpec, StoreWriter, open_writer

from .parallel import run_chunks

log = get_logger(__name__)


@dataclass
class Stage:
    """A planned data stage (nothing written yet).

    Attributes:
        kind: store kind ("variants", "blends", "stress", "renders").
        n: samples of the store (the sample axis).
        chunk: samples per chunk (one task writes one chunk).
        arrays: array name -> spec of one sample.
        config: the resolved configuration; its hash decides whether a ``.partial`` store may be resumed.
        attrs: further store attributes, or a function of the output path returning them (attributes that record
            input paths relative to the output: :func:`storage.store.recorded_path`).
        task: module-level worker function ``(c, threads, *, partial, **task_kw) -> units written``.
        task_kw: its keyword arguments (picklable: they travel to the dask workers).
        desc, unit: progress label and unit ("variant", "view").
        units_per_sample: progress units per sample (render: views per SVBRDF).
        inputs: the stores this stage reads: an output inside one of them (or containing one) is refused.
        finish: optional, called in this process once every chunk is written, with the ``.partial`` store's
            path; returns attributes added at finalize (the import stage gathers its per-chunk records).
    """

    kind: str
    n: int
    chunk: int
    arrays: dict[str, ArraySpec]
    config: dict[str, Any]
    attrs: Union[dict[str, Any], Callable[[Path], dict[str, Any]]]
    task: Callable[..., int]
    task_kw: dict[str, Any] = field(default_factory=dict)
    desc: str = ""
    unit: str = "sample"
    units_per_sample: int = 1
    inputs: tuple[str, ...] = ()
    finish: Callable[[Path], dict[str, Any]] | None = None

    def writer(self, out) -> StoreWriter:
        """The store writer of this stage at ``out`` (not entered yet).

        Raises:
            StoreError: ``out`` exists or lies inside an input. ConfigError: a chunk task or the store cannot fit.
        """
        attrs = self.attrs(out if is_object_url(out) else Path(local_path(out))) if callable(self.attrs) else self.attrs
        # the store names its code by what the task's module can run (svcore.versions.store_versions)
        return open_writer(out, self.kind, self.n, self.chunk, self.arrays, self.config, attrs, inputs=self.inputs,
                           code_of=self.task.__module__)

    def task_for(self, w: StoreWriter) -> Callable[[int, int], int]:
        """The picklable ``(chunk id, threads) -> units`` of this stage writing into ``w``'s partial store."""
        return functools.partial(self.task, partial=str(w.partial), **self.task_kw)

    def run(self, out, workers: int = 2, scheduler_address: str | None = None) -> str:
        """Write (or resume) the store at ``out``. Returns its path."""
        with self.writer(out) as w:
            done = w.done_samples()
            if done:
                log.info("resuming %s: %d of %d samples already written", out, done, self.n)
            run_chunks(self.task_for(w), w.pending(), workers=workers, scheduler_address=scheduler_address,
                       desc=self.desc or self.kind, unit=self.unit, total_units=self.n * self.units_per_sample,
                       done_units=done * self.units_per_sample, task_bytes=w.task_bytes)
            return str(w.finalize(self.finish(w.partial) if self.finish is not None else None))
