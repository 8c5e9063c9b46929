"""The README's paper-scale recipe (`dvc exp run -S ...`) stays valid: applied to params.yaml the way DVC applies
`-S key=value` (the value parsed as YAML), every stage config resolves and the scale is the paper's."""
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
    text = (ROOT / "README.md").read_text()
    m = re.search(r"<!-- paper-scale.*?-->\s*```\n(.*?)```", text, re.S)
    assert m, "README.md lost its paper-scale block"
    words = shlex.split(m.group(1).replace("\\\n", " "))
    assert words[:3] == ["dvc", "exp", "run"], words[:3]
    sets = [words[k + 1] for k, w in enumerate(words) if w == "-S"]
    assert sets and len(sets) == words.count("-S")
    return {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in sets)}


def test_paper_recipe_resolves_to_the_paper_scale(tmp_path):
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

    sample = build(SampleConfig, params_file=path)
    blend = build(BlendConfig, params_file=path)
    render = build(RenderConfig, params_file=path)
    train = resolve(None, path)
    variants = sample.per_preset * len(list(presets()))
    assert abs(variants - 1850) / 1850 < 0.05, variants          # the paper: ~1,850 variants
    assert blend.count == 20000 and render.views == 10 and render.res == 288
    assert (train.preset, train.model.base_width, train.model.levels) == ("paper", 64, 8)
    assert (train.optim.lr, train.optim.iterations, train.data.crop) == (2e-5, 400_000, 256)
    assert train.optim.schedule == "constant" and train.optim.grad_clip == 0  # the paper's optimiser, unchanged
    assert train.optim.normal_l2 == 0 and train.optim.map_l1 == 0  # and the paper's loss: renderings only
