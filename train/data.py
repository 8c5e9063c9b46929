"""Training data: a torch Dataset over a renders source, the held-out split, augmentation, the loader.

A *source* is anything with ``__len__``, ``image(i) -> (H, W, 3) float32``, ``maps(i) -> SVBRDF``
(aligned with the image pixel for pixel) and ``source(i)`` (the material/preset ids it came from):
the renders store reader of ``storage.renders_store`` or :class:`train.synthetic.SyntheticSource`.

Determinism: the batch of step t is a pure function of (seed, t): sample *position* p = t·B + b
selects index ``perm_e[p mod N]`` with ``perm_e`` the permutation of epoch e = p // N, and the crop and
flip/rotation come from a generator seeded by (seed, p). So any number of workers, and a run resumed
at step t, see exactly the same batches.
"""
from __future__ import annotations

from typing import Any, Iterator, Protocol, Sequence

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, Sampler

from materials.maps import pack_maps
from svcore.errors import ConfigError, StoreError
from svcore.seeds import stream_rng
from svcore.split import held_out_names, split_indices


class Source(Protocol):
    def __len__(self) -> int: ...
    def image(self, i: int) -> np.ndarray: ...
    def maps(self, i: int) -> Any: ...
    def source(self, i: int) -> Any: ...


def packed_maps(src: Source, i: int) -> np.ndarray:
    """(H, W, 10) packed maps of sample i (normal, diffuse, specular, roughness)."""
    if hasattr(src, "packed"):
        return src.packed(i)
    return pack_maps(src.maps(i))


def preset_ids(src_entry: Any) -> tuple[str, ...]:
    """Normalise whatever ``source(i)`` returns into a tuple of preset/material names.

    Accepts a name, a sequence of names, or a mapping with "presets"/"preset"/"sources"/"materials".
    """
    if isinstance(src_entry, str):
        return (src_entry,)
    if isinstance(src_entry, dict):
        for key in ("presets", "preset", "sources", "materials", "material"):
            if key in src_entry:
                return preset_ids(src_entry[key])
        raise StoreError(f"cannot find preset ids in source entry {src_entry!r}")
    if isinstance(src_entry, (list, tuple, np.ndarray)):
        return tuple(str(x) for x in src_entry)
    return (str(src_entry),)


def split_by_source(src: Source, holdout: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Hold out a fraction of the presets; no preset appears on both sides (:mod:`svcore.split`).

    A renders store records the split of training's defaults (``data.holdout``, ``data.split_seed``) in its attributes
    (``split``); with those values its recorded held-out materials are used, so the split is the one an outside
    reader sees. Other values, older stores and other sources compute it.

    Returns:
        (train indices, test indices), sorted int64 arrays.
    """
    # a store reader lists every sample's presets in one read; source(i) per sample is the generic fallback
    fast = getattr(src, "source_presets", None)
    ids = [tuple(t) for t in fast()] if fast is not None else [preset_ids(src.source(i)) for i in range(len(src))]
    stored = getattr(src, "stored_split", lambda: None)()
    if stored is not None and stored.get("holdout") == holdout and stored.get("seed") == seed:
        return split_indices(ids, stored["test_materials"])
    return split_indices(ids, held_out_names(ids, holdout, seed))


def split_for(src: Source, data) -> tuple[np.ndarray, np.ndarray]:
    """The (train, test) indices a run with data config ``data`` uses: the split by material of ``data.holdout`` and
    ``data.split_seed`` (:func:`split_by_source`), then, with ``data.blends`` off, the blends dropped from the
    training side only, so both arms of the mixing ablation are evaluated on the same held-out views.

    Raises:
        ConfigError: ``data.blends`` off on a source that does not record which samples are blends.
    """
    train, test = split_by_source(src, data.holdout, data.split_seed)
    if not data.blends:
        kinds = getattr(src, "input_kinds_of_views", None)
        if kinds is None:
            raise ConfigError("train.data.blends=false needs a renders store (it records which SVBRDFs are blends); "
                              "the synthetic source has none")
        k = kinds()
        train = np.asarray([i for i in train if k[i] != "blends"], np.int64)
    return train, test


def augment(image: np.ndarray, maps: np.ndarray, rng: np.random.Generator | None, crop: int,
            flips: bool = True, centre: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Crop, rotate by k·90° and flip an image and its maps together, keeping normals consistent.

    With x right and y up in the image, ``np.rot90`` (counter-clockwise on screen) maps a normal
    (x, y) to (-y, x); a left-right flip negates x; rng=None takes the centre crop only.

    Args:
        image: (H, W, 3). maps: (H, W, 10) packed.
        rng: randomness (None: deterministic centre crop, no flips).
        crop: output side (<= H, W).
        flips: random rotations and flips (with ``rng``).
        centre: the centre crop even with ``rng`` (the offsets are still drawn, so the flips stay those of step t).

    Returns:
        (crop, crop, 3) image and (crop, crop, 10) maps, contiguous float32.
    """
    h, w = image.shape[:2]
    if crop > h or crop > w:
        raise StoreError(f"crop {crop} is larger than the {h}x{w} renders")
    if rng is None:
        y0, x0 = (h - crop) // 2, (w - crop) // 2
    else:
        y0, x0 = int(rng.integers(0, h - crop + 1)), int(rng.integers(0, w - crop + 1))
        if centre:
            y0, x0 = (h - crop) // 2, (w - crop) // 2
    img = image[y0:y0 + crop, x0:x0 + crop]
    mp = maps[y0:y0 + crop, x0:x0 + crop]
    if rng is not None and flips:
        k = int(rng.integers(0, 4))
        flip = bool(rng.integers(0, 2))
        if k:
            img = np.rot90(img, k)
            mp = np.rot90(mp, k).copy()
            nx, ny = mp[..., 0].copy(), mp[..., 1].copy()
            c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][k]
            mp[..., 0] = c * nx - s * ny
            mp[..., 1] = s * nx + c * ny
        if flip:
            img = img[:, ::-1]
            mp = mp[:, ::-1].copy()
            mp[..., 0] = -mp[..., 0]
    return np.ascontiguousarray(img, np.float32), np.ascontiguousarray(mp, np.float32)


class PairDataset(Dataset):
    """(image, maps) pairs addressed by sample *position* (see module docstring).

    Args:
        src: the source.
        indices: the source indices this dataset draws from (e.g. the train split).
        crop: crop side.
        seed: master seed.
        train: random crops/flips and epoch permutations; False = index k is ``indices[k]``,
            centre crop, no flips (evaluation).
        flips: random 90° rotations and flips (train only).
        centre: training crops at the view's centre, like evaluation's (``data.crop_at``); flips still apply.

    Items are ``(image (3, c, c), maps (10, c, c))`` float32 tensors.
    """

    def __init__(self, src: Source, indices: Sequence[int], crop: int, seed: int = 0, train: bool = True,
                 flips: bool = True, centre: bool = False):
        self.src, self.indices = src, np.asarray(indices, np.int64)
        if len(self.indices) == 0:
            raise StoreError("the dataset split is empty (too few samples or presets)")
        self.crop, self.seed, self.train, self.flips = int(crop), int(seed), train, flips
        self.centre = centre
        self._perm_epoch, self._perm = -1, None

    def __len__(self) -> int:
        return len(self.indices)

    def index_of(self, pos: int) -> int:
        """Source index at sample position ``pos`` (train: epoch permutations)."""
        if not self.train:
            return int(self.indices[pos])
        n = len(self.indices)
        epoch = pos // n
        if epoch != self._perm_epoch:
            self._perm = stream_rng(self.seed, "train.epoch_order", epoch).permutation(n)
            self._perm_epoch = epoch
        return int(self.indices[self._perm[pos % n]])

    def __getitem__(self, pos: int) -> tuple[torch.Tensor, torch.Tensor]:
        i = self.index_of(int(pos))
        rng = stream_rng(self.seed, "train.augment", int(pos)) if self.train else None
        crop = getattr(self.src, "crop", None)
        if crop is not None:
            # the store transforms only the window's pixels (4x less work for 256 -> 128 crops)
            h = self.src.res
            if self.crop > h:
                raise StoreError(f"crop {self.crop} is larger than the {h}x{h} renders")
            y0, x0 = tuple(int(rng.integers(0, h - self.crop + 1)) for _ in range(2)) if rng is not None \
                else ((h - self.crop) // 2,) * 2
            if self.centre:  # the same draws as random crops, so the flips of step t are those of a random-crop run
                y0, x0 = ((h - self.crop) // 2,) * 2
            img, m = crop(i, y0, x0, self.crop)
            mp = pack_maps(m)
        else:
            img, mp = np.asarray(self.src.image(i), np.float32), packed_maps(self.src, i)
        img, mp = augment(img, mp, rng, self.crop, self.flips, self.centre)
        return torch.from_numpy(img).permute(2, 0, 1), torch.from_numpy(mp).permute(2, 0, 1)


class StepSampler(Sampler):
    """Batches of sample positions for steps ``start .. stop-1``: step t -> [t·B, ..., t·B + B - 1].

    Under data-parallel training the global batch of step t is those positions with B the global batch, and rank r
    of a world of ``global_batch / batch_size`` processes takes the r-th contiguous ``batch_size`` of them: a pure
    function of (seed, step, rank), so the ranks together see exactly the batch one process would.

    Args:
        batch_size: samples per step of this process.
        start, stop: the steps.
        global_batch: samples per step over all processes (None: ``batch_size``, a single process).
        rank: this process's rank.
    """

    def __init__(self, batch_size: int, start: int, stop: int, global_batch: int | None = None, rank: int = 0):
        self.b, self.start, self.stop = int(batch_size), int(start), int(stop)
        self.g = self.b if global_batch is None else int(global_batch)
        self.offset = int(rank) * self.b
        if self.offset + self.b > self.g:
            raise ValueError(f"rank {rank} x batch {batch_size} does not fit in the global batch {self.g}")

    def __iter__(self) -> Iterator[list[int]]:
        for t in range(self.start, self.stop):
            lo = t * self.g + self.offset
            yield list(range(lo, lo + self.b))

    def __len__(self) -> int:
        return max(0, self.stop - self.start)


def make_loader(ds: PairDataset, batch_size: int, start: int, stop: int, workers: int, global_batch: int | None = None,
                rank: int = 0, pin_memory: bool = False, timeout: float = 0) -> DataLoader:
    """A DataLoader yielding the batches of steps start..stop-1 (any worker count gives the same batches).

    The loader always runs on the CPU (its workers are processes); ``pin_memory`` page-locks the batches so that
    the copy to a CUDA device can be asynchronous. ``global_batch``/``rank``: see :class:`StepSampler`. ``timeout``:
    seconds a worker may take per batch (0 = forever; ignored without workers, where nothing can hang apart).
    """
    return DataLoader(ds, batch_sampler=StepSampler(batch_size, start, stop, global_batch, rank), num_workers=workers,
                      persistent_workers=False, prefetch_factor=4 if workers else None,
                      worker_init_fn=_one_thread if workers else None, pin_memory=pin_memory,
                      timeout=timeout if workers else 0)  # torch refuses a timeout without worker processes


def _one_thread(_worker_id: int) -> None:
    """Loader workers do small per-sample work: one thread each for torch and drjit, or the workers and the
    training process oversubscribe the cores (seen here: 7 s/it instead of 0.4)."""
    torch.set_num_threads(1)
    import sys

    if "drjit" in sys.modules:
        sys.modules["drjit"].set_thread_count(1)


def open_source(data_cfg) -> Source:
    """The renders store at ``data_cfg.store``, or the synthetic source when it is None."""
    if data_cfg.store:
        # no existence check here: open_store says "does not exist", or "incomplete ... rerun to resume" where
        # an interrupted run left <store>.partial, the same line as svgen
        try:
            from storage.renders_store import RendersReader
        except ImportError as e:
            raise StoreError(f"cannot read renders stores on this install ({e})") from None
        return RendersReader(data_cfg.store)
    from .synthetic import SyntheticSource

    return SyntheticSource(data_cfg.synthetic_samples, data_cfg.synthetic_size, data_cfg.synthetic_materials,
                           seed=data_cfg.synthetic_seed, kind=data_cfg.synthetic_kind)
