"""U-Net with instance normalisation and the global-feature track of the paper (§4.1–4.2).

Every convolution is followed by instance normalisation whose subtracted means feed the global track
(concatenated with the previous global vector -> FC -> SELU), and the previous global vector is added
back to the normalised maps as a per-channel bias (FC) before the leaky ReLU. Dropout sits on the
coarsest decoder levels and, unlike the original code, is off at inference (``model.eval()``).

Strided 4×4 convolutions downsample (as in the paper); the stride-1 decoder convolutions are 3×3
because an even kernel at stride 1 shifts the output by half a pixel.
"""
from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from materials.capture import ROUGHNESS_MIN

from .config import ModelConfig

IN_EPS = 1e-5
LOG_EPS = 0.01
#: the material the untrained network predicts (output biases): grey diffuse, the usual dielectric F0, mid roughness.
INIT_DIFFUSE, INIT_SPECULAR, INIT_ROUGHNESS = 0.25, 0.04, 0.5


def _logit(p: float) -> float:
    return math.log(p / (1.0 - p))


def log_map(x: torch.Tensor) -> torch.Tensor:
    """DESIGN.md input mapping of a linear image: (log(x+0.01) - log 0.01) / (log 1.01 - log 0.01) ∈ [0, 1]."""
    x = x.clamp(0.0, 1.0)
    return (torch.log(x + LOG_EPS) - math.log(LOG_EPS)) / (math.log(1.0 + LOG_EPS) - math.log(LOG_EPS))


class GlobalConv(nn.Module):
    """conv -> instance norm -> + FC(global) bias; the norm's means update the global vector.

    Args:
        cin, cout: channels.
        k, stride, pad: convolution geometry.
        gdim: size of the incoming global vector.
        track: with the global track; False: conv -> instance norm -> per-channel scale and a plain learned bias
            (the ablation), ``g`` passes through as None.
    """

    def __init__(self, cin: int, cout: int, k: int, stride: int, pad: int, gdim: int, track: bool = True):
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, k, stride, pad, bias=False)
        self.scale = nn.Parameter(torch.ones(cout))
        self.track = track
        if track:
            self.to_bias = nn.Linear(gdim, cout)
            self.to_global = nn.Linear(gdim + cout, cout)
            nn.init.normal_(self.to_bias.weight, std=0.01)
            nn.init.zeros_(self.to_bias.bias)
        else:  # instance norm's usual affine shift, in place of the global bias
            self.shift = nn.Parameter(torch.zeros(cout))

    def forward(self, x: torch.Tensor, g: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """(B, cin, H, W), (B, gdim) or None -> (B, cout, H', W'), (B, cout) or None (without the track)."""
        # float32 statistics under autocast (train/device.py): a half-precision variance loses or overflows
        y = self.conv(x).float()
        mean = y.mean((2, 3))
        var = y.var((2, 3), unbiased=False)
        y = (y - mean[..., None, None]) * torch.rsqrt(var[..., None, None] + IN_EPS)
        if not self.track:
            return y * self.scale[:, None, None] + self.shift[:, None, None], None
        y = y * self.scale[:, None, None] + self.to_bias(g)[..., None, None]
        g_next = F.selu(self.to_global(torch.cat([g, mean], 1)))
        return y, g_next


class SVBRDFNet(nn.Module):
    """Linear flash photo (B, 3, H, W) -> packed maps (B, 10, H, W) (normal, diffuse, specular, roughness).

    H and W must be multiples of 2^levels.
    """

    def __init__(self, cfg: ModelConfig):
        super().__init__()
        self.cfg = cfg
        w = cfg.widths()
        self.levels = cfg.levels
        track = cfg.global_track
        cimg = 3  # the (log-mapped) photo, concatenated again at full resolution
        self.g0 = nn.Linear(3, w[0]) if track else None
        self.enc = nn.ModuleList()
        cin, gdim = cimg, w[0]
        for c in w:
            self.enc.append(GlobalConv(cin, c, 4, 2, 1, gdim, track))
            cin, gdim = c, c
        self.dec, self.drop, out_in, gdim = build_decoder(cfg, cin, gdim, cimg)
        # Output layer at full resolution: skip from the input image; no norm, global bias only.
        self.out_conv = nn.Conv2d(out_in, 9, 3, 1, 1)
        self.out_bias = nn.Linear(gdim, 9) if track else None
        if track:
            nn.init.normal_(self.out_bias.weight, std=0.01)
            nn.init.zeros_(self.out_bias.bias)
        # Start from a plausible material, not sigmoid(0) = 0.5 everywhere: an F0 of 0.5 (metal-like) under the
        # rendering loss's lights gives highlights ~10x too bright, and the fastest way down the loss is to shrink
        # the lobe to a mirror (roughness -> floor) rather than to lower F0; the net then stayed there (dvc store,
        # 700 steps: held-out roughness RMSE 0.64, specular 0.39, both far worse than the mean baselines).
        # Started near the data means, the same 450-step probe gave 0.27 / 0.07 (experiments/output_init/results/train_probes.json).
        with torch.no_grad():
            b = self.out_conv.bias
            b.zero_()
            b[2:5] = _logit(INIT_DIFFUSE)  # after the normal's two channels
            b[5] = _logit((INIT_ROUGHNESS - ROUGHNESS_MIN) / (1.0 - ROUGHNESS_MIN))
            b[6:9] = _logit(INIT_SPECULAR)
            if cfg.zero_output:
                self.out_conv.weight.zero_()

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """(B, 3, H, W) photos linear in [0, 1] -> (B, 10, H, W) packed maps."""
        x0 = log_map(image)
        g = F.selu(self.g0(x0.mean((2, 3)))) if self.g0 is not None else None
        skips = []
        x = x0
        for layer in self.enc:
            x, g = layer(x, g)
            x = F.leaky_relu(x, 0.2)
            skips.append(x)
        x, g_dec = decode(self.dec, self.drop, skips, g, x0)
        o = self.out_conv(x)
        if self.out_bias is not None:
            o = o + self.out_bias(g_dec)[..., None, None]
        return outputs_to_maps(o)


def build_decoder(cfg: ModelConfig, cin: int, gdim: int, cimg: int) -> tuple[nn.ModuleList, nn.ModuleList, int, int]:
    """The decoder's layers: per level (coarse to fine) its convolutions and dropout.

    Args:
        cin: channels of the coarsest encoder level. gdim: size of the global vector it receives.
        cimg: channels of the network's input as concatenated again at full resolution (the photo's 3).

    Returns:
        (decoder levels, their dropouts, channels the output layer receives (the finest level's and the input's),
        size of the global vector the output layer receives).
    """
    w = cfg.widths()
    track = cfg.global_track
    dec, drop = nn.ModuleList(), nn.ModuleList()
    for n, i in enumerate(range(cfg.levels - 2, -1, -1)):
        convs = nn.ModuleList()
        c_in = cin + w[i]
        for _ in range(cfg.decoder_convs):
            convs.append(GlobalConv(c_in, w[i], 3, 1, 1, gdim, track))
            c_in, gdim = w[i], w[i]
        dec.append(convs)
        drop.append(nn.Dropout(cfg.dropout) if n < cfg.dropout_levels and cfg.dropout > 0 else nn.Identity())
        cin = w[i]
    return dec, drop, cin + cimg, gdim


def decode(dec: nn.ModuleList, drop: nn.ModuleList, skips: list[torch.Tensor], g: torch.Tensor | None,
           x0: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Run the layers of :func:`build_decoder` from the coarsest encoder level up to full resolution.

    Args:
        skips: the encoder's outputs, finest first (the last is the coarsest, where decoding starts).
        g: (B, gdim) the global vector at the coarsest level, or None without the global track.
        x0: (B, cimg, H, W) the network's (log-mapped) input, concatenated again at full resolution.

    Returns:
        (B, C, H, W) the features the output layer sees, and the global vector after the last layer.
    """
    x = skips[-1]
    for convs, dp, skip in zip(dec, drop, reversed(skips[:-1])):
        x = torch.cat([F.interpolate(x, scale_factor=2.0, mode="nearest"), skip], 1)
        for conv in convs:
            x, g = conv(x, g)
            x = F.leaky_relu(x, 0.2)
        x = dp(x)
    x = torch.cat([F.interpolate(x, scale_factor=2.0, mode="nearest"), x0], 1)
    return x, g


def outputs_to_maps(o: torch.Tensor) -> torch.Tensor:
    """Raw 9-channel outputs -> packed maps.

    Args:
        o: (B, 9, H, W): normal xy (tanh -> x, y of the unit normal), diffuse (3), roughness (1), specular (3).

    Returns:
        (B, 10, H, W): unit normal with reconstructed z > 0, diffuse, specular in [0, 1], roughness in
        [ROUGHNESS_MIN, 1].
    """
    xy = torch.tanh(o[:, 0:2])
    # z from the unit-length constraint; the floor keeps sqrt's gradient finite when |xy| -> 1,
    # and the normalisation brings |xy| > 1 back onto the sphere.
    z = torch.sqrt((1.0 - (xy * xy).sum(1, keepdim=True)).clamp(min=1e-4))
    n = torch.cat([xy, z], 1)
    n = n * torch.rsqrt((n * n).sum(1, keepdim=True))
    return _maps(n, o)


def _maps(n: torch.Tensor, o: torch.Tensor) -> torch.Tensor:
    """(B, 3, H, W) unit normals and the raw outputs (B, 9, H, W) -> (B, 10, H, W) packed maps."""
    diffuse = torch.sigmoid(o[:, 2:5])
    # roughness in [ROUGHNESS_MIN, 1], the renderer's domain: below the floor its clamp has zero gradient, and the
    # dvc model had 55 % of its held-out pixels there (a dead zone the loss could never pull them out of).
    rough = ROUGHNESS_MIN + (1.0 - ROUGHNESS_MIN) * torch.sigmoid(o[:, 5:6])
    spec = torch.sigmoid(o[:, 6:9])
    return torch.cat([n, diffuse, spec, rough], 1)


def count_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
