"""``svtrain export-model RUN --format onnx OUT.onnx``: the trained network as an ONNX model for use outside svgen.

What the ONNX model computes (:class:`DecodedMaps`):

- input ``image``: (B, 3, H, W) float32, **linear** RGB in [0, 1] (a PNG/JPEG photo must be sRGB-decoded first;
  values outside [0, 1] are clamped), H and W multiples of the network's stride 2^levels (128 for the compact
  preset); the log mapping the network applies to it (train/net.py ``log_map``) is inside the model;
- outputs, decoded (B, C, H, W) float32 maps: ``normal`` (3: unit xyz, z > 0, OpenGL convention of DESIGN.md),
  ``diffuse`` (3: linear albedo in [0, 1]), ``roughness`` (1: perceptual roughness in [ROUGHNESS_MIN, 1],
  alpha = r²), ``specular`` (3: linear F0 in [0, 1]).

The batch size and the image size are dynamic axes. The exporter is torch's TorchScript-based one
(``torch.onnx.export(dynamo=False)``, opset :data:`OPSET`): with torch pinned (pyproject) it traces this network in
seconds on a CPU, where the dynamo-based exporter took minutes (the model's graph is plain convolutions, norms and
element-wise ops, which both export identically). The model's metadata records the opset, the input space, the
stride, the outputs, the source checkpoint's SHA-256, config and svgen version, and the exporting svgen version.

A checkpoint trained with another svgen version is exported when its network format
(:data:`train.checkpoint.NETWORK_FORMAT`) is this version's and its weights load into this version's network
unchanged (said in one line, both versions recorded); otherwise it is refused in one line.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import torch
from torch import nn

from svcore.errors import ConfigError, SvgenError
from svcore.log import get_logger
from svcore.versions import svgen_version

from . import bundled_model, checkpoint
from .brdf import DIFFUSE, NORMAL, ROUGHNESS, SPECULAR
from .config import from_dict
from .net import SVBRDFNet
from .runinfo import run_versions

log = get_logger(__name__)

#: the ONNX opset the export targets (onnxruntime >= 1.14 runs it).
OPSET = 17
FORMATS = ("onnx",)
INPUT = "image"
OUTPUTS = ("normal", "diffuse", "roughness", "specular")
#: the image side traced (any multiple of the stride works afterwards: the axes are dynamic).
TRACE_SIZE = 256


class DecodedMaps(nn.Module):
    """The network with its packed output split into the four maps (what the ONNX model computes).

    Args:
        net: a trained :class:`SVBRDFNet` (eval mode).
    """

    def __init__(self, net: SVBRDFNet):
        super().__init__()
        self.net = net

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """(B, 3, H, W) linear RGB in [0, 1] -> normal (B, 3, H, W), diffuse (B, 3), roughness (B, 1), specular
        (B, 3), each (B, C, H, W)."""
        maps = self.net(image)
        return maps[:, NORMAL], maps[:, DIFFUSE], maps[:, ROUGHNESS], maps[:, SPECULAR]


def load_for_export(ckpt: str | Path) -> tuple[SVBRDFNet, dict, str]:
    """The network of a checkpoint, checked to be exportable by this svgen version.

    Returns:
        (network in eval mode, the checkpoint state, a one-line note when it was trained by another svgen version,
        else "").

    Raises:
        SvgenError: not a checkpoint or run; another network format; weights that do not fit this version's network.
    """
    path = Path(bundled_model.resolve(ckpt))
    state = checkpoint.load(path)
    here = run_versions()["svgen"]  # as a run records its code: the digest of the training code
    theirs = str(state.get("provenance", {}).get("versions", {}).get("svgen", "unknown"))
    fmt = int(state.get("network_format", 1))
    if fmt != checkpoint.NETWORK_FORMAT:
        raise SvgenError(f"{ckpt} was trained with svgen {theirs} (network format {fmt}); this svgen {here} exports "
                         f"format {checkpoint.NETWORK_FORMAT}: refused, export it with the svgen that trained it")
    try:
        cfg = from_dict(state["config"])
        net = SVBRDFNet(cfg.model)
        net.load_state_dict(state["model"])
    except (SvgenError, KeyError, TypeError, RuntimeError) as e:
        raise SvgenError(f"{ckpt} was trained with svgen {theirs}: its config or weights do not fit this svgen "
                         f"{here}'s network ({str(e).splitlines()[0][:160]}); refused, export it with the svgen "
                         "that trained it") from None
    net.eval()
    note = "" if theirs == here else (
        f"{ckpt} was trained with svgen {theirs}, exported with svgen {here}: same network format "
        f"({fmt}) and its weights load unchanged, so it is converted as is (both versions are in the model's "
        "metadata)")
    return net, state, note


def metadata(state: dict, source: Path, stride: int) -> dict[str, str]:
    """The ONNX model's metadata_props: how to call it and where it came from."""
    versions = state.get("provenance", {}).get("versions", {})
    return {
        "producer": "svgen svtrain export-model",
        "opset": str(OPSET),
        "input": f"{INPUT}: (B, 3, H, W) float32 linear RGB in [0, 1] (sRGB-decode PNG/JPEG first); H, W multiples "
                 f"of {stride}",
        "outputs": "normal (B,3,H,W) unit xyz z>0; diffuse (B,3,H,W) linear [0,1]; roughness (B,1,H,W) perceptual "
                   "(alpha = r^2); specular (B,3,H,W) linear F0 [0,1]",
        "stride": str(stride),
        "svgen_version_trained": str(versions.get("svgen", "unknown")),
        # both as a run records its code (the training code's digest: equal when this code trained it), and the
        # exporting install's package version
        "svgen_version_exported": run_versions()["svgen"], "svgen_package_exported": svgen_version(),
        "network_format": str(state.get("network_format", 1)),
        "checkpoint_sha256": bundled_model.sha256(source),
        "checkpoint_step": str(state.get("step", "")),
        "config": json.dumps(state["config"], sort_keys=True),
    }


def export_onnx(ckpt: str | Path, out: str | Path, trace_size: int = TRACE_SIZE) -> tuple[Path, str]:
    """Export a checkpoint (file, run directory or ``"bundled"``) to ``out`` as ONNX.

    Args:
        trace_size: the square side traced; a multiple of the stride (the exported axes stay dynamic).

    Returns:
        (the written file, the one-line note of :func:`load_for_export`).

    Raises:
        ConfigError: a trace size that is not a multiple of the stride, or an output that is a folder.
        SvgenError: see :func:`load_for_export`.
    """
    import onnx

    net, state, note = load_for_export(ckpt)
    stride = 2 ** net.levels
    if trace_size < stride or trace_size % stride:
        raise ConfigError(f"--size {trace_size} is not a positive multiple of the network's stride {stride} "
                          f"(2^levels)")
    out = Path(out)
    if out.is_dir():
        raise ConfigError(f"{out} is a folder: give the .onnx file to write")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    example = torch.rand(1, 3, trace_size, trace_size, generator=torch.Generator().manual_seed(0))
    axes = {INPUT: {0: "batch", 2: "height", 3: "width"}, **{o: {0: "batch", 2: "height", 3: "width"}
                                                              for o in OUTPUTS}}
    with warnings.catch_warnings():  # the TorchScript exporter announces its deprecation on every call
        warnings.simplefilter("ignore")
        torch.onnx.export(DecodedMaps(net), (example,), str(tmp), dynamo=False, opset_version=OPSET,
                          input_names=[INPUT], output_names=list(OUTPUTS), dynamic_axes=axes)
    model = onnx.load(str(tmp))
    source = Path(bundled_model.resolve(ckpt))
    if source.is_dir():
        source = next(source / n for n in ("model.pt", "checkpoint.pt") if (source / n).is_file())
    for k, v in metadata(state, source, stride).items():
        model.metadata_props.add(key=k, value=v)
    model.doc_string = "svgen SVBRDF capture network: linear flash photo -> normal, diffuse, roughness, specular"
    onnx.checker.check_model(model)
    onnx.save(model, str(tmp))
    tmp.replace(out)
    return out, note
