"""``svtrain bundle RUN``: make a trained run the model shipped in the package, with its model card.

Writes into ``train/bundled/`` (or ``--into``): ``model.pt`` (weights only: config, weights, step, provenance with
no machine paths), ``bundled.json`` (its SHA-256, size and summary, :mod:`train.bundled_model`) and
``MODEL_CARD.md``, generated here from the run and from the evaluations it runs (``svtrain eval``'s held-out and
stress suites and ``svtrain eval-reference``'s real materials, tables with 95 % bootstrap intervals), so that the
card is reproduced with the model by the DVC stage ``train_bundled`` (the exact commands are in the card).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from svcore.errors import SvgenError
from svcore.log import get_logger

from . import bundled_model, checkpoint, photo_check
from .evaluate import COLUMNS, MEANS_KEY, markdown, run_eval

log = get_logger(__name__)

#: the commands that reproduce the bundled model (the DVC stage train_bundled runs exactly these).
RECIPE = ("svtrain fit --config-preset compact --store data/renders.zarr --iterations 12000 --seed 0 "
          "--out runs/bundled --resume-if-unchanged",
          "svtrain bundle runs/bundled --stress-store data/stress_renders.zarr --reference-store "
          "data/reference/renders.zarr --params params.yaml --limit 400 --final")
#: views of the training store whose input statistics the card reports (spread evenly over the store).
FLAG_VIEWS = 400
LICENCE = ("The weights: CC BY 4.0, like the svgen-generated data they were trained on (every store's dataset card "
           "states it); the code that runs them: MIT (LICENSE).")


def _store_config(path: str) -> dict[str, Any]:
    """A renders store's recorded config, its inputs' configs and its size (the card's data section)."""
    import zarr

    g = zarr.open_group(path, mode="r")
    attrs = dict(g.attrs)
    out = {"kind": attrs["svgen"].get("kind"), "svbrdfs": attrs["svgen"].get("n"),
           "config_hash": attrs["svgen"].get("config_hash"), "svgen_version": attrs["svgen"]["versions"].get("svgen"),
           "render": {k: v for k, v in attrs.get("config", {}).items() if k != "inputs"}, "inputs": []}
    for inp in attrs.get("inputs", []):
        cfg = None
        try:
            cfg = dict(zarr.open_group(str(Path(path) / ".." / inp["path"]), mode="r").attrs).get("config")
        except Exception:  # an input store moved or deleted: the card says so rather than failing
            pass
        out["inputs"].append({"kind": inp["kind"], "n": inp["n"], "config_hash": inp["config_hash"], "config": cfg})
    return out


def _flag_rates(store: str, crop: int) -> dict[str, Any]:
    """Share of the training store's views that the out-of-distribution rules flag (the thresholds' false alarms)."""
    import torch

    from .config import preset
    from .data import open_source

    cfg = preset("compact")
    src = open_source(cfg.data.model_copy(update={"store": store}))
    idx = np.unique(np.linspace(0, len(src) - 1, min(FLAG_VIEWS, len(src))).astype(int))
    imgs = np.stack([np.asarray(src.image(int(i)), np.float32).transpose(2, 0, 1) for i in idx])
    return {"views": int(len(idx)), "rates": photo_check.flag_rates(torch.from_numpy(imgs))}


def _worst(stress: dict) -> list[tuple[str, float, list[str]]]:
    """Stress categories by the model's re-render RMSE, worst first, with the columns where a baseline is better."""
    rows = []
    for name, r in stress.get("groups", {stress.get("suite", "stress"): stress}).items():  # one category: no groups
        lost = [c for c in COLUMNS if not r["beats_baselines"][c]]
        rows.append((name, float(r["model"]["rerender"]), lost))
    return sorted(rows, key=lambda t: -t[1])


def weights_state(run: Path) -> dict[str, Any]:
    """The run's model.pt reduced to what the package ships: no optimiser, no machine paths."""
    state = checkpoint.load(run / "model.pt")
    prov = json.loads(json.dumps(state.get("provenance", {})))
    prov.get("data", {}).pop("store_resolved", None)  # an absolute path of the training machine (older runs)
    return {"config": state["config"], "model": state["model"], "step": state["step"], "provenance": prov,
            "network_format": state.get("network_format", checkpoint.NETWORK_FORMAT)}


def _reference_section(reference: dict | None) -> list[str]:
    """The card's real-material table, or why there is none."""
    head = ["### Real-material reference store", ""]
    if reference is None:
        return head + ["Not evaluated for this card: no reference store (params.yaml `reference.sources` empty, or "
                       "`svtrain bundle` run without `--reference-store`). README \"How real is the data?\" says how "
                       "to build one from real CC0 materials.", ""]
    src = reference.get("reference_source") or {}
    what = (f"{src.get('materials', '?')} real CC0 materials ({src.get('folders', 'reference.sources')}, imported at "
            f"crop {src.get('crop', '?')}) rendered with the training views, every view evaluated; never trained on. "
            "The baselines' normal is the flat map, so the normal column's gain is the model's gain over flat.")
    return head + [what, "", markdown(reference).rstrip(), ""]


def _reference_source(params_file: str | Path, store: str | Path) -> dict:
    """What the reference store holds, for the card: material count, source folder names (no paths), crop."""
    import zarr

    from svcore.config import params_section

    section = params_section(params_file, "reference") if Path(params_file).exists() else {}
    n = None
    try:
        n = int(zarr.open_group(str(store), mode="r")["image"].shape[0])
    except Exception:  # the eval already opened it; a count is only a label
        pass
    return {"materials": n, "folders": ", ".join(Path(str(f)).name for f in section.get("sources") or []),
            "crop": section.get("crop", 1.0)}


def card(run: Path, state: dict, metrics: dict, data: dict, heldout: dict, stress: dict | None,
         flags: dict, size_bytes: int, placeholder: bool, reference: dict | None = None) -> str:
    """The model card's markdown."""
    cfg = state["config"]
    versions = state["provenance"].get("versions", {})
    lines = ["# svgen bundled model: card", ""]
    if placeholder:
        lines += ["**Placeholder.** This model exists to build and test the mechanism (bundling, `svtrain predict` "
                  "without `--checkpoint`, ONNX export) on today's default data and a short training. It will be "
                  "replaced by a model trained on the improved data and training once those land; do not judge "
                  "svgen's capture quality by it.", ""]
    lines += ["## What it is", "",
              f"The compact single-image SVBRDF capture network (U-Net with the global-feature track, "
              f"{metrics.get('parameters', '?'):,} parameters, {size_bytes / 1e6:.1f} MB of float32 weights, "
              f"`train/bundled/model.pt`, loadable with `torch.load(weights_only=True)`). Input: one flash photo, "
              f"linear RGB in [0, 1], centre-cropped square, side a multiple of {2 ** cfg['model']['levels']}. "
              "Output: normal, diffuse, roughness and specular maps (DESIGN.md conventions).", "",
              "## Data", "",
              f"- training store: `{state['provenance'].get('data', {}).get('store', '?')}`, "
              f"{data['svbrdfs']} SVBRDFs x {data['render'].get('views')} views at {data['render'].get('res')}², "
              f"config hash `{data['config_hash']}`, written by svgen `{data['svgen_version']}`",
              f"- render config: `{json.dumps(data['render'], sort_keys=True)}`"]
    for inp in data["inputs"]:
        lines.append(f"- input {inp['kind']} ({inp['n']}, hash `{inp['config_hash']}`): "
                     f"`{json.dumps(inp['config'], sort_keys=True)}`")
    lines += [f"- held-out split: {cfg['data']['holdout']:.0%} of the source materials (split seed "
              f"{cfg['data']['split_seed']}), never trained on", "",
              "## Training", "",
              f"- steps: {state['step']} (batch {cfg['optim']['batch_size']}, seed {cfg['optim']['seed']}), "
              f"device {metrics.get('device', '?')}, precision {metrics.get('precision', '?')}",
              f"- training wall time: {metrics.get('train_wall_s', 0) / 60:.1f} min "
              f"({metrics.get('train_cpu_s', 0) / 60:.1f} CPU min; a shared 2-core machine)",
              f"- final training loss {metrics.get('loss_final', float('nan')):.4f} "
              f"(first {metrics.get('loss_first', float('nan')):.4f})",
              f"- svgen `{versions.get('svgen', '?')}`, torch `{versions.get('torch', '?')}`",
              "- config (`svtrain fit --print-config` form):", "", "```yaml",
              yaml.safe_dump({"train": {"config_preset": cfg.get("preset", "compact"),
                                        **{k: v for k, v in cfg.items() if k != "preset"}}}, sort_keys=False).rstrip(),
              "```", "",
              "## Reproduce", "",
              "From a checkout, after the data stages of `dvc repro` (the default `params.yaml`):", "",
              "```bash", *RECIPE, "```", "",
              "This is the DVC stage `train_bundled` (frozen, so that `dvc repro` leaves it out: "
              "`dvc unfreeze train_bundled && dvc repro train_bundled && dvc freeze train_bundled`). The "
              "real-material table needs the reference store: list the real material folders in params.yaml "
              "`reference.sources` (this card: `[../shared/materials-cc0]`, `reference.crop: 1.0`) so that the "
              "`reference` stage renders them.", "",
              "## Licence", "", LICENCE, "",
              "## Evaluation", "",
              "RMSE against the ground-truth maps and re-renderings, beside two baselines (the input photo as the "
              "diffuse map with mean other maps; the training data's mean maps), from `svtrain eval`. Gains are "
              "the model's RMSE below the stronger baseline of each column, with 95 % bootstrap intervals over "
              "SVBRDFs.", "",
              "### Held-out materials", "", markdown(heldout).rstrip(), ""]
    if stress is not None:
        lines += ["### Stress suite (one group per category)", "", markdown(stress).rstrip(), ""]
    lines += _reference_section(reference)
    lines += ["## Intended use", "",
              "- Estimating SVBRDF maps of a roughly flat, roughly fronto-parallel material sample from one photo "
              "taken with the phone's flash on, for previews, look-development starting points and research.",
              "- Fine-tuning (`svtrain fit --init bundled`) and export (`svtrain export-model bundled --format onnx "
              "OUT.onnx`).",
              "- Not for measurement: the maps are plausible estimates, not calibrated reflectance.", "",
              "## Known failure cases", ""]
    if stress is not None:
        worst = _worst(stress)
        lines.append("The stress suite's categories, worst re-render RMSE first (columns where a baseline does "
                     "better in brackets):")
        lines.append("")
        for name, err, lost in worst[:3]:
            lines.append(f"- {name}: re-render RMSE {err:.4f}" + (f" (baseline better on: {', '.join(lost)})"
                                                                  if lost else ""))
        lines.append("")
    lines += ["- Photos far from the training photos: very dark, with large saturated highlights, or without a "
              "flash. `svtrain predict` still predicts and records a warning in `prediction.json` "
              "(`input_check`). On the training store, the rules flag "
              + ", ".join(f"{k} {100 * v:.1f} %" for k, v in flags["rates"].items())
              + f" of {flags['views']} views.", ""]
    return "\n".join(lines)


def bundle(run_dir: str | Path, stress_store: str | None = None, into: str | Path | None = None,
           limit: int | None = 400, placeholder: bool = True, device: str = "cpu",
           reference_store: str | None = None, params_file: str | Path = "params.yaml") -> Path:
    """Evaluate a finished run and write it as the bundled model with its card.

    Args:
        run_dir: a finished ``svtrain fit`` run (model.pt, metrics.json).
        stress_store: a renders store of ``svgen stress`` (the card's stress table and failure cases); None: none.
        into: the folder to write (default: the package's ``train/bundled``).
        limit: held-out views evaluated (as the DVC eval stage's ``eval.limit``).
        placeholder: mark the card and manifest as a placeholder model.
        reference_store: the reference renders store (``svgen reference OUT``: OUT/renders.zarr), evaluated as
            ``svtrain eval-reference`` does when ``params_file`` lists reference sources; None: no reference table.
        params_file: the params file whose ``reference`` section says whether there is a reference.

    Returns:
        the folder written.

    Raises:
        SvgenError: not a finished run, or its store is missing; reference sources listed but no finished
            reference store.
    """
    run = Path(run_dir)
    if not (run / "model.pt").is_file() or not (run / "metrics.json").is_file():
        raise SvgenError(f"{run} is not a finished svtrain run (no model.pt and metrics.json): run `svtrain fit` "
                         "to the end first")
    from . import timing

    # the card's training time: the run's clock (timing.json; metrics.json of runs from before it held the clock)
    metrics = {**json.loads((run / "metrics.json").read_text()),
               **{k: v for k, v in timing.read(run).items() if k in timing.KEYS and v is not None}}
    state = weights_state(run)
    store = state["config"]["data"]["store"]
    if not store:
        raise SvgenError(f"{run} trained on the synthetic source: bundle a run trained on a renders store")
    heldout = run_eval(run, run / "bundle_eval_heldout", suite="heldout", limit=limit, device=device)
    stress = run_eval(run, run / "bundle_eval_stress", suite="stress", store=stress_store, device=device) \
        if stress_store else None
    reference = None
    if reference_store:
        from . import eval_reference

        reference = eval_reference.run(run, params_file, reference_store, run / "bundle_eval_reference", device)
        if reference is None:
            log.info("no reference sources in %s (reference.sources is empty): the card has no real-material table",
                     params_file)
        else:
            reference["reference_source"] = _reference_source(params_file, reference_store)
    from .runinfo import train_store

    store_path = train_store(run, store)
    data = _store_config(store_path)
    flags = _flag_rates(store_path, state["config"]["data"]["crop"])
    out = Path(into) if into else bundled_model.folder()
    out.mkdir(parents=True, exist_ok=True)
    model_file = out / bundled_model.MODEL_FILE
    checkpoint.save(model_file, state)
    size = model_file.stat().st_size
    info = {"file": bundled_model.MODEL_FILE, "sha256": bundled_model.sha256(model_file), "bytes": size,
            "steps": state["step"], "placeholder": placeholder,
            "data": f"the default store ({data['svbrdfs']} SVBRDFs x {data['render'].get('views')} views)",
            "svgen_version": state["provenance"].get("versions", {}).get("svgen"),
            "heldout_rerender_rmse": round(float(heldout["model"]["rerender"]), 5),
            # what the baselines of `svtrain eval --checkpoint bundled` use: no user has the training store
            MEANS_KEY: heldout[MEANS_KEY]["maps"]}
    if reference is not None:
        info["reference_normal_rmse"] = round(float(reference["model"]["normal"]), 5)
    (out / bundled_model.MANIFEST_FILE).write_text(json.dumps(info, indent=2) + "\n")
    (out / bundled_model.CARD_FILE).write_text(card(run, state, metrics, data, heldout, stress, flags, size,
                                                    placeholder, reference))
    return out
