"""`svgen import`: material libraries (folders of map files, MatSynth, ambientCG ...) and the 2018 strips into
svgen's variants and renders stores. One module per job:

* :mod:`.aliases`   file name -> map role (case-insensitive aliases, resolution suffixes, separators)
* :mod:`.discover`  material folders under the sources, the file chosen per role, sidecar metadata, symlink loops
* :mod:`.readers`   image files -> float arrays (Pillow, pypng for 16-bit colour PNG, tifffile, OpenEXR)
* :mod:`.convert`   colour (sRGB -> linear) and workflow (metallic/roughness, specular/glossiness) -> SVBRDF
* :mod:`.normals`   normal conventions, 2-channel normals, height -> normals
* :mod:`.resample`  centre square crop, area average to the output size (tileable)
* :mod:`.strips`    the 2018 dataset's 5-tile strips
* :mod:`.job`       planning, dask chunk tasks, the variants/renders store glue
* :mod:`.perturb`   the generic parameter table that `svgen sample --from` applies to imported materials
"""
from __future__ import annotations

from svcore.errors import SvgenError


class ImportInputError(SvgenError):
    """A source folder, file or strip that cannot be imported (printed as one line, exit 2)."""
