"""`svgen render --variant` (issue #44): llvm_ad_rgb by default and left out of the recorded config (the bytes and
config hash of a default store as before the key), cuda_ad_rgb refused in one line where there is no CUDA, the
variant named in the store, and one variant per process."""
from __future__ import annotations

import typing

import drjit as dr
import pytest
import zarr

from conftest import tree_digest
from svcore import mi_env
from pipeline.config import MitsubaVariant, RenderConfig, SampleConfig
from pipeline.render.stage import render_stage, run_render
from pipeline.sample import run_sample
from svcore.config import build

NO_CUDA = not dr.has_backend(dr.JitBackend.CUDA)


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """2 variants of one preset at 64^2."""
    out = tmp_path_factory.mktemp("variant_in") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=("paint/glossy_red",), per_preset=2), workers=0)
    return out


def test_the_config_offers_the_variants_mi_env_loads():
    assert typing.get_args(MitsubaVariant) == mi_env.VARIANTS
    assert RenderConfig().variant == mi_env.DEFAULT_VARIANT == "llvm_ad_rgb"


def test_the_default_renders_in_llvm_names_it_and_keeps_the_config_of_before(variants, tmp_path, svgen_cli):
    """The default store names llvm_ad_rgb in its scene attributes, but its recorded config (and so its config hash)
    has no variant key: a store rendered before the key existed is the same store. ``--variant llvm_ad_rgb`` spelled
    out gives the same arrays, config and hash."""
    default = tmp_path / "default.zarr"
    run_render(variants, default, build(RenderConfig, "tiny", chunk=1), workers=0)
    a = dict(zarr.open_group(default, mode="r").attrs)
    assert a["scene"]["mitsuba_variant"] == "llvm_ad_rgb"
    assert "variant" not in a["config"]
    spelled = tmp_path / "spelled.zarr"
    code, err = svgen_cli("render", variants, spelled, "--config-preset", "tiny", "--chunk", "1", "--variant",
                          "llvm_ad_rgb", "--workers", "0")
    assert code == 0, err
    b = dict(zarr.open_group(spelled, mode="r").attrs)
    assert b["config"] == a["config"] and b["svgen"]["config_hash"] == a["svgen"]["config_hash"]
    def chunks(store):  # every file but the metadata and the card (which name the command line)
        return {k: v for k, v in tree_digest(store).items() if not k.endswith((".json", ".md"))}

    assert chunks(default) == chunks(spelled) and len(chunks(default)) > 10


def test_another_variant_is_part_of_the_recorded_config():
    """A cuda_ad_rgb store is another config (its own hash): CUDA need not match LLVM bit for bit."""
    assert "variant" in build(RenderConfig, "tiny").dropped_keys()
    assert "variant" not in build(RenderConfig, "tiny", variant="cuda_ad_rgb").dropped_keys()


@pytest.mark.skipif(not NO_CUDA, reason="this machine has CUDA: cuda_ad_rgb renders here")
def test_cuda_without_a_gpu_is_refused_in_one_line(variants, tmp_path, svgen_cli):
    code, msg = svgen_cli("render", variants, tmp_path / "o.zarr", "--config-preset", "tiny", "--variant",
                          "cuda_ad_rgb", "--workers", "0")
    assert code != 0
    assert "'cuda_ad_rgb' needs an NVIDIA GPU" in msg and "no CUDA driver" in msg, msg
    assert len(msg.strip().splitlines()) == 1 and "Traceback" not in msg, msg
    assert not (tmp_path / "o.zarr").exists()


@pytest.mark.skipif(not NO_CUDA, reason="this machine has CUDA")
def test_the_stage_refuses_before_opening_anything(tmp_path):
    with pytest.raises(mi_env.MitsubaUnavailable, match="cuda_ad_rgb"):
        render_stage([tmp_path / "missing.zarr"], build(RenderConfig, "tiny", variant="cuda_ad_rgb"))


def test_a_process_renders_in_one_variant():
    """The svgen BSDF is a class of the variant it was loaded in: asking this (llvm) process for another variant is
    refused, naming both, and leaves its variant as it was."""
    from pipeline.render import bsdf

    assert bsdf.VARIANT == "llvm_ad_rgb"
    with pytest.raises(mi_env.MitsubaUnavailable, match="already renders in 'llvm_ad_rgb'.*'llvm_ad_mono'"):
        mi_env.use_variant("llvm_ad_mono")
    assert bsdf.mi.variant() == "llvm_ad_rgb"
