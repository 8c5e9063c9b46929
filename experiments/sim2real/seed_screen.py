"""Which recorded paired effects stand out from training-seed noise: every ``effects_*.json`` of
``experiments/sim2real/paired_effects.py`` screened against the seed pairs of one control (``effects_seed.json``,
``effects_seed2.json``: ``--seed``, repeatable), as ``--seed-noise`` does.

The records themselves are kept as they were measured; this writes one summary beside them. Sets are matched by
name (``real_crop1``, ``real_crop0.5``); a held-out set of another name (``heldout_before``, ``heldout_options`` ...)
is screened with the seed pairs' ``heldout_default``. The seed runs were trained 2,770 steps on the #23 default
library: for runs of other lengths or libraries they are a rough guide, and a few seeds estimate the noise poorly.

    python3 experiments/sim2real/seed_screen.py          # -> experiments/sim2real/results/effects_seed_screen.json
"""
from __future__ import annotations

import copy
import json
import sys
from pathlib import Path

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/sim2real/results/)
RESULTS = Path(__file__).resolve().parent / "results"
from paired_effects import COLUMNS, with_seed_noise

SEEDS = [RESULTS / "effects_seed.json", RESULTS / "effects_seed2.json"]


def seed_set_for(name: str, seed_sets: dict) -> str | None:
    """The seed pairs' set that screens a set called ``name``: the same name, else heldout_default for held-out
    sets; None when there is none."""
    if name in seed_sets:
        return name
    if name.startswith("heldout") and "heldout_default" in seed_sets:
        return "heldout_default"
    return None


def screen(effects: dict, seeds: list[dict]) -> dict:
    """Per set and column of one effects file: gain, both intervals and both verdicts (a copy: ``effects`` is kept).
    ``seeds``: each seed pair's ``sets``; a set is screened only where every pair has its counterpart."""
    out = {}
    for name, e in effects["sets"].items():
        s = seed_set_for(name, seeds[0])
        if s is None or any(s not in sets for sets in seeds):
            out[name] = {"screened_with": None}
            continue
        e = copy.deepcopy(e)
        with_seed_noise(e, [sets[s] for sets in seeds])
        out[name] = {"screened_with": s, **{c: {k: e[c][k] for k in ("gain", "ci95", "ci95_with_seed", "beyond_noise",
                                                                        "beyond_seed_noise")} for c in COLUMNS}}
    return out


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--seed", action="append", default=None, help="a seed pair's effects file (repeatable; default: "
                    "the recorded ones that exist)")
    ap.add_argument("--results", default=str(RESULTS), help="folder of the effects_*.json files")
    ap.add_argument("--out", default=str(RESULTS / "effects_seed_screen.json"))
    a = ap.parse_args(argv)
    seed_paths = [Path(p) for p in a.seed] if a.seed else [p for p in SEEDS if p.is_file()]
    seeds = [json.loads(p.read_text())["sets"] for p in seed_paths]
    skip = {p.resolve() for p in seed_paths} | {Path(a.out).resolve()}
    files = sorted(p for p in Path(a.results).glob("effects_*.json") if p.resolve() not in skip)
    result = {"seed_pairs": [p.name for p in seed_paths], "rule": "paired_effects.with_seed_noise (its module "
              "docstring)", "files": {}, "standing_out": []}
    for p in files:
        e = json.loads(p.read_text())
        result["files"][p.name] = {"what": e.get("what", ""), "sets": screen(e, seeds)}
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
