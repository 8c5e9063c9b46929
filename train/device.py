"""Where training runs and in which precision: ``--device`` and ``--precision`` of ``svtrain fit``.

Devices: ``auto`` (CUDA when torch sees one, else the CPU), ``cpu``, ``cuda``, ``cuda:N``, ``mps``. A device that
is named but absent is a :class:`~svcore.errors.ConfigError` (one line on the CLI), never a silent fallback.

Precisions (:data:`PRECISIONS`): ``fp32``; ``bf16`` and ``fp16`` run the *network* under ``torch.autocast``
(convolutions and linear layers in the low precision). What must stay float32 does, and these are the places:

- the rendering loss (``train.loss.rendering_loss``): the predicted maps are cast to float32 and autocast is
  switched off around both renderings and the log, because ``log(R + 0.01)`` of radiances near 0 and the GGX
  terms near the roughness floor (``a2 = 1e-8`` at r = 0.01, ``D`` up to 3e7) need float32's 24-bit mantissa:
  bf16 has 8 bits, fp16 overflows at 65504;
- ``train.brdf.ggx_cos`` upcasts half inputs to float32 (the same guard for evaluation and re-renders);
- the network's instance normalisation statistics (``train.net.GlobalConv``): mean and variance of a
  convolution's output are taken in float32 (a bf16 variance of 256² values loses the small ones, an fp16 one
  overflows);
- the optimiser state and the weights (autocast never changes them; Adam runs in float32).

fp16 needs a gradient scaler (``torch.amp.GradScaler``, on for fp16 only). fp16 on the CPU is *refused*, not
silently changed to something else: CPUs have no fast float16 arithmetic, and bf16 (float32's exponent range, no
scaler needed) is the CPU's half precision. bf16 on a CPU without native bf16 instructions (AVX512-BF16, AMX) runs,
but several times slower than fp32 (benchmarks/results/train.json rows).
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import torch

from svcore.errors import ConfigError

from .config import DEVICE_SPEC

#: device kinds of ``--device`` (``cuda`` also as ``cuda:N``).
DEVICE_KINDS = ("auto", "cpu", "cuda", "mps")
#: precision name -> autocast dtype (None = plain float32).
PRECISIONS: dict[str, torch.dtype | None] = {"fp32": None, "bf16": torch.bfloat16, "fp16": torch.float16}


def _mps_available() -> bool:
    mps = getattr(torch.backends, "mps", None)
    return bool(mps is not None and mps.is_available())


def resolve_device(spec: str, local_rank: int | None = None) -> torch.device:
    """The torch device for a ``--device`` string.

    Args:
        spec: ``auto``, ``cpu``, ``cuda``, ``cuda:N`` or ``mps``.
        local_rank: under data-parallel training, the process's rank on its machine: ``cuda`` then means
            ``cuda:local_rank`` (one GPU per process).

    Raises:
        ConfigError: unknown string, or a device this machine does not have.
    """
    s = str(spec).strip().lower()
    m = DEVICE_SPEC.fullmatch(s)
    if m is None or (m.group(2) is not None and m.group(1) != "cuda"):
        raise ConfigError(f"unknown device {spec!r}; use one of auto, cpu, cuda, cuda:N, mps")
    kind, index = m.group(1), m.group(2)
    if kind == "auto":
        kind = "cuda" if torch.cuda.is_available() else "cpu"
    if kind == "cpu":
        return torch.device("cpu")
    if kind == "mps":
        if not _mps_available():
            raise ConfigError("device 'mps' requested but this machine has no Apple GPU torch can use "
                              "(torch.backends.mps.is_available() is False); use --device cpu")
        return torch.device("mps")
    if not torch.cuda.is_available():
        why = "this torch is a CPU-only build" if torch.version.cuda is None else "torch sees no CUDA GPU"
        raise ConfigError(f"device {spec!r} requested but CUDA is not available ({why}, torch {torch.__version__}); "
                          f"use --device cpu or auto")
    n = torch.cuda.device_count()
    if index is not None and local_rank is not None:
        raise ConfigError(f"--device {spec} names one GPU, but data-parallel training gives each process its own "
                          f"(cuda:LOCAL_RANK): use --device cuda")
    i = int(index) if index is not None else (local_rank or 0)
    if i >= n:
        raise ConfigError(f"device cuda:{i} requested but this machine has {n} CUDA device(s) (0..{n - 1})")
    return torch.device("cuda", i)


def check_precision(name: str, device: torch.device) -> torch.dtype | None:
    """The autocast dtype of a ``--precision`` on ``device`` (None for fp32).

    Raises:
        ConfigError: unknown precision; fp16 on the CPU (refused: use bf16 there).
    """
    if name not in PRECISIONS:
        raise ConfigError(f"unknown precision {name!r}; use one of {', '.join(PRECISIONS)}")
    if name == "fp16" and device.type == "cpu":
        raise ConfigError("--precision fp16 is refused on the CPU (no gradient-scaled fp16 path there); "
                          "use --precision bf16 on the CPU, fp16 on a GPU")
    return PRECISIONS[name]


@dataclass
class Placement:
    """Device and precision of one training process.

    Attributes:
        device: where the model, the loss renderer and the batches live.
        precision: ``fp32``, ``bf16`` or ``fp16``.
        dtype: the autocast dtype (None for fp32).
    """

    device: torch.device
    precision: str = "fp32"
    dtype: torch.dtype | None = None

    @property
    def pin_memory(self) -> bool:
        """Page-locked loader batches: only worth it (and only allowed) when copying to a CUDA GPU."""
        return self.device.type == "cuda"

    def autocast(self):
        """Context of the network's forward pass: autocast for bf16/fp16, a no-op for fp32."""
        if self.dtype is None:
            return contextlib.nullcontext()
        return torch.autocast(device_type=self.device.type, dtype=self.dtype)

    def scaler(self) -> torch.amp.GradScaler:
        """Gradient scaler: active for fp16 only (bf16 has float32's exponent range and needs none)."""
        return torch.amp.GradScaler(self.device.type, enabled=self.precision == "fp16")

    def to(self, t: torch.Tensor) -> torch.Tensor:
        """Move a host tensor to the device, asynchronously when it is pinned (the copy overlaps compute)."""
        return t.to(self.device, non_blocking=self.pin_memory)


def placement(device: str, precision: str, local_rank: int | None = None) -> Placement:
    """Resolve ``--device`` and ``--precision`` together (bad combinations raise ConfigError)."""
    dev = resolve_device(device, local_rank)
    return Placement(dev, precision, check_precision(precision, dev))
