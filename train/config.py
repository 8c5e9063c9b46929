"""Typed training configuration (:mod:`svcore.config`): sections, presets, loading from params.yaml and flags.

``resolve(preset, params_file, overrides)`` builds a :class:`Config` as preset < ``train:`` section of
params.yaml < ``key.sub=value`` overrides, and rejects unknown keys, wrong types and out-of-range values with
:class:`svcore.errors.ConfigError` (one line on the CLI, naming the key).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from svcore.config import ConfigModel, parse_sets, validate
from svcore.errors import ConfigError
from svcore.split import DEFAULT_HOLDOUT, DEFAULT_SEED
from svcore.config import resolve as resolve_config


class ModelConfig(ConfigModel):
    """U-Net + global-feature track."""

    base_width: int = Field(16, ge=1)
    """channels of the first (finest) encoder level; level i has min(base_width·2^i, max_width)."""
    max_width: int = Field(128, ge=1)
    """channel cap of the coarse levels."""
    levels: int = Field(7, ge=1, le=10)
    """encoder levels (each halves the resolution); 8 at 256² reaches 1×1 like the paper."""
    decoder_convs: int = Field(1, ge=1)
    """convolutions per decoder level after the skip concatenation (paper: 2)."""
    dropout: float = Field(0.5, ge=0, lt=1)
    """dropout probability on the coarsest decoder levels, training only."""
    dropout_levels: int = Field(3, ge=0)
    """how many of the coarsest decoder levels get dropout (paper: 3)."""
    global_track: bool = True
    """the paper's global-feature track (§4.2: instance-norm means -> FC -> SELU, fed back as per-channel biases);
    false leaves a plain U-Net with instance normalisation (the ablation of benchmarks/ablation.py)."""
    zero_output: bool = False
    """start the output convolution at zero weights, so that the untrained network predicts exactly its output
    biases (a flat normal and a uniform plausible material) instead of random per-pixel maps."""

    def widths(self) -> list[int]:
        """Channels of each encoder level, finest first."""
        return [min(self.base_width * 2 ** i, self.max_width) for i in range(self.levels)]


class DataConfig(ConfigModel):
    """Training data and augmentation."""

    store: str | None = None
    """renders store path; None = the in-memory synthetic source (tests, benchmarks, smoke runs)."""
    crop: int = Field(256, ge=1)
    """random crop size fed to the network (the paper crops 288 -> 256); must divide by 2^levels."""
    augment: bool = True
    """random flips and 90° rotations (normals rotated with the image)."""
    crop_at: Literal["random", "centre"] = "random"
    """where a training crop sits in its view: "random" (anywhere), or "centre" (always the view's centre, as
    evaluation crops: the network then sees the capture geometry of the evaluated window)."""
    holdout: float = Field(DEFAULT_HOLDOUT, gt=0, lt=1)
    """fraction of source materials/presets held out for evaluation (split by material, not sample)."""
    workers: int = Field(2, ge=0)
    """DataLoader worker processes (0 = load in the main process)."""
    loader_memory_mib: int = Field(0, ge=0)
    """MiB the store reader's caches may hold over the whole run on this machine, divided among the processes
    that read (every rank's main process and its ``workers``; train/loader_memory.py); 0 = automatic: the smaller
    of 4 GiB and a quarter of the memory available at the start. Workers that cannot get the reader's minimum
    from it, or from the machine, are refused in one line."""
    split_seed: int = Field(DEFAULT_SEED, ge=0, lt=2 ** 64)
    """seed of the held-out split (:mod:`svcore.split`), separate from ``optim.seed`` so that training seeds vary the
    training only; the default is the split a renders store records (its ``split`` attribute)."""
    blends: bool = True
    """train on the blended SVBRDFs too; false: only on SVBRDFs rendered from a variants store (paper §3's mixing
    ablation). The held-out split and every evaluation stay the same (they are chosen before this filter)."""
    eval_views: int = Field(32, ge=1)
    """held-out views evaluated every ``optim.eval_every`` steps during fit (spread evenly over the held-out split)."""
    synthetic_samples: int = Field(256, ge=1)
    """samples of the synthetic source (only when store is None)."""
    synthetic_size: int = Field(288, ge=1)
    """image size of the synthetic source."""
    synthetic_materials: int = Field(16, ge=1)
    """distinct synthetic 'materials' (the unit of the held-out split)."""
    synthetic_kind: Literal["simple", "presets"] = "simple"
    """synthetic maps: "simple" (smooth random fields) or "presets" (materials package presets)."""
    synthetic_seed: int = Field(0, ge=0, lt=2 ** 64)
    """seed of the synthetic source (independent of the training seed)."""


class OptimConfig(ConfigModel):
    """Adam, the schedule and the loss terms (paper: lr 2e-5, beta1 0.5, batch 8, 400k iterations)."""

    lr: float = Field(2e-5, gt=0)
    """Adam learning rate."""
    beta1: float = Field(0.5, ge=0, lt=1)
    """Adam beta1."""
    beta2: float = Field(0.999, ge=0, lt=1)
    """Adam beta2."""
    batch_size: int = Field(8, ge=1)
    """samples per step."""
    iterations: int = Field(1000, ge=1)
    """total optimisation steps (at least 1: 0 steps would write a 'done' run with no loss)."""
    seed: int = Field(0, ge=0, lt=2 ** 64)
    """master seed: data order, augmentation, loss configurations, weights, dropout."""
    checkpoint_every: int = Field(200, ge=1)
    """steps between checkpoints (and at the end / on interruption)."""
    checkpoint_minutes: float = Field(10.0, ge=0)
    """also checkpoint when this many minutes passed since the last checkpoint, so a killed long run loses
    minutes (0 = by steps only)."""
    log_every: int = Field(10, ge=1)
    """steps between rows of the loss log."""
    threads: int = Field(0, ge=0)
    """torch intra-op threads (0 = torch's default)."""
    render_weight: float = Field(1.0, ge=0)
    """weight of the rendering loss (paper §4.3); 0 with ``map_l1`` > 0 is the paper's L1-on-the-maps comparison
    (no rendering term is computed at all)."""
    map_l1: float = Field(0.0, ge=0)
    """weight of an L1 term on the packed maps added to the rendering loss (0 = the 2018 paper's loss alone; the
    2019 follow-up, Deschaintre et al. "Flexible SVBRDF capture", mixes both)."""
    spec_grad: float = Field(0.0, ge=0)
    """weight of an L1 term on the specular map's neighbour differences, predicted against true (0 = off;
    ``train.fit.spec_grad_term``): it prices specular texture that the truth does not have, which the rendering
    loss pays for when the other maps are wrong."""
    normal_loss: Literal["l2", "rmse"] = "l2"
    """the form of the ``normal_l2`` term: "l2" (squared error on the unit normals' x and y) or "rmse" (each sample's
    RMSE in the (n+1)/2 encoding, averaged: the metric of ``svtrain eval``, which a pooled squared error is not: it
    makes relief predicted on a flat material cost as much as the evaluation says it does)."""
    normal_l2: float = Field(0.0, ge=0)
    """weight of a squared-error term on the predicted normals' x and y added to the rendering loss (0 = off). The
    rendering loss alone leaves the normals flat within a CPU budget (README, known limits); RMSE is the metric, so
    the term is squared, not L1 (an L1 term pulls an uncertain tilt to its median, flat)."""
    normal_late_loss: Literal["l2", "rmse"] | None = None
    """the normal term's form from ``normal_late_from`` of the run on, with weight ``normal_late_weight`` (None: the
    ``normal_loss`` form throughout). With "rmse" after the l2 form the first part of a run learns relief and the
    rest removes the relief the model is unsure of (experiments/real_shape/REPORT.md)."""
    normal_late_from: float = Field(0.5, gt=0, lt=1)
    """share of ``iterations`` after which ``normal_late_loss`` replaces the ``normal_loss`` form."""
    normal_late_weight: float = Field(30.0, gt=0)
    """weight of the late normal term (30 for "rmse": the l2 term's gradient at weight 100 and a sample RMSE of
    0.03)."""
    grad_clip: float = Field(0.0, ge=0)
    """largest global gradient norm per step, 0 = no clipping (the paper clips nothing)."""
    schedule: Literal["constant", "cosine"] = "constant"
    """learning rate over the run: "constant" (the paper) or "cosine" (from lr down to lr·lr_final at the last of
    ``iterations``, a pure function of the step, so resumed runs see the same rates)."""
    lr_final: float = Field(0.05, ge=0, le=1)
    """last learning rate of the cosine schedule as a fraction of lr."""
    eval_every: int = Field(0, ge=0)
    """steps between evaluations of ``data.eval_views`` held-out views during fit, written to heldout.csv with the
    training time so far (evaluation time excluded); 0 = off (heldout.csv then holds only its header)."""
    init: str | None = None
    """start from these weights instead of the seeded initialisation (fine-tuning): a checkpoint file, a run
    directory, or "bundled" (the model shipped in the package); its model config must equal this run's, and the
    optimiser, schedule and step count start fresh. None: the seeded initialisation."""
    compile_loss: bool = True
    """torch.compile the loss renderer (fuses its elementwise ops: faster on CPU after a one-off compile, cached
    on disk by inductor; benchmarks/bench_train.py measures both); off in tests."""


    @model_validator(mode="after")
    def _some_loss(self) -> "OptimConfig":
        if self.render_weight == 0 and self.map_l1 == 0 and self.normal_l2 == 0:
            raise ValueError("every loss weight is 0 (render_weight, map_l1, normal_l2): nothing to train on")
        return self


#: what ``compute.device`` may say (``train.device.resolve_device`` then checks the machine has it).
DEVICE_SPEC = re.compile(r"(auto|cpu|cuda|mps)(?::(\d+))?")


class ComputeConfig(ConfigModel):
    """Where and how wide training runs (train/device.py, train/distributed.py; README "Training on GPUs")."""

    device: str = "auto"
    """auto (CUDA when available, else CPU), cpu, cuda, cuda:N or mps; under --nproc each process takes
    cuda:LOCAL_RANK."""
    precision: Literal["fp32", "bf16", "fp16"] = "fp32"
    """fp32, bf16 or fp16 (autocast on the network; the loss renderer stays float32; fp16 is refused on the CPU)."""
    nproc: int = Field(1, ge=1)
    """data-parallel processes on this machine, launched by torch.distributed's elastic launcher (gloo on CPU,
    NCCL on CUDA); under torchrun the launcher's world size is used instead."""
    global_batch: int = Field(0, ge=0)
    """samples per step over all processes; 0 = optim.batch_size x world size. optim.lr is used as given (no
    automatic scaling): when the global batch grows k-fold, scale optim.lr yourself, by sqrt(k) for Adam."""

    @field_validator("device")
    @classmethod
    def _device_spelling(cls, v: str) -> str:
        # only the spelling here (configs are read on machines without the device); presence: train.device
        m = DEVICE_SPEC.fullmatch(v.strip().lower())
        if m is None or (m.group(2) is not None and m.group(1) != "cuda"):
            raise ValueError(f"unknown device {v!r}; use one of auto, cpu, cuda, cuda:N, mps")
        return v

    @model_validator(mode="after")
    def _even_split(self) -> "ComputeConfig":
        if self.global_batch and self.global_batch % self.nproc:
            raise ValueError(f"global_batch {self.global_batch} does not split over {self.nproc} processes; "
                             f"use a multiple of {self.nproc}")
        return self


class Config(ConfigModel):
    """Everything ``svtrain fit`` needs (params.yaml section ``train``)."""

    SECTION: ClassVar[str] = "train"
    DEFAULT_PRESET: ClassVar[str] = "compact"
    # compact: the width and the loss terms chosen by measurement (experiments/train_budget and
    # experiments/normal_supervision): the smallest base width whose held-out re-render RMSE after ~10 min on 2
    # cores is within 5 % of the next larger width's; grad_clip cuts only the gradient spikes that otherwise
    # saturated the larger widths at lr 1e-3; zero_output and normal_l2 from the normal-supervision probes.
    # The numbers live in those files, not here, so that rerunning a benchmark cannot leave this comment stale.
    # base_width 16 (max 128) since #22: the shape grid (results/shape.json) found width 16 the network change that
    # most lowers held-out normal RMSE relative to flat, also at equal CPU time (its probe beats width 8 at 2x the
    # steps); the re-render rule above had found 8 and 16 within 5 % of each other.
    # normal_loss stays l2: the rmse form (#22) helps on real materials when fine-tuning (results/shape_finetune.json
    # rmse_term) but from scratch it predicts nearly flat normals at 2,770 steps (results/sim2real_rmse.json) and at
    # weight 30 a 5,540-step cosine run collapsed at step ~750 (normals saturated, loss 1.0 -> 15; README).
    # Since #39 round 5 (experiments/real_shape): from 30 % of the run on, the normal term is each sample's RMSE
    # (false relief costs as evaluation counts it) after l2 has shaped the normals, plus 0.1 x L1 on the maps (the
    # 2019 mixed loss; in round 5 it widened the real diffuse's interval more than it protected the diffuse, and it
    # pulls the specular toward grey), at lr 5e-4 (1e-3 diverged from scratch at step ~700 in the real-data
    # control); the bundled model retrained this way is judged in results/retrain_r5.json.
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "compact": {"model": {"base_width": 16, "max_width": 128, "levels": 7, "decoder_convs": 1, "zero_output": True},
                    "data": {"crop": 128, "synthetic_size": 144},
                    "optim": {"lr": 5e-4, "grad_clip": 5.0, "schedule": "cosine", "normal_l2": 100.0, "map_l1": 0.1,
                              "normal_late_loss": "rmse", "normal_late_from": 0.3}},
        "paper": {"model": {"base_width": 64, "max_width": 512, "levels": 8, "decoder_convs": 2, "dropout": 0.5},
                  "data": {"crop": 256},
                  "optim": {"iterations": 400_000, "checkpoint_every": 5000, "log_every": 100}},
    }

    model: ModelConfig = Field(default_factory=ModelConfig)
    """network shape."""
    data: DataConfig = Field(default_factory=DataConfig)
    """data source and augmentation."""
    optim: OptimConfig = Field(default_factory=OptimConfig)
    """optimiser and schedule."""
    compute: ComputeConfig = Field(default_factory=ComputeConfig)
    """device, precision, data-parallel width."""

    @model_validator(mode="after")
    def _consistent(self) -> "Config":
        m, d = self.model, self.data
        if m.max_width < m.base_width:
            raise ValueError(f"model.max_width ({m.max_width}) must be >= model.base_width ({m.base_width})")
        if d.crop % (2 ** m.levels):
            raise ValueError(f"data.crop={d.crop} must be a multiple of 2^model.levels={2 ** m.levels}")
        if d.store is None and d.synthetic_size < d.crop:
            raise ValueError(f"data.synthetic_size={d.synthetic_size} must be >= data.crop={d.crop}")
        return self

    @classmethod
    def stored(cls, values: dict[str, Any]) -> dict[str, Any]:
        """A params file's ``train:`` section (a run's config.yaml, an older params.yaml) without the keys #41 retired
        (:func:`drop_retired`)."""
        return drop_retired(values)

    def check(self) -> "Config":
        """Validate again as a whole (after fields were assigned one by one, e.g. by a benchmark)."""
        validate(Config, self.as_dict())
        return self


#: the last commit that still runs the arms #41 removed first (fullres_convs, normal_head, normal_param,
#: grazing_lights and the slope and cosine normal terms).
RETIRED_AT = "50a7983"
#: the last commit that still runs the #39 arms #41 removed later (model.coord_channels, model.normal_decoder,
#: model.highlight_cue).
RETIRED_AT_39 = "614fe8c"

#: config keys removed in #41 with their code paths (arms that lost): key -> (the value it had by default, at which
#: the removed path did nothing, so that a stored config holding it at that value means the same without it; the
#: last commit that runs it at another value).
RETIRED: dict[str, tuple[Any, str]] = {
    "model.fullres_convs": (0, RETIRED_AT), "model.normal_head": (False, RETIRED_AT),
    "model.normal_param": ("unit", RETIRED_AT), "optim.grazing_lights": (0.0, RETIRED_AT),
    "model.coord_channels": (False, RETIRED_AT_39),  # CoordConv pixel coordinates (#39 rounds 3 and 7)
    "model.normal_decoder": (False, RETIRED_AT_39),  # a second decoder for the normal (#39 rounds 1-3)
    "model.highlight_cue": (False, RETIRED_AT_39),  # the photo minus a highlight-suppressed copy (#39 round 8)
}

#: values of kept keys whose code paths #41 removed (the normal term's forms other than l2 and rmse) -> (those
#: values, the last commit that runs them).
RETIRED_VALUES: dict[str, tuple[tuple[Any, ...], str]] = {"optim.normal_loss": (("slope", "cosine"), RETIRED_AT),
                                                          "optim.normal_late_loss": (("slope", "cosine"), RETIRED_AT)}


def drop_retired(values: dict[str, Any]) -> dict[str, Any]:
    """A stored config (sections as nested mappings: a checkpoint's, a run's config.yaml, an older params.yaml)
    without the :data:`RETIRED` keys, which it may hold at their old defaults only.

    Args:
        values: the config's sections (``{"model": {...}, "optim": {...}, ...}``); not modified.

    Returns:
        A copy without the retired keys.

    Raises:
        ConfigError: a retired key at another value, or a :data:`RETIRED_VALUES` value (one line naming the key and
            the commit that still runs it).
    """
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in values.items()}
    for key, (old, commit) in RETIRED.items():
        section, _, name = key.partition(".")
        if isinstance(out.get(section), dict) and name in out[section]:
            value = out[section].pop(name)
            # bool is an int in Python: False must not pass for 0, nor 0 for False
            if value != old or isinstance(value, bool) != isinstance(old, bool):
                raise ConfigError(_retired(key, value, commit))
    for key, (gone, commit) in RETIRED_VALUES.items():
        section, _, name = key.partition(".")
        value = out.get(section, {}).get(name) if isinstance(out.get(section), dict) else None
        if isinstance(value, str) and value in gone:
            raise ConfigError(_retired(key, value, commit))
    return out


def _retired(key: str, value: Any, commit: str) -> str:
    return (f"{Config.SECTION}.{key}={value!r}: this arm's code path was removed in #41; commit {commit} is the "
            f"last that runs it (git checkout {commit})")


def preset(name: str) -> Config:
    """A fresh Config of a named preset (see ``Config.PRESETS``)."""
    return resolve_config(Config, name)


def resolve(preset_name: str | None = None, params_file: str | Path | None = None,
            overrides: dict[str, Any] | None = None) -> Config:
    """preset < params.yaml ``train:`` section < overrides (dotted keys, typed values); validated.

    The preset is ``preset_name``, else the section's ``config_preset:`` key, else "compact".
    """
    return resolve_config(Config, preset_name, params_file, flags=overrides)


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["model.base_width=32", ...]`` -> ``{"model.base_width": 32}`` (values read as YAML, like params.yaml)."""
    return parse_sets(items)


def from_dict(d: dict[str, Any]) -> Config:
    """Rebuild a Config written by :meth:`Config.to_dict` (checkpoints, config.yaml), retired keys dropped
    (:func:`drop_retired`).

    Raises:
        ConfigError: an unknown key, a bad value, or a retired key at another value than its old default.
    """
    # runs written before svcore.config recorded the preset name as a field; the values are complete without it
    return validate(Config, drop_retired({k: v for k, v in d.items() if k != "preset"}))
