"""``svtrain export-model``: a run's network as ONNX for use outside svgen (:mod:`train.export`)."""
from __future__ import annotations

import click


@click.command("export-model")
@click.argument("run")
@click.option("--format", "fmt", type=click.Choice(["onnx"]), default="onnx", show_default=True,
              help="Model format: onnx (torch.onnx, opset 17).")
@click.argument("out", type=click.Path())
@click.option("--size", type=int, default=256, show_default=True,
              help="Square side traced for the export (a multiple of the stride 2^levels); the exported image size "
                   "stays dynamic.")
def export_model(run, fmt, out, size):
    """Export RUN (a run directory, checkpoint file or 'bundled') to OUT for use outside svgen.

    ONNX, opset 17. Input 'image': (B, 3, H, W) float32 linear RGB in [0, 1] (sRGB-decode PNG/JPEG first), H and W
    multiples of the stride 2^levels (128 for the compact preset); batch and size are dynamic. Outputs, decoded:
    'normal' (B,3,H,W) unit xyz, 'diffuse' (B,3,H,W) linear, 'roughness' (B,1,H,W) perceptual, 'specular'
    (B,3,H,W) linear F0. A checkpoint of another svgen version is exported only when its weights load unchanged.
    """
    from ..export import export_onnx

    path, note = export_onnx(run, out, size)
    if note:
        click.echo(note, err=True)
    click.echo(str(path))
