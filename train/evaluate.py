"""``svtrain eval``: RMSE per map and of re-renderings on the held-out split, beside trivial baselines.

Map RMSE is over all pixels of a sample (averaged over samples) in the stored [0, 1] encodings:
normal as (n + 1) / 2, the others linear. Re-rendering RMSE compares flash renders (clipped, linear)
of prediction and ground truth under :data:`EVAL_LIGHTS` (paper Table 1 columns).

Baselines (the bar a network must clear):
- ``input_as_diffuse``: the photo as diffuse albedo, a flat normal, training-mean roughness and specular;
- ``dataset_mean``: every map constant at its training-set mean (mean normal renormalised).

Suites: ``heldout`` is the held-out split of the training source (or of ``--store``); ``all`` is every view of
``--store``; ``stress`` evaluates every view of a renders store of ``svgen stress`` sets, one table row per
category (the paper's failure cases beside the unmodified ``reference`` category). Without a suite
(:func:`choose_suite`), the checkpoint's own training store gets ``heldout`` and any other store ``all``: a store
training never saw has no trained-on views, and its held-out split alone would be a few of its SVBRDFs (2 of the
15 imported 2018 strips). The report says which views were evaluated and why. Baseline means always come from the
training split of the training store.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from svcore.errors import ConfigError
from svcore.progress import progress

from storage.store import refuse_inside

from . import dvc_metrics, runinfo
from .brdf import DIFFUSE, NORMAL, ROUGHNESS, SPECULAR
from .config import DataConfig
from .data import PairDataset, open_source, split_for
from .dvc_metrics import COLUMNS
from .eval_chart import groups_of, plot_eval
from .render import flash_render
from .spec_stats import STATS, quartiles, spec_stats

#: flash offsets of the re-rendering metric: the capture position and four moved lights.
EVAL_LIGHTS = ((0.0, 0.0), (0.5, 0.0), (-0.4, 0.4), (0.3, -0.6), (-0.7, -0.7))
MAPS = {"normal": NORMAL, "diffuse": DIFFUSE, "roughness": ROUGHNESS, "specular": SPECULAR}
#: fewer SVBRDFs than this behind a bootstrap interval: the table flags it (resampling 2-4 SVBRDFs gives an
#: interval that is mostly an artefact of which of them are drawn, not a statement about the material population).
MIN_CLUSTERS = 5
#: the key of :func:`evaluate`'s per-view model errors, which run_eval writes to per_view.csv, not eval.json.
PER_VIEW = "per_view"
PER_VIEW_FILE = "per_view.csv"
#: the key of :func:`evaluate`'s specular-copy statistics (train/spec_stats.py) of the model's maps and the truth's.
SPEC_KEY = "specular_copy"

#: suite name -> fn(cfg, store) -> {group name: (source, indices)}.
SUITES: dict[str, Callable] = {}


def register_suite(name: str, fn: Callable) -> None:
    """Register an evaluation suite: ``fn(data: DataConfig, store: str | None) -> {group: (source, indices)}``, where
    ``data`` is the run's data config (its store, split and crop) and ``store`` the store to evaluate, if given."""
    SUITES[name] = fn


def _heldout(data: DataConfig, store: str | None):
    src = open_source(data.model_copy(update={"store": store}) if store else data)
    _, test = split_for(src, data.model_copy(update={"blends": True}))  # the held-out side: never filtered
    return {"heldout": (src, test)}


#: training views the ``train`` suite evaluates, spread evenly over the training split (a store lists its views
#: material by material, so the first N would be a few materials)
TRAIN_SUITE_VIEWS = 400


def _train(data: DataConfig, store: str | None):
    # can the model fit what it saw? An arm that cannot fit its own training views cannot show an effect elsewhere.
    data = data.model_copy(update={"store": store}) if store else data
    src = open_source(data)
    train, _ = split_for(src, data)
    if len(train) > TRAIN_SUITE_VIEWS:
        train = train[np.linspace(0, len(train) - 1, TRAIN_SUITE_VIEWS).round().astype(np.int64)]
    return {"train": (src, train)}


def _stress(data: DataConfig, store: str | None):
    if not store:
        raise ConfigError("--suite stress needs --store: a renders store of `svgen stress` sets")
    src = open_source(data.model_copy(update={"store": store}))
    cats = getattr(src, "categories_of_views", lambda: [])()
    names = [c for c in dict.fromkeys(cats) if c is not None]
    if not names:
        raise ConfigError(f"{store} holds no stress categories (render a `svgen stress` store)")
    return {c: (src, np.array([i for i, x in enumerate(cats) if x == c], np.int64)) for c in names}


def _all(data: DataConfig, store: str | None):
    # every view of an external test set, e.g. the 2018 strips imported with `svgen import --as renders`
    if not store:
        raise ConfigError("--suite all needs --store: a renders store to evaluate in full")
    src = open_source(data.model_copy(update={"store": store}))
    return {"all": (src, np.arange(len(src), dtype=np.int64))}


register_suite("heldout", _heldout)
register_suite("train", _train)
register_suite("stress", _stress)
register_suite("all", _all)


def metrics(pred: torch.Tensor, gt: torch.Tensor) -> dict[str, np.ndarray]:
    """Per-sample RMSEs.

    Args:
        pred, gt: (B, 10, H, W) packed maps.

    Returns:
        {column: (B,) RMSE}.
    """
    out = {}
    for name, sl in MAPS.items():
        a, b = pred[:, sl], gt[:, sl]
        if name == "normal":
            a, b = (a + 1) * 0.5, (b + 1) * 0.5
        out[name] = ((a - b) ** 2).mean((1, 2, 3)).sqrt().cpu().numpy()
    errs = []
    for light in EVAL_LIGHTS:
        lt = torch.tensor(light)
        errs.append(((flash_render(pred, lt) - flash_render(gt, lt)) ** 2).mean((1, 2, 3)))
    out["rerender"] = torch.stack(errs).mean(0).sqrt().cpu().numpy()
    return out


def cluster_ids(src, indices) -> np.ndarray:
    """(N,) the SVBRDF each evaluated view shows (views of one SVBRDF share their maps, so they are not independent
    samples); a source without that notion gives every view its own id."""
    per = getattr(src, "views", None)
    indices = np.asarray(indices, np.int64)
    return indices // per if isinstance(per, int) and per > 0 else indices


def paired(model_err: np.ndarray, base_err: np.ndarray, clusters: np.ndarray, seed: int,
           resamples: int = 2000) -> dict:
    """Is the model better than a baseline on one column, beyond the spread of the evaluated set?

    The gain is the mean over views of (baseline RMSE - model RMSE). Its 95 % interval comes from a cluster
    bootstrap: whole SVBRDFs (all their views together) are resampled, because views of one SVBRDF are correlated.

    Args:
        model_err, base_err: (N,) per-view RMSEs. clusters: (N,) SVBRDF id of each view.

    Returns:
        {"gain": mean gain, "ci95": [low, high], "views_better": share of views where the model is better,
        "clusters": number of SVBRDFs}.
    """
    diff = np.asarray(base_err, np.float64) - np.asarray(model_err, np.float64)
    ids, inv = np.unique(clusters, return_inverse=True)
    sums = np.bincount(inv, weights=diff, minlength=len(ids))
    counts = np.bincount(inv, minlength=len(ids)).astype(np.float64)
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(ids), size=(resamples, len(ids)))
    boot = sums[pick].sum(1) / counts[pick].sum(1)
    lo, hi = np.quantile(boot, [0.025, 0.975])
    out = {"gain": float(diff.mean()), "ci95": [float(lo), float(hi)], "views_better": float((diff > 0).mean()),
           "clusters": int(len(ids))}
    if len(ids) < MIN_CLUSTERS:
        out["warning"] = small_sample_warning(len(ids))
    return out


def small_sample_warning(clusters: int) -> str:
    """The caveat every interval over fewer than :data:`MIN_CLUSTERS` SVBRDFs carries (eval.json and eval.md)."""
    return (f"only {clusters} SVBRDF{'s' if clusters != 1 else ''} (< {MIN_CLUSTERS}): the interval is not a "
            "reliable statement about other materials")


def train_means(src, indices, crop: int, seed: int, limit: int = 64) -> torch.Tensor:
    """(10,) per-channel mean of the packed maps over (up to ``limit``) training samples.

    The samples are spread evenly over ``indices``: a store lists its samples preset by preset, so the first
    ``limit`` views of the training split are a handful of materials (on the dvc store: 3 ceramic presets of 46,
    mean specular 0.046 against 0.11 over the whole split), which made ``dataset_mean`` a weaker bar than its name.
    """
    indices = np.asarray(indices)
    if len(indices) > limit:
        indices = indices[np.linspace(0, len(indices) - 1, limit).round().astype(np.int64)]
    ds = PairDataset(src, indices, crop, seed, train=False)
    acc = torch.zeros(10)
    for k in range(len(ds)):
        acc += ds[k][1].mean((1, 2))
    return acc / len(ds)


#: the key under which a run's provenance (provenance.json, model.pt, checkpoint.pt), the bundled manifest and
#: eval.json record the baselines' training means.
MEANS_KEY = "train_means"


def means_record(means: torch.Tensor) -> dict[str, list[float]]:
    """The (10,) packed training means as recorded: {map: its channels' means} (:data:`MAPS` order)."""
    return {name: [float(v) for v in means[sl]] for name, sl in MAPS.items()}


def means_from_record(record: dict[str, list[float]]) -> torch.Tensor:
    """(10,) packed training means from :func:`means_record`'s form."""
    means = torch.zeros(10)
    for name, sl in MAPS.items():
        means[sl] = torch.tensor([float(v) for v in record[name]])
    return means


def fit_means(src, data: DataConfig, seed: int) -> dict[str, list[float]]:
    """The baselines' training means of a run, as ``svtrain fit`` records them (:func:`train_means` over the
    training split of ``src`` by ``data``, centre crops at ``data.crop``, seeded by the run's ``optim.seed``): what
    ``svtrain eval`` would compute from the training store, so that evaluating the run needs no training store."""
    train_idx, _ = split_for(src, data)
    return means_record(train_means(src, train_idx, data.crop, seed))


def input_as_diffuse(image: torch.Tensor, means: torch.Tensor) -> torch.Tensor:
    """Baseline maps (B, 10, H, W) from images (B, 3, H, W)."""
    b, _, h, w = image.shape
    out = means[None, :, None, None].expand(b, 10, h, w).clone()
    out[:, NORMAL] = torch.tensor([0.0, 0.0, 1.0], device=image.device)[None, :, None, None]
    out[:, DIFFUSE] = image.clamp(0, 1)
    return out


def dataset_mean(image: torch.Tensor, means: torch.Tensor) -> torch.Tensor:
    """Baseline maps: every channel at its training mean, mean normal renormalised."""
    b, _, h, w = image.shape
    m = means.clone()
    m[NORMAL] = m[NORMAL] / m[NORMAL].norm().clamp(min=1e-8)
    return m[None, :, None, None].expand(b, 10, h, w).clone()


@torch.no_grad()
def evaluate(model, src, indices, crop: int, means: torch.Tensor, batch_size: int = 8, seed: int = 0,
             device: torch.device | str = "cpu", desc: str = "eval") -> dict:
    """Mean RMSEs of the model and both baselines over ``indices`` (centre crops, no augmentation), computed on
    ``device`` (model, baselines and batches).

    Returns:
        {"model"|"input_as_diffuse"|"dataset_mean": {column: mean RMSE}, "samples": n,
        "paired": {baseline: {column: :func:`paired` statistics of model against that baseline}},
        :data:`SPEC_KEY`: {"model"|"ground_truth": {statistic: :func:`train.spec_stats.quartiles` over the views}}}
        (the specular-diffuse correlation and the specular chroma of the predicted and the true maps, side by side).
    """
    ds = PairDataset(src, indices, crop, seed, train=False)
    device = torch.device(device)
    means = means.to(device)
    model = model.to(device) if model is not None else None
    methods = {"model": lambda img: model(img), "input_as_diffuse": lambda img: input_as_diffuse(img, means),
               "dataset_mean": lambda img: dataset_mean(img, means)}
    acc: dict[str, dict[str, list]] = {m: {c: [] for c in COLUMNS} for m in methods}
    spec: dict[str, dict[str, list]] = {m: {s: [] for s in STATS} for m in ("model", "ground_truth")}
    if model is not None:
        model.eval()
    else:
        methods.pop("model")
        acc.pop("model")
        spec.pop("model")
    with progress(len(ds), desc, unit="sample", lines=True) as bar:
        for lo in range(0, len(ds), batch_size):
            items = [ds[k] for k in range(lo, min(lo + batch_size, len(ds)))]
            img = torch.stack([x[0] for x in items]).to(device)
            gt = torch.stack([x[1] for x in items]).to(device)
            for name, fn in methods.items():
                pred = fn(img)
                for c, v in metrics(pred, gt).items():
                    acc[name][c].extend(v.tolist())
                if name in spec:
                    _extend(spec[name], spec_stats(pred))
            _extend(spec["ground_truth"], spec_stats(gt))
            bar.update(len(items))
    res = {m: {c: float(np.mean(v)) for c, v in cols.items()} for m, cols in acc.items()}
    res["samples"] = len(ds)
    res[SPEC_KEY] = {m: {s: quartiles(v) for s, v in d.items()} for m, d in spec.items()}
    if "model" in acc:
        cl = cluster_ids(src, indices)
        # per-view errors for run_eval's per_view.csv (effects between runs bootstrap over SVBRDFs: ablation.py)
        res[PER_VIEW] = {"view": np.asarray(indices, np.int64).tolist(), "svbrdf": cl.tolist(), **acc["model"]}
        res["paired"] = {b: {c: paired(acc["model"][c], acc[b][c], cl, seed) for c in COLUMNS}
                         for b in acc if b != "model"}
    return res


def _extend(lists: dict[str, list], values: dict[str, np.ndarray]) -> None:
    for k, v in values.items():
        lists[k].extend(v.tolist())


def spec_markdown(groups: dict[str, dict], suite: str) -> list[str]:
    """eval.md's lines of the specular-copy statistics: per group, the model's maps beside the ground truth's."""
    if not any(SPEC_KEY in r for r in groups.values()):
        return []
    lines = ["", "Specular copying of the photo (train/spec_stats.py), median [quartiles] over views: the correlation "
             "of specular with diffuse luminance (Rec. 709, linear) and the specular chroma (per pixel RGB std / "
             "mean). The ground truth's give the range of the evaluated materials.", "",
             "| group | maps | specular-diffuse correlation | specular chroma |", "|---|---|---|---|"]
    for g, r in groups.items():
        for m, st in r.get(SPEC_KEY, {}).items():
            cells = [f"{q['median']:.3f} [{q['q25']:.3f}, {q['q75']:.3f}]" for q in (st[s] for s in STATS)]
            lines.append(f"| {g or suite} | {m.replace('_', ' ')} | " + " | ".join(cells) + " |")
    return lines


def markdown(res: dict) -> str:
    """A markdown table: one row per method (and per group for multi-group suites), the paper's Table 1 columns."""
    groups = res.get("groups", {"": res})
    lines = ["| group | method | " + " | ".join(COLUMNS) + " |", "|---|---|" + "---|" * len(COLUMNS)]
    for g, r in groups.items():
        for m in ("model", "input_as_diffuse", "dataset_mean"):
            if m in r:
                lines.append(f"| {g or res.get('suite', '')} | {m} | " + " | ".join(f"{r[m][c]:.4f}" for c in COLUMNS) + " |")
    n = sum(r["samples"] for r in groups.values())
    lines.append("")
    lines.append(f"RMSE over {n} samples; normal in (n+1)/2 encoding, other maps linear; "
                 f"re-rendering: flash renders under {len(EVAL_LIGHTS)} light positions.")
    if "views" in res:
        v = res["views"]
        lines.append("")
        lines.append(f"Views evaluated: {v['evaluated']} ({v['which']}) of the {v['store_views']} in {v['store']}. "
                     f"Why: {v['why']}")
    lines += spec_markdown(groups, res.get("suite", ""))
    for g, r in groups.items():
        if "paired" not in r:
            continue
        lines.append("")
        n_cl = next(iter(next(iter(r["paired"].values())).values()))["clusters"]
        lines.append(f"Model against the stronger baseline of each column{f' ({g})' if g else ''}: mean RMSE gain, "
                     f"95 % bootstrap interval over {n_cl} SVBRDFs, share of views where the model is better.")
        lines.append("")
        lines.append("| column | baseline | gain | 95 % interval | views better |")
        lines.append("|---|---|---|---|---|")
        for c in COLUMNS:
            b = min(r["paired"], key=lambda k: r[k][c])
            p = r["paired"][b][c]
            flag = f" ⚠ {p['warning']}" if p.get("warning") else ""
            lines.append(f"| {c} | {b} | {p['gain']:+.4f} | [{p['ci95'][0]:+.4f}, {p['ci95'][1]:+.4f}]{flag} | "
                         f"{100 * p['views_better']:.0f} % |")
    return "\n".join(lines) + "\n"


def write_per_view(path: Path, groups: dict[str, dict]) -> None:
    """per_view.csv: group, view index, SVBRDF id and the model's RMSE per column, one row per evaluated view."""
    with open(path, "w") as f:
        f.write(",".join(("group", "view", "svbrdf", *COLUMNS)) + "\n")
        for g, pv in groups.items():
            for k in range(len(pv["view"])):
                f.write(",".join([g, str(pv["view"][k]), str(pv["svbrdf"][k]),
                                  *(f"{pv[c][k]:.6g}" for c in COLUMNS)]) + "\n")


def store_identity(src) -> tuple | None:
    """What makes two renders stores the same data: kind, config hash and size (svgen stores are deterministic in
    their config, so a copy or a moved store is the same store); None for the synthetic source."""
    meta = (getattr(src, "attrs", None) or {}).get("svgen")
    return None if not meta else (meta.get("kind"), meta.get("config_hash"), meta.get("n"))


def train_identity(provenance: dict, train_src=None) -> tuple | None:
    """:func:`store_identity` of a run's training store from what the run recorded (its provenance's ``data``),
    so that telling the training store from another one needs no copy of it; ``train_src`` when nothing is
    recorded; None for the synthetic source."""
    data = provenance.get("data")
    if data is None:
        return store_identity(train_src) if train_src is not None else None
    return None if "synthetic" in data else (data.get("kind"), data.get("config_hash"), data.get("n"))


def choose_suite(suite: str | None, store: str | None, store_src, train_ident: tuple | None) -> tuple[str, str]:
    """The suite to run and why, in words for the report.

    Without ``suite``: ``heldout`` on the checkpoint's training store (its other views were trained on), ``all`` on
    any other store (training saw none of it: evaluating only its held-out split would drop most of it).
    ``train_ident``: the training store's :func:`store_identity` (:func:`train_identity`).
    """
    foreign = store is not None and (train_ident is None or store_identity(store_src) != train_ident)
    if suite is not None:
        return suite, f"--suite {suite} was asked for" + (
            " (the store is not the checkpoint's training store)" if foreign and suite == "heldout" else "")
    if foreign:
        return "all", ("the store is not the checkpoint's training store (different data), so training saw none of "
                       "its views: every view is evaluated (--suite heldout for its held-out split only)")
    return "heldout", ("the checkpoint's own training store: only the held-out split (materials training never saw) "
                       "is evaluated")


def recorded_means(checkpoint_path, provenance: dict) -> tuple[dict | None, str]:
    """The baselines' training means a model carries (:func:`means_record` form) and where they were found: its
    provenance (``svtrain fit`` records them), else, for the bundled model, its manifest (a model bundled before
    fit recorded them); None for older runs."""
    from . import bundled_model

    if provenance.get(MEANS_KEY):
        return provenance[MEANS_KEY], "recorded with the model at fit time"
    if bundled_model.is_bundled(checkpoint_path):
        return bundled_model.manifest().get(MEANS_KEY), f"the bundled model's {bundled_model.MANIFEST_FILE}"
    return None, ""


def run_eval(checkpoint_path: str | Path, out_dir: str | Path, suite: str | None = None,
             store: str | None = None, limit: int | None = None, train_store: str | None = None,
             device: str = "cpu") -> dict:
    """Evaluate a checkpoint on a suite on ``device`` (train/device.py strings); writes eval.json, eval.md and
    eval.png (bars) into ``out_dir``.

    The baselines' means are those the model carries (:func:`recorded_means`), so a model evaluates on any
    ``store`` from any directory without its training store. The training store is needed only for its held-out
    split (no ``store``), or for the means of a run that records none; it is found through the run's ``run.json``
    (:mod:`train.runinfo`), or given as ``train_store``, whose means then override recorded ones. ``suite`` None
    picks one (:func:`choose_suite`); the result's ``views`` says which views were evaluated and why, its
    :data:`MEANS_KEY` which means the baselines used and where they came from.

    Returns:
        for one-group suites: {"model"|baseline: {column: RMSE}, "samples", "suite", "beats_baselines"};
        for several groups (stress): {"suite", "groups": {name: that dict}}.

    Raises:
        StoreError: the training store is needed and not found (one line saying why it is needed).
    """
    from .checkpoint import load, model_from_state
    from .device import resolve_device

    dev = resolve_device(device)
    if suite is not None and suite not in SUITES:
        raise ConfigError(f"unknown eval suite {suite!r}; known: {', '.join(sorted(SUITES))}")
    state = load(checkpoint_path)
    model, cfg = model_from_state(state)
    prov = state.get("provenance") or {}
    recorded, means_from = (None, "") if train_store else recorded_means(checkpoint_path, prov)
    train_src, inputs = None, [store] if store else []
    if store is None or recorded is None:  # the training source itself is needed
        need = ("eval without --store evaluates its held-out split" if store is None else
                "the run records no training means for the baselines (trained before svtrain fit recorded them)")
        cfg = cfg.model_copy(update={"data": cfg.data.model_copy(
            update={"store": runinfo.train_store(checkpoint_path, cfg.data.store, train_store, need)})})
        train_src = open_source(cfg.data)
        inputs += [cfg.data.store] if cfg.data.store else []
    refuse_inside(out_dir, inputs)
    store_src = open_source(cfg.data.model_copy(update={"store": store})) if store else train_src
    suite, why = choose_suite(suite, store, store_src, train_identity(prov, train_src))
    groups = SUITES[suite](cfg.data, store)
    if recorded is not None:
        means = means_from_record(recorded)
    else:
        train_idx, _ = split_for(train_src, cfg.data)  # baseline means: the training split of the training store
        means = train_means(train_src, train_idx, cfg.data.crop, cfg.optim.seed)
        means_from = "computed from --train-store" if train_store else "computed from the training store"
    out_groups, per_view = {}, {}
    for name, (src, idx) in groups.items():
        if limit:
            idx = idx[:limit]
        r = evaluate(model, src, idx, cfg.data.crop, means, cfg.optim.batch_size, cfg.optim.seed, dev,
                     desc=f"eval {name}" if len(groups) > 1 else "eval")
        r["beats_baselines"] = {c: all(r["model"][c] < r[b][c] for b in ("input_as_diffuse", "dataset_mean"))
                                for c in COLUMNS}
        per_view[name] = r.pop(PER_VIEW)
        out_groups[name] = r
    res = {**out_groups[next(iter(out_groups))], "suite": suite} if len(out_groups) == 1 else \
        {"suite": suite, "groups": out_groups}
    res["views"] = {"which": {"heldout": "the held-out split", "all": "every view",
                              "stress": "every view, per stress category"}.get(suite, f"suite {suite}"),
                    "evaluated": sum(r["samples"] for r in out_groups.values()), "store_views": len(store_src),
                    "store": "the training store" if store is None else Path(str(store).rstrip("/")).name,
                    "why": why + (f"; at most {limit} views per group (--limit)" if limit else "")}
    res[MEANS_KEY] = {"from": means_from, "maps": means_record(means)}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_per_view(out / PER_VIEW_FILE, per_view)
    (out / "eval.json").write_text(json.dumps(res, indent=2) + "\n")
    dvc_metrics.write(out / dvc_metrics.EVAL_FILE, dvc_metrics.eval_metrics(res))  # what `dvc metrics` shows
    (out / "eval.md").write_text(markdown(res))
    plot_eval(groups_of(res), out / "eval.png",
              f"svtrain eval --suite {suite}: {shown_checkpoint(checkpoint_path, out)}")
    return res


def shown_checkpoint(checkpoint_path: str | Path, out_dir: str | Path) -> str:
    """How eval.png names the model: "bundled", else its path relative to the output folder's parent, as a store
    records its inputs relative to its own directory (``runs/train`` from ``runs/eval``: ``train``), so that neither
    the working directory nor the spelling of the paths changes a byte."""
    import os

    from .bundled_model import is_bundled

    if is_bundled(checkpoint_path):
        return "bundled"
    return os.path.relpath(Path(checkpoint_path).resolve(), Path(out_dir).resolve().parent)
