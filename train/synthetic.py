"""An in-memory stand-in for the renders store: procedural maps rendered by the torch flash renderer.

Same interface as the renders store reader (``__len__``, ``image(i)``, ``maps(i)``, ``source(i)``),
so training, evaluation and the benchmarks run before (and without) a Mitsuba-rendered store.
Two map generators: ``"presets"`` (the materials package's base materials at their defaults, one
seed per sample) and ``"simple"`` (smooth random fields, a few ms per sample, no other package).
Everything is a pure function of (seed, index).
"""
from __future__ import annotations

import math

import numpy as np
import torch
from torch.nn import functional as F

from materials.capture import LIGHT_R_MAX, LIGHT_R_MIN
from materials.maps import SVBRDF, pack_maps, unpack_maps
from svcore.seeds import stream_rng

from .render import flash_render

def _field(rng: np.random.Generator, size: int, cells: int, ch: int) -> np.ndarray:
    """Smooth random field (ch, size, size) in about [-1, 1]: bicubic upsampling of a coarse grid."""
    g = torch.from_numpy(rng.standard_normal((1, ch, cells, cells)).astype(np.float32))
    return F.interpolate(g, size=(size, size), mode="bicubic", align_corners=False)[0].numpy()


def simple_maps(material: int, sample: int, size: int, seed: int) -> SVBRDF:
    """A cheap procedural SVBRDF: the material fixes the look, the sample varies the fields."""
    mrng = stream_rng(seed, "synthetic.material", material)
    base = mrng.uniform(0.05, 0.8, 3)
    metal = mrng.random() < 0.25
    spec0 = mrng.uniform(0.5, 1.0, 3) if metal else np.full(3, mrng.uniform(0.02, 0.08))
    r0, r_var = mrng.uniform(0.15, 0.85), mrng.uniform(0.0, 0.25)
    bump, cells = mrng.uniform(0.0, 3.0), int(mrng.integers(3, 24))
    rng = stream_rng(seed, "synthetic.sample", material, sample)
    f = _field(rng, size, cells, 5)
    diffuse = np.clip(base[:, None, None] * (1.0 + 0.4 * f[0:3]), 0.0, 1.0) * (0.1 if metal else 1.0)
    rough = np.clip(r0 + r_var * f[3:4], 0.05, 1.0)
    h = f[4] * bump / cells
    # Height gradient per plane unit (plane is 2 wide): x right = columns, y up = minus rows.
    dhdx = np.gradient(h, axis=1) * size / 2.0
    dhdy = -np.gradient(h, axis=0) * size / 2.0
    n = np.stack([-dhdx, -dhdy, np.ones_like(h)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    spec = np.broadcast_to(spec0, (size, size, 3))
    return SVBRDF(normal=n.astype(np.float32), diffuse=diffuse.transpose(1, 2, 0).astype(np.float32),
                  specular=np.ascontiguousarray(spec, np.float32), roughness=rough.transpose(1, 2, 0).astype(np.float32))


class SyntheticSource:
    """Rendered training pairs held in memory.

    Args:
        n: number of samples.
        size: image side.
        n_materials: distinct materials ("simple") or presets used round-robin ("presets"); the unit
            of the held-out split.
        seed: master seed.
        kind: "simple" or "presets".
    """

    def __init__(self, n: int, size: int = 144, n_materials: int = 16, seed: int = 0, kind: str = "simple"):
        if kind not in ("simple", "presets"):
            raise ValueError(f"unknown synthetic kind {kind!r}")
        self.n, self.size, self.seed, self.kind = int(n), int(size), int(seed), kind
        if kind == "presets":
            import materials

            names = [p.name for p in materials.presets()]
            step = max(1, len(names) // n_materials)
            self._presets = [materials.get_preset(nm) for nm in names[::step][:n_materials]]
            self.n_materials = len(self._presets)
        else:
            self.n_materials = int(n_materials)
        self._maps = np.empty((self.n, self.size, self.size, 10), np.float32)
        self._images = np.empty((self.n, self.size, self.size, 3), np.float32)
        self.light = np.empty((self.n, 2), np.float32)
        self._build()

    def _material(self, i: int) -> int:
        return i % self.n_materials

    def _build(self, chunk: int = 16) -> None:
        for lo in range(0, self.n, chunk):
            idx = range(lo, min(lo + chunk, self.n))
            for i in idx:
                m = self._material(i)
                if self.kind == "presets":
                    svb = self._presets[m].generate(None, self.size, stream_rng(self.seed, "synthetic.preset_maps", i).integers(2**31))
                else:
                    svb = simple_maps(m, i, self.size, self.seed)
                self._maps[i] = pack_maps(svb)
                rng = stream_rng(self.seed, "synthetic.light", i)
                rho = math.sqrt(rng.uniform(LIGHT_R_MIN ** 2, LIGHT_R_MAX ** 2))
                phi = rng.uniform(0.0, 2.0 * math.pi)
                self.light[i] = (rho * math.cos(phi), rho * math.sin(phi))
            sl = slice(lo, idx[-1] + 1)
            with torch.no_grad():
                t = torch.from_numpy(self._maps[sl]).permute(0, 3, 1, 2)
                img = flash_render(t, torch.from_numpy(self.light[sl]))
            self._images[sl] = img.permute(0, 2, 3, 1).numpy()

    def __len__(self) -> int:
        return self.n

    def image(self, i: int) -> np.ndarray:
        """(H, W, 3) float32 linear image in [0, 1]."""
        return self._images[i]

    def maps(self, i: int) -> SVBRDF:
        """The aligned maps of sample i."""
        return unpack_maps(self._maps[i])

    def packed(self, i: int) -> np.ndarray:
        """(H, W, 10) packed maps (fast path used by the dataset)."""
        return self._maps[i]

    def source(self, i: int) -> dict:
        """Source ids of sample i: {"presets": [name]}."""
        m = self._material(i)
        name = self._presets[m].name if self.kind == "presets" else f"synthetic/{m:03d}"
        return {"presets": [name]}
