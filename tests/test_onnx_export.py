"""``svtrain export-model RUN --format onnx OUT.onnx``: onnxruntime runs the exported model on a photo at two sizes
(dynamic axes) and matches torch; the metadata says how to call it; other versions are converted or refused in one
line; bad input is one line and exit 2."""
from __future__ import annotations

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch
from PIL import Image

from train import checkpoint
from train.export import OPSET, OUTPUTS, DecodedMaps, load_for_export
from train.predict import read_photo, to_network_input

from test_train_cli import run  # noqa: E402  (one svtrain-in-process helper)
from test_train_predict import SMALL  # a 3-level network (stride 8), 32² crops

#: float32 agreement of onnxruntime and torch on maps in [0, 1]. The two runtimes sum the instance norms' means and
#: variances over H x W pixels in different orders and fuse the convolutions differently; float32 rounding (eps
#: 1.2e-7) of sums over ~1e5 values, renormalised at every level, gives differences of order 1e-6 to 1e-5. 1e-4 is
#: 40x below one step of the 8-bit maps predict writes (1/255), so no written map can tell the two apart, and far
#: above what the runtimes' reordering gives. 2e-4 since #39: with the compact preset's new loss the tiny model's
#: decoded normal (x, y divided by the vector's norm) amplified that to 1.1e-4 in 1 of 215,040 values; still 20x
#: below one 8-bit step.
ATOL = 2e-4


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A tiny trained model whose output layer is not zero (the maps vary per pixel)."""
    d = tmp_path_factory.mktemp("run")
    code, _, err = run("fit", "--out", d, "--iterations", 2, *SMALL, "--set", "model.zero_output=false")
    assert code == 0, err
    return d


@pytest.fixture(scope="module")
def exported(run_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("onnx") / "model.onnx"
    code, stdout, err = run("export-model", run_dir, "--format", "onnx", out)
    assert code == 0, err
    assert stdout.strip() == str(out)
    return out


def flash_photo(h: int, w: int) -> np.ndarray:
    """An sRGB photo (uint8) of a textured surface under a centred flash: a falloff lobe over noise."""
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:h, 0:w]
    lobe = 1.0 / (1.0 + ((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (0.1 * h * w))
    tex = rng.uniform(0.3, 1.0, (h, w, 3))
    return (255 * np.clip(lobe[..., None] * tex, 0, 1) ** (1 / 2.2)).astype(np.uint8)


def assert_onnx_matches_torch(run_dir, exported, tmp_path):
    """onnxruntime and torch agree on a photo at two sizes (a square and a wide batch of 2), maps decoded."""
    path = tmp_path / "photo.jpg"
    Image.fromarray(flash_photo(480, 640)).save(path, quality=95)
    img = read_photo(path)  # the svgen path: sRGB-decoded, linear in [0, 1]
    net, _, note = load_for_export(run_dir)
    assert note == ""  # trained by this very code
    wrapped = DecodedMaps(net)
    sess = ort.InferenceSession(str(exported), providers=["CPUExecutionProvider"])
    assert [i.name for i in sess.get_inputs()] == ["image"]
    assert [o.name for o in sess.get_outputs()] == list(OUTPUTS)
    square = to_network_input(img, 256)  # what svtrain predict feeds the network
    whole = torch.from_numpy(img).permute(2, 0, 1)[None]
    wide = torch.nn.functional.interpolate(whole, size=(160, 224), mode="area")  # not square, and a batch of 2
    wide = torch.cat([wide, wide.flip(-1)])
    for x in (square, wide):
        got = sess.run(None, {"image": x.numpy()})
        with torch.no_grad():
            want = [t.numpy() for t in wrapped(x)]
        for name, g, w in zip(OUTPUTS, got, want):
            assert g.shape == w.shape == (x.shape[0], 1 if name == "roughness" else 3, *x.shape[2:])
            np.testing.assert_allclose(g, w, atol=ATOL, rtol=0, err_msg=name)
        n = got[0]
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)  # decoded: unit normals
        assert (n[:, 2] > 0).all() and all(0 <= o.min() and o.max() <= 1 for o in got[1:])


def test_onnxruntime_matches_torch_on_a_photo_at_two_sizes(run_dir, exported, tmp_path):
    assert_onnx_matches_torch(run_dir, exported, tmp_path)


def test_onnxruntime_gives_the_maps_svtrain_predict_writes(run_dir, exported, tmp_path):
    """The exported model's decoded maps are those `svtrain predict` writes for the same photo (its linear EXRs,
    decoded by the network and predict, not by the export's DecodedMaps): each map in its meaning and units."""
    from svcore.image_io import read_exr

    path = tmp_path / "photo.jpg"
    Image.fromarray(flash_photo(480, 640)).save(path, quality=95)
    code, _, err = run("predict", path, "--checkpoint", run_dir, "--out", tmp_path / "maps", "--size", 256)
    assert code == 0, err
    sess = ort.InferenceSession(str(exported), providers=["CPUExecutionProvider"])
    got = dict(zip(OUTPUTS, sess.run(None, {"image": to_network_input(read_photo(path), 256).numpy()})))
    for name in OUTPUTS:
        written = read_exr(tmp_path / "maps" / f"{name}.exr")  # (256, 256, 3): roughness in all three channels
        onnx_map = got[name][0].transpose(1, 2, 0)
        np.testing.assert_allclose(np.broadcast_to(onnx_map, written.shape), written, atol=ATOL, rtol=0,
                                   err_msg=name)


def test_the_model_records_how_to_call_it(exported, run_dir):
    m = onnx.load(str(exported))
    assert any(o.domain in ("", "ai.onnx") and o.version == OPSET for o in m.opset_import)
    meta = {p.key: p.value for p in m.metadata_props}
    assert meta["opset"] == str(OPSET)
    assert "linear RGB in [0, 1]" in meta["input"] and meta["stride"] == "8"
    assert meta["checkpoint_sha256"] and meta["svgen_version_trained"] == meta["svgen_version_exported"]
    code, out, _ = run("export-model", "--help")
    assert code == 0 and f"opset {OPSET}" in out  # the help states the opset the code exports


def test_another_svgen_version_is_converted_or_refused_in_one_line(run_dir, tmp_path):
    state = checkpoint.load(run_dir / "model.pt")
    state["provenance"]["versions"]["svgen"] = "v0.0.1-other"
    checkpoint.save(tmp_path / "old.pt", {k: v for k, v in state.items() if k != "format"})
    code, stdout, err = run("export-model", tmp_path / "old.pt", tmp_path / "old.onnx")
    assert code == 0, err
    note = [line for line in err.splitlines() if "v0.0.1-other" in line]
    assert len(note) == 1 and "converted" in note[0], err
    meta = {p.key: p.value for p in onnx.load(str(tmp_path / "old.onnx")).metadata_props}
    assert meta["svgen_version_trained"] == "v0.0.1-other"

    state["network_format"] = checkpoint.NETWORK_FORMAT + 1  # weights that mean something else
    torch.save(state, tmp_path / "future.pt")
    code, _, err = run("export-model", tmp_path / "future.pt", tmp_path / "future.onnx")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "network format" in err, err
    assert not (tmp_path / "future.onnx").exists()

    state["network_format"] = checkpoint.NETWORK_FORMAT
    state["model"] = {k: v for k, v in state["model"].items() if not k.startswith("out_conv")}  # another layout
    torch.save(state, tmp_path / "layout.pt")
    code, _, err = run("export-model", tmp_path / "layout.pt", tmp_path / "layout.onnx")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "do not fit" in err, err


@pytest.mark.parametrize("case", ["not_a_run", "size", "out_is_folder", "format"])
def test_bad_input_is_one_line_and_exit_2(run_dir, tmp_path, case):
    args = {"not_a_run": [tmp_path, tmp_path / "m.onnx"],
            "size": [run_dir, tmp_path / "m.onnx", "--size", 100],
            "out_is_folder": [run_dir, tmp_path],
            "format": [run_dir, tmp_path / "m.onnx", "--format", "tflite"]}[case]
    code, _, err = run("export-model", *args)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not (tmp_path / "m.onnx").exists()


def test_the_readme_snippet_runs_the_exported_model(exported, tmp_path):
    """docs/MODEL.md's few lines of onnxruntime (no svgen import) run as written on a photo."""
    import re
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "docs" / "MODEL.md").read_text()
    code = re.search(r"\*\*ONNX\*\*.*?```python\n(.*?)```", readme, re.S).group(1)
    assert "import train" not in code and "svgen" not in code.replace('"svgen.onnx"', "")
    shutil.copy(exported, tmp_path / "svgen.onnx")
    Image.fromarray(flash_photo(300, 400)).save(tmp_path / "photo.jpg")
    check = "\nprint(normal.shape, diffuse.shape, roughness.shape, specular.shape, normal.dtype)\n"
    r = subprocess.run([sys.executable, "-c", code + check], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["(1,", "3,", "256,", "256)", "(1,", "3,", "256,", "256)", "(1,", "1,", "256,", "256)",
                                "(1,", "3,", "256,", "256)", "float32"], r.stdout
