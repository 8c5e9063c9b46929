"""The paper-scale recipe of docs/TRAINING.md (`dvc exp run -S ...`, the README links it) stays valid: applied to
params.yaml the way DVC applies `-S key=value` (the value parsed as YAML), every stage config resolves and the scale
is the paper's."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import yaml

from materials.registry import presets
from pipeline.config import BlendConfig, RenderConfig, SampleConfig
from svcore.config import build
from train.config import resolve

ROOT = Path(__file__).resolve().parents[1]


def recipe_overrides() -> dict[str, object]:
    text = (ROOT / "docs" / "TRAINING.md").read_text()
    m = re.search(r"<!-- paper-scale.*?-->\s*```\n(.*?)```", text, re.S)
    assert m, "docs/TRAINING.md lost its paper-scale block"
    assert "(docs/TRAINING.md#paper-scale)" in (ROOT / "README.md").read_text()
    words = shlex.split(m.group(1).replace("\\\n", " "))
    assert words[:3] == ["dvc", "exp", "run"], words[:3]
    sets = [words[k + 1] for k, w in enumerate(words) if w == "-S"]
    assert sets and len(sets) == words.count("-S")
    return {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in sets)}


def recipe_params(tmp_path) -> Path:
    """params.yaml with the recipe's -S values applied as DVC applies them."""
    params = yaml.safe_load((ROOT / "params.yaml").read_text())
    for key, value in recipe_overrides().items():
        node = params
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        assert leaf in node, f"{key}: not a key of params.yaml (a typo would add a new key)"
        node[leaf] = value
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(params))
    return path


def test_paper_recipe_resolves_to_the_paper_scale(tmp_path):
    path = recipe_params(tmp_path)
    sample = build(SampleConfig, params_file=path)
    blend = build(BlendConfig, params_file=path)
    render = build(RenderConfig, params_file=path)
    train = resolve(None, path)
    variants = sample.per_preset * len(list(presets()))
    assert abs(variants - 1850) / 1850 < 0.05, variants          # the paper: ~1,850 variants
    assert blend.count == 20000 and render.views == 10 and render.res == 288
    assert render.maps == "inputs"  # the paper preset's: the renders store holds no copy of the maps (docs/DATA.md)
    assert (train.preset, train.model.base_width, train.model.levels) == ("paper", 64, 8)
    assert (train.optim.lr, train.optim.iterations, train.data.crop) == (2e-5, 400_000, 256)
    assert train.optim.schedule == "constant" and train.optim.grad_clip == 0  # the paper's optimiser, unchanged
    assert train.optim.normal_l2 == 0 and train.optim.map_l1 == 0  # and the paper's loss: renderings only


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k: v})
    return out


def test_the_paper_presets_are_the_one_source_of_the_recipes_figures(tmp_path):
    """Issue #25 item 15: each stage's `paper` config preset and the docs' recipe set the same values (the
    sample preset said 12 variants per material, the recipe 36), and the --per-preset help quotes no other."""
    path = recipe_params(tmp_path)
    for cls in (SampleConfig, BlendConfig, RenderConfig):
        recipe = _flat(build(cls, params_file=path).as_dict())
        paper = _flat(build(cls, "paper").as_dict())
        for key in _flat(cls.PRESETS["paper"]):
            assert recipe[key] == paper[key], f"{cls.SECTION}.{key}: recipe {recipe[key]}, paper preset {paper[key]}"
    train_recipe, train_paper = _flat(resolve(None, path).as_dict()), _flat(resolve("paper").as_dict())
    for key in _flat(__import__("train.config").config.Config.PRESETS["paper"]):
        assert train_recipe[key] == train_paper[key], f"train.{key}"
    doc = " ".join(SampleConfig.model_fields["per_preset"].description.split())
    assert all(int(n) == SampleConfig.PRESETS["paper"]["per_preset"] for n in re.findall(r"(\d+) each", doc)), doc


def test_the_pipeline_duration_is_quoted_once():
    """Issue #25 item 15: params.yaml's header said about 15 minutes for a fresh `dvc repro`, the README 5: the
    figure lives in the README beside its measurement, the header points there."""
    header = "".join(line for line in (ROOT / "params.yaml").read_text().splitlines(True) if line.startswith("#"))
    assert not re.search(r"\d+\s*(minutes|min\b|hours)", header), header
    assert re.search(r"takes about \d+ minutes", " ".join((ROOT / "README.md").read_text().split()))
