"""Typed training configuration: dataclasses, named presets, loading from params.yaml and flags.

``resolve(preset, params_file, overrides)`` builds a :class:`Config` as
preset < ``train:`` section of params.yaml < ``key.sub=value`` overrides, and rejects unknown keys
and out-of-range values with :class:`pipeline.errors.ConfigError` (one line on the CLI).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from pipeline.errors import ConfigError


#: learning-rate schedules of OptimConfig.schedule (train.fit.lr_at).
SCHEDULES = ("constant", "cosine")


@dataclass
class ModelConfig:
    """U-Net + global-feature track."""

    base_width: int = 16
    """channels of the first (finest) encoder level; level i has min(base_width·2^i, max_width)."""
    max_width: int = 128
    """channel cap of the coarse levels."""
    levels: int = 7
    """encoder levels (each halves the resolution); 8 at 256² reaches 1×1 like the paper."""
    decoder_convs: int = 1
    """convolutions per decoder level after the skip concatenation (paper: 2)."""
    dropout: float = 0.5
    """dropout probability on the coarsest decoder levels, training only."""
    dropout_levels: int = 3
    """how many of the coarsest decoder levels get dropout (paper: 3)."""
    zero_output: bool = False
    """start the output convolution at zero weights, so that the untrained network predicts exactly its output
    biases (a flat normal and a uniform plausible material) instead of random per-pixel maps."""

    def widths(self) -> list[int]:
        """Channels of each encoder level, finest first."""
        return [min(self.base_width * 2 ** i, self.max_width) for i in range(self.levels)]


@dataclass
class DataConfig:
    """Training data and augmentation."""

    store: str | None = None
    """renders store path; None = the in-memory synthetic source (tests, benchmarks, smoke runs)."""
    crop: int = 256
    """random crop size fed to the network (the paper crops 288 -> 256); must divide by 2^levels."""
    augment: bool = True
    """random flips and 90° rotations (normals rotated with the image)."""
    holdout: float = 0.1
    """fraction of source materials/presets held out for evaluation (split by material, not sample)."""
    workers: int = 2
    """DataLoader worker processes (0 = load in the main process)."""
    synthetic_samples: int = 256
    """samples of the synthetic source (only when store is None)."""
    synthetic_size: int = 288
    """image size of the synthetic source."""
    synthetic_materials: int = 16
    """distinct synthetic 'materials' (the unit of the held-out split)."""
    synthetic_kind: str = "simple"
    """synthetic maps: "simple" (smooth random fields) or "presets" (materials package presets)."""
    synthetic_seed: int = 0
    """seed of the synthetic source (independent of the training seed)."""


@dataclass
class OptimConfig:
    """Adam and the schedule (paper: lr 2e-5, beta1 0.5, batch 8, 400k iterations)."""

    lr: float = 2e-5
    """Adam learning rate."""
    beta1: float = 0.5
    """Adam beta1."""
    beta2: float = 0.999
    """Adam beta2."""
    batch_size: int = 8
    """samples per step."""
    iterations: int = 1000
    """total optimisation steps."""
    seed: int = 0
    """master seed: data order, augmentation, loss configurations, weights, dropout."""
    checkpoint_every: int = 200
    """steps between checkpoints (and at the end / on interruption)."""
    log_every: int = 10
    """steps between rows of the loss log."""
    threads: int = 0
    """torch intra-op threads (0 = torch's default)."""
    map_l1: float = 0.0
    """weight of an L1 term on the packed maps added to the rendering loss (0 = the 2018 paper's loss alone; the
    2019 follow-up, Deschaintre et al. "Flexible SVBRDF capture", mixes both)."""
    normal_l2: float = 0.0
    """weight of a squared-error term on the predicted normals' x and y added to the rendering loss (0 = off). The
    rendering loss alone leaves the normals flat within a CPU budget (README, known limits); RMSE is the metric, so
    the term is squared, not L1 (an L1 term pulls an uncertain tilt to its median, flat)."""
    grad_clip: float = 0.0
    """largest global gradient norm per step, 0 = no clipping (the paper clips nothing)."""
    schedule: str = "constant"
    """learning rate over the run: "constant" (the paper) or "cosine" (from lr down to lr·lr_final at the last of
    ``iterations``, a pure function of the step, so resumed runs see the same rates)."""
    lr_final: float = 0.05
    """last learning rate of the cosine schedule as a fraction of lr."""
    compile_loss: bool = True
    """torch.compile the loss renderer (fuses ~60 elementwise ops: ~4x faster on CPU after a one-off
    compile of 20-80 s, cached on disk by inductor); off in tests."""


@dataclass
class ComputeConfig:
    """Where and how wide training runs (train/device.py, train/distributed.py; README "Training on GPUs")."""

    device: str = "auto"
    """auto (CUDA when available, else CPU), cpu, cuda, cuda:N or mps; under --nproc each process takes
    cuda:LOCAL_RANK."""
    precision: str = "fp32"
    """fp32, bf16 or fp16 (autocast on the network; the loss renderer stays float32; fp16 is refused on the CPU)."""
    nproc: int = 1
    """data-parallel processes on this machine, launched by torch.distributed's elastic launcher (gloo on CPU,
    NCCL on CUDA); under torchrun the launcher's world size is used instead."""
    global_batch: int = 0
    """samples per step over all processes; 0 = optim.batch_size x world size. optim.lr is used as given (no
    automatic scaling): when the global batch grows k-fold, scale optim.lr yourself, by sqrt(k) for Adam."""


@dataclass
class Config:
    """Everything ``svtrain fit`` needs."""

    preset: str = "compact"
    """name of the preset this config started from (informational)."""
    model: ModelConfig = field(default_factory=ModelConfig)
    """network shape."""
    data: DataConfig = field(default_factory=DataConfig)
    """data source and augmentation."""
    optim: OptimConfig = field(default_factory=OptimConfig)
    """optimiser and schedule."""
    compute: ComputeConfig = field(default_factory=ComputeConfig)
    """device, precision, data-parallel width."""

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def validate(self) -> "Config":
        m, d, o = self.model, self.data, self.optim
        checks = [
            (m.base_width >= 1 and m.max_width >= m.base_width, "model.base_width must be >= 1 and <= max_width"),
            (1 <= m.levels <= 10, "model.levels must be 1..10"),
            (m.decoder_convs >= 1, "model.decoder_convs must be >= 1"),
            (0.0 <= m.dropout < 1.0, "model.dropout must be in [0, 1)"),
            (d.crop % (2 ** m.levels) == 0, f"data.crop={d.crop} must be a multiple of 2^levels={2 ** m.levels}"),
            (0.0 < d.holdout < 1.0, "data.holdout must be in (0, 1)"),
            (d.workers >= 0, "data.workers must be >= 0"),
            (d.synthetic_kind in ("simple", "presets"), "data.synthetic_kind must be 'simple' or 'presets'"),
            (d.store is not None or d.synthetic_size >= d.crop, "data.synthetic_size must be >= data.crop"),
            (o.lr > 0 and 0 <= o.beta1 < 1 and 0 <= o.beta2 < 1, "optim.lr > 0 and betas in [0, 1)"),
            (o.batch_size >= 1 and o.iterations >= 0, "optim.batch_size >= 1, optim.iterations >= 0"),
            (o.checkpoint_every >= 1 and o.log_every >= 1, "optim.checkpoint_every/log_every >= 1"),
            (o.seed >= 0, "optim.seed must be >= 0"),
            (o.grad_clip >= 0, "optim.grad_clip must be >= 0 (0 = off)"),
            (o.map_l1 >= 0, "optim.map_l1 must be >= 0 (0 = rendering loss only)"),
            (o.normal_l2 >= 0, "optim.normal_l2 must be >= 0 (0 = off)"),
            (o.schedule in SCHEDULES, f"optim.schedule must be one of {', '.join(SCHEDULES)}"),
            (0.0 <= o.lr_final <= 1.0, "optim.lr_final must be in [0, 1]"),
            (self.compute.nproc >= 1, f"compute.nproc (--nproc) must be >= 1, got {self.compute.nproc}"),
            (self.compute.global_batch >= 0, "compute.global_batch (--global-batch) must be >= 0 (0 = batch x world)"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ConfigError(msg)
        return self


def _paper() -> Config:
    return Config(preset="paper",
                  model=ModelConfig(base_width=64, max_width=512, levels=8, decoder_convs=2, dropout=0.5),
                  data=DataConfig(crop=256),
                  optim=OptimConfig(iterations=400_000, checkpoint_every=5000, log_every=100))


def _compact() -> Config:
    # Width chosen by benchmarks/bench_train_budget.py (results/train_budget.json, chart 2): the smallest base width
    # whose held-out re-render RMSE after ~10 min of training on 2 cores is within 5 % of the next larger width's.
    # Measured (dvc default store, lr 1e-3 cosine, 170 held-out views): 0.0402 (8, 2707 steps), 0.0412 (16, 1847),
    # 0.0391 (32, 1345) -> 8; its mean over the five columns is the best of the three (0.078 / 0.096 / 0.084).
    # grad_clip 5: 2-4x the median gradient norm of widths 8-32 at lr 1e-3 (1.3 / 1.7 / 3.0; 99th percentile 6 / 5
    # / 27), so only the spikes are cut; without it width 32 jumped to a saturated state at lr 1e-3 and stayed there
    # (results/train_budget_constant_noclip.json).
    # zero_output: same 2707 steps, re-render 0.0384 against 0.0402 with random output weights, normal / diffuse /
    # specular a little better, roughness worse (0.203 against 0.186; results/probe_zero_output.json).
    # normal_l2 100: the rendering loss alone leaves the normals flat (held-out normal RMSE 0.0791 against the flat
    # normal's 0.0792); the same 2707 steps with the squared normal term at 10 / 30 / 100 give 0.0790 / 0.0765 /
    # 0.0734, for a re-render RMSE of 0.0393 / 0.0422 / 0.0447 (0.0384 without;
    # results/probe_normal_l2_{10,30,100}.json).
    # 100 is the one whose normals are better than flat on most views (71 %, 53 % at 30).
    return Config(preset="compact", model=ModelConfig(base_width=8, max_width=64, levels=7, decoder_convs=1,
                                                      zero_output=True),
                  data=DataConfig(crop=128, synthetic_size=144),
                  optim=OptimConfig(lr=1e-3, grad_clip=5.0, schedule="cosine", normal_l2=100.0))


#: named presets: name -> factory.
PRESETS = {"compact": _compact, "paper": _paper}


def preset(name: str) -> Config:
    """A fresh Config for a named preset."""
    if name not in PRESETS:
        raise ConfigError(f"unknown preset {name!r}; known: {', '.join(sorted(PRESETS))}")
    return PRESETS[name]()


def _coerce(value: Any, typ: Any, key: str) -> Any:
    t = typ if isinstance(typ, str) else getattr(typ, "__name__", str(typ))
    try:
        if isinstance(value, str) and value.lower() in ("none", "null") and "None" in t:
            return None
        if t.startswith("int"):
            return int(value)
        if t.startswith("float"):
            return float(value)
        if t.startswith("bool"):
            if isinstance(value, str):
                if value.lower() not in ("true", "false", "1", "0", "yes", "no"):
                    raise ValueError(value)
                return value.lower() in ("true", "1", "yes")
            return bool(value)
        if t.startswith("str"):
            return None if value is None else str(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{key}={value!r} is not a valid {t}") from None
    return value


def apply(cfg: Config, values: dict[str, Any], prefix: str = "") -> Config:
    """Set nested values ``{"model": {"base_width": 32}}`` or flat ``{"model.base_width": 32}`` on cfg."""
    for key, val in values.items():
        if "." in key:
            head, rest = key.split(".", 1)
            apply(cfg, {head: {rest: val}}, prefix)
            continue
        obj_fields = {f.name: f for f in dataclasses.fields(cfg)}
        full = prefix + key
        if key not in obj_fields:
            raise ConfigError(f"unknown config key {full!r}; known: {', '.join(prefix + k for k in obj_fields)}")
        cur = getattr(cfg, key)
        if dataclasses.is_dataclass(cur):
            if not isinstance(val, dict):
                raise ConfigError(f"config key {full!r} is a section; give its fields")
            apply(cur, val, full + ".")
        else:
            setattr(cfg, key, _coerce(val, obj_fields[key].type, full))
    return cfg


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["model.base_width=32", ...]`` -> ``{"model.base_width": "32"}``."""
    out = {}
    for it in items:
        if "=" not in it:
            raise ConfigError(f"override {it!r} is not key=value (e.g. model.base_width=32)")
        k, v = it.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def load_params(path: str | Path, section: str = "train") -> dict[str, Any]:
    """The ``section`` of a params.yaml (empty when the file has none)."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"params file {str(p)!r} does not exist")
    try:
        doc = yaml.safe_load(p.read_text()) or {}
    except yaml.YAMLError as e:
        raise ConfigError(f"params file {str(p)!r} is not valid YAML: {str(e).splitlines()[0]}") from None
    sec = doc.get(section, {}) if isinstance(doc, dict) else None
    if not isinstance(sec, dict):
        raise ConfigError(f"section {section!r} of {str(p)!r} must be a mapping")
    return sec


def resolve(preset_name: str | None = None, params_file: str | Path | None = None,
            overrides: dict[str, Any] | None = None) -> Config:
    """preset < params.yaml ``train:`` section (may name its own ``preset``) < overrides; validated."""
    sec = dict(load_params(params_file)) if params_file else {}
    name = preset_name or sec.pop("preset", None) or "compact"
    sec.pop("preset", None)
    cfg = preset(name)
    apply(cfg, sec)
    apply(cfg, overrides or {})
    return cfg.validate()


def from_dict(d: dict[str, Any]) -> Config:
    """Rebuild a Config written by :meth:`Config.to_dict` (checkpoints, config.yaml)."""
    d = dict(d)
    cfg = preset(d.pop("preset", "compact"))
    return apply(cfg, d).validate()
