"""svgen's data pipeline: materials -> variants, blends and renders stores (zarr v3), the ``svgen`` CLI."""
