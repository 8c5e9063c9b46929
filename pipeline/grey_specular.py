"""Grey dielectric specular (#39, round 9): one grey, constant F0 for a variant's dielectric pixels.

The presets give some dielectrics a specular that varies with their colour (brick against mortar, glaze against
grout, wet and dry ground) and painted or rusted metal sheet a dielectric layer whose F0 follows the paint. Real
libraries' dielectrics have one grey F0 per material (materials-cc0's CV of specular luminance within a material
is 0.01, the default library's 0.07: benchmarks/results/realism.json). :class:`GreySpecular` makes a share of the
variants so: a network trained on them never sees specular texture that follows albedo texture on a dielectric.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import materials
from svcore.seeds import derive_seed

from .config import SampleConfig

#: specular luminance below which a pixel is dielectric: common dielectrics' F0 is 0.02-0.08, metals' 0.5 and
#: above (physicallybased.info); the library's dielectric pixels reach 0.085 (paint's 95th percentile)
DIELECTRIC_MAX = 0.1
#: Rec. 709 luminance weights of linear RGB
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float64)
#: the variant stream key of the grey draw: no index of the sample stream (nor Relief's 1 << 20 | 1..5) reaches it
STREAM = (1 << 20) | 6


@dataclass(frozen=True)
class GreySpecular:
    """``SampleConfig.grey_specular``: the share of presets' variants whose dielectric pixels get one grey F0.

    Attributes:
        share: probability that a variant is made grey (its own uniform draw, stream :data:`STREAM`).
    """

    share: float = 0.0

    @classmethod
    def of(cls, cfg: SampleConfig) -> "GreySpecular":
        return cls(cfg.grey_specular)

    def chosen(self, seed: int) -> bool:
        """Whether the variant of seed ``seed`` is made grey: one uniform draw of its own stream, so the rest of
        the variant (maps, relief mode, grain) is what it is without the option."""
        if self.share <= 0:
            return False
        return bool(np.random.default_rng(derive_seed(seed, "sample", STREAM)).random() < self.share)

    def apply(self, m: materials.SVBRDF, seed: int, modes: bool = True) -> materials.SVBRDF:
        """``m`` with its dielectric specular grey and constant when the variant is chosen; an imported material's
        variant (``modes`` False: measured maps) and a variant with no dielectric pixel unchanged.

        Args:
            m: the variant's maps; ``m.specular`` is (H, W, 3) linear F0.
            seed: the variant's derived seed.
            modes: False for an imported material's variant.
        """
        if not modes or not self.chosen(seed):
            return m
        y = m.specular.astype(np.float64) @ LUMA
        dielectric = y < DIELECTRIC_MAX
        if not dielectric.any():
            return m
        spec = m.specular.copy()
        spec[dielectric] = np.float32(y[dielectric].mean())
        return materials.SVBRDF(m.normal, m.diffuse, spec, m.roughness)
