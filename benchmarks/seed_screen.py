"""Which recorded paired effects stand out from training-seed noise: every ``effects_*.json`` of
``benchmarks/paired_effects.py`` screened against a seed pair (``effects_seed.json``), as ``--seed-noise`` does.

The records themselves are kept as they were measured; this writes one summary beside them. Sets are matched by
name (``real_crop1``, ``real_crop0.5``); a held-out set of another name (``heldout_before``, ``heldout_options`` ...)
is screened with the seed pair's ``heldout_default``. The seed pair was trained 2,770 steps on the #23 default
library: for runs of other lengths or libraries it is a rough guide, and one pair estimates the noise poorly.

    python3 benchmarks/seed_screen.py          # -> benchmarks/results/effects_seed_screen.json
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

from harness import RESULTS, parser, write_results
from paired_effects import COLUMNS, with_seed_noise

SEED = RESULTS / "effects_seed.json"


def seed_set_for(name: str, seed_sets: dict) -> str | None:
    """The seed pair's set that screens a set called ``name``: the same name, else heldout_default for held-out
    sets; None when there is none."""
    if name in seed_sets:
        return name
    if name.startswith("heldout") and "heldout_default" in seed_sets:
        return "heldout_default"
    return None


def screen(effects: dict, seed_sets: dict) -> dict:
    """Per set and column of one effects file: gain, both intervals and both verdicts (a copy: ``effects`` is kept)."""
    out = {}
    for name, e in effects["sets"].items():
        s = seed_set_for(name, seed_sets)
        if s is None:
            out[name] = {"screened_with": None}
            continue
        e = copy.deepcopy(e)
        with_seed_noise(e, seed_sets[s])
        out[name] = {"screened_with": s, **{c: {k: e[c][k] for k in ("gain", "ci95", "ci95_with_seed", "beyond_noise",
                                                                        "beyond_seed_noise")} for c in COLUMNS}}
    return out


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--seed", default=str(SEED), help="the seed pair's effects file")
    ap.add_argument("--results", default=str(RESULTS), help="folder of the effects_*.json files")
    ap.add_argument("--out", default=str(RESULTS / "effects_seed_screen.json"))
    a = ap.parse_args(argv)
    seed_path = Path(a.seed)
    seed_sets = json.loads(seed_path.read_text())["sets"]
    files = sorted(p for p in Path(a.results).glob("effects_*.json")
                   if p.resolve() != seed_path.resolve() and p.name != Path(a.out).name)
    result = {"seed_pair": seed_path.name, "rule": "paired_effects.with_seed_noise (its module docstring)",
              "files": {}, "standing_out": []}
    for p in files:
        e = json.loads(p.read_text())
        result["files"][p.name] = {"what": e.get("what", ""), "sets": screen(e, seed_sets)}
        for name, cols in result["files"][p.name]["sets"].items():
            for c in COLUMNS:
                if cols.get("screened_with") and cols[c]["beyond_seed_noise"] != "no":
                    result["standing_out"].append(f"{p.name} {name} {c}: {cols[c]['beyond_seed_noise']} "
                                                  f"{cols[c]['gain']:+.4f} {cols[c]['ci95_with_seed']}")
    for line in result["standing_out"] or ["nothing stands out from the seed noise"]:
        print(line)
    write_results(a.out, result, a.note)
    return result


if __name__ == "__main__":
    main()
