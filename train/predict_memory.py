"""``svtrain predict``'s memory bound: the peak of a prediction estimated up front, refused in one line when it
cannot fit (as the data stages refuse oversize requests, :mod:`storage.bounds`).

Every tensor of the forward pass and of the re-rendering scales with the pixels (the network is fully
convolutional; its global track is a vector per image), so the peak of a prediction at side ``s`` is the peak at
the network's stride times ``(s / stride)²``. That peak is measured, not modelled: :func:`bytes_per_pixel` runs the
model once at the stride (the smallest size it takes) and tracks the bytes of the live tensors op by op
(:class:`LiveBytes`), whatever the network's options and widths.

Measured (this machine, CPU, float32, batch 1): the live tensors peak at 272 bytes per pixel for the compact preset
and 723 for the paper preset (1,467 for the paper widths with a second normal decoder and one full-resolution
convolution, options removed in #41); the peak resident memory of a whole ``svtrain predict`` above what the loaded
model holds measured 292-408 bytes per pixel (compact, sizes 512-2048) and 324-772 (paper, 512-1536): at most 1.5x
the traced peak (the allocator's slack, the convolutions' workspaces, the PNG/EXR encodings), hence :data:`MARGIN` 2.
With it the compact model needs about 544 bytes per pixel (``--size 8192``: about 34 GiB; ``--size 99968``: about 4.9
TiB) and the paper preset about 1,445.
"""
from __future__ import annotations

import math
import weakref

import torch

from svcore.errors import ConfigError

from .render import flash_render

#: the estimate over the traced peak of the live tensors: the peak resident memory of a whole prediction measured
#: 1.07-1.50 times it (module docstring); the rest covers what the trace does not run (the photo, the statistics
#: and files written per photo) and the allocator's run-to-run slack.
MARGIN = 2.0
GiB = float(1 << 30)


class LiveBytes:
    """Bytes of the tensors alive during a block, and their peak: each new tensor an op returns (not a view, not
    one of its inputs: in-place results) counts from its creation until Python frees it.

    Used as ``with LiveBytes() as live: ...; live.peak``.
    """

    def __init__(self):
        from torch.utils._python_dispatch import TorchDispatchMode
        from torch.utils._pytree import tree_flatten

        outer = self
        self.live = self.peak = 0

        class _Mode(TorchDispatchMode):
            def __torch_dispatch__(self, func, types, args=(), kwargs=None):
                out = func(*args, **(kwargs or {}))
                given = {id(t) for t in tree_flatten((args, kwargs))[0] if isinstance(t, torch.Tensor)}
                for t in tree_flatten(out)[0]:
                    if isinstance(t, torch.Tensor) and id(t) not in given and t._base is None:
                        outer._add(t.numel() * t.element_size())
                        weakref.finalize(t, outer._add, -t.numel() * t.element_size())
                return out

        self._mode = _Mode()

    def _add(self, n: int) -> None:
        self.live += n
        self.peak = max(self.peak, self.live)

    def __enter__(self) -> "LiveBytes":
        self._mode.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self._mode.__exit__(*exc)


@torch.no_grad()
def bytes_per_pixel(model: torch.nn.Module, stride: int) -> float:
    """Peak bytes of live tensors per input pixel of one photo through ``model`` and the re-rendering that
    ``svtrain predict`` writes (measured at side ``stride`` on the CPU, where the model is when loaded)."""
    image = torch.rand(1, 3, stride, stride, generator=torch.Generator().manual_seed(0))
    with LiveBytes() as live:
        maps = model(image)
        flash_render(maps, torch.tensor((0.6, 0.4)))  # where the light sits changes no tensor's size
        del maps
    return live.peak / stride ** 2


def need(per_pixel: float, size: int, batch: int) -> float:
    """Estimated peak bytes of predicting ``batch`` photos at ``size``² (with :data:`MARGIN`)."""
    return MARGIN * per_pixel * size * size * batch


def largest_size(per_pixel: float, mem: float, stride: int, batch: int) -> int:
    """The largest multiple of ``stride`` whose :func:`need` fits in ``mem`` bytes (0: not even ``stride``)."""
    return int(math.sqrt(mem / (MARGIN * per_pixel * batch)) // stride) * stride


def check(model: torch.nn.Module, stride: int, size: int, batch: int, device: torch.device) -> None:
    """Refuse a prediction whose estimated peak memory exceeds what the device has free.

    Args:
        model: the loaded network (on the CPU). stride: its stride (2^levels). size: the prediction side.
        batch: photos per network call. device: where it will run (CPU: the host's available memory, within a
            cgroup or address-space limit; CUDA: that GPU's free memory; others are not checked).

    Raises:
        ConfigError: one line with the estimate, the memory available and the largest size that fits.
    """
    from .runinfo import device_memory

    free = device_memory(device)
    if free is None:
        return
    mem, where = free
    per_pixel = bytes_per_pixel(model, stride)
    if need(per_pixel, size, batch) <= mem:
        return
    fits = largest_size(per_pixel, mem, stride, batch)
    photos = f" for a batch of {batch} photos" if batch > 1 else ""
    advice = f"use --size ≤ {fits}" if fits >= stride else f"even --size {stride} does not fit"
    raise ConfigError(f"--size {size} needs about {need(per_pixel, size, batch) / GiB:,.1f} GiB{photos} "
                      f"({MARGIN * per_pixel:.0f} bytes per pixel), {mem / GiB:.1f} GiB {where}; {advice}"
                      + (" or a smaller --batch" if batch > 1 else ""))
