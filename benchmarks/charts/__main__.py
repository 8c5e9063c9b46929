"""Rebuild the README's charts from the benchmark results (matplotlib PNG + the plotted data as CSV).

    python3 benchmarks/charts              # docs/img/chart_*.png, benchmarks/results/chart_*.csv
    python3 benchmarks/charts --out runs/charts   # both into one folder (the DVC `charts` stage)

1. render: time per view against error to a converged reference (bench_render_quality.py), default marked;
2. training: held-out re-render RMSE against training wall time per width (experiments/train_budget, frozen);
3. scale-out: views/s against dask workers, local and a loopback cluster (bench_scaleout.py);
4. agreement: torch flash render against Mitsuba at increasing spp (bench_agreement.py);
5. stress: the pipeline's stress-suite evaluation beside its held-out one (runs/eval*, written by `dvc repro`);
6. codecs: bytes per view against CPU-s per view of the store codecs and layouts (experiments/store_codecs,
   frozen; drawn by its chart_codecs.py);
7. ablation: per claim of the paper, held-out error against training CPU time of both arms with their seed spread,
   and the effects table beside it (ablation.py; the 2026-11-24 grid's results and chart frozen in
   experiments/ablation).
A chart whose results file is missing is skipped with a note (run its benchmark first).
"""
from __future__ import annotations

import importlib
import importlib.util
import json
import sys
from pathlib import Path

if not __package__:  # run as a file (python3 benchmarks/charts/...): harness.py is one folder up
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from harness import IMG, RESULTS, ROOT, parser, pyplot, save_figure, write_csv  # noqa: E402

plt = pyplot()
#: the width sweep behind the training chart: a finished experiment, its results frozen there
TRAIN_BUDGET = ROOT / "experiments" / "train_budget" / "results"
#: the store codec measurement behind chart 6: a finished experiment, its chart code and results frozen there
STORE_CODECS = ROOT / "experiments" / "store_codecs"
#: the ablation grid of 2026-11-24 behind chart 7 (run by benchmarks/ablation.py): its chart code and results there
ABLATION = ROOT / "experiments" / "ablation"
CSV = RESULTS  # --out sends the PNGs and CSVs into one folder


def chart_render() -> Path | None:
    src = RESULTS / "render_quality.json"
    if not src.exists():
        return None
    d = json.loads(src.read_text())
    rows = [{k: c[k] for k in ("res", "light", "sampler", "spp", "cpu_s_per_view", "rel_rmse")}
            for c in d["candidates"]]
    write_csv(CSV / "chart_render.csv", rows)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    styles = {"point": "o", "sphere": "s"}
    colours = {128: "tab:blue", 256: "tab:orange"}
    for (res, light, sampler) in sorted({(r["res"], r["light"], r["sampler"]) for r in rows}):
        pts = sorted((r for r in rows if (r["res"], r["light"], r["sampler"]) == (res, light, sampler)),
                     key=lambda r: r["spp"])
        ax.plot([p["cpu_s_per_view"] * 1e3 for p in pts], [p["rel_rmse"] * 100 for p in pts],
                marker=styles[light], color=colours.get(res, "grey"), ls="-" if sampler == "independent" else ":",
                label=f"{res}² {light} {sampler}", ms=4)
        for p in pts:
            ax.annotate(str(p["spp"]), (p["cpu_s_per_view"] * 1e3, p["rel_rmse"] * 100), fontsize=6,
                        xytext=(2, 2), textcoords="offset points")
    chosen = d["chosen"].get("256")
    if chosen:
        ax.scatter([chosen["cpu_s_per_view"] * 1e3], [chosen["rel_rmse"] * 100], s=160, facecolors="none",
                   edgecolors="red", linewidths=2, zorder=5, label="default (256², point, centre, 1 spp)")
    ax.axhline(d["threshold_rel_rmse"] * 100, color="red", lw=0.8, ls="--", label="1 % bar")
    ax.set(xscale="log", yscale="log", xlabel="CPU ms per view", ylabel="relative RMSE vs converged reference (%)",
           title="Render: cost against error (labels: spp)")
    ax.legend(fontsize=6, ncol=2)
    return _save(fig, "chart_render.png")


def chart_scaleout() -> Path | None:
    src = RESULTS / "scaleout.json"
    if not src.exists():
        return None
    d = json.loads(src.read_text())
    rows = [{k: r[k] for k in ("config", "workers", "views_per_s_total", "views_per_s_steady")} for r in d["rows"]]
    # the S3 rows (issue #12): whole commands only, to the loopback S3 server and to local disk, from their own run
    rows += [{"config": r["config"], "workers": r["workers"], "views_per_s_total": r["views_per_s_total"],
              "views_per_s_steady": None} for r in d.get("s3_rows", [])]
    write_csv(CSV / "chart_scaleout.csv", rows)
    loader = d.get("loader_rows", [])
    height = 3.5 + 0.2 * len(d.get("s3_rows", []))
    fig, axes = plt.subplots(1, 2 if loader else 1, figsize=(11 if loader else 7, height),
                             gridspec_kw={"width_ratios": [3, 2]} if loader else None, squeeze=False)
    ax = axes[0][0]
    y = range(len(rows))
    ax.barh([i + 0.2 for i in y], [r["views_per_s_steady"] or 0 for r in rows], height=0.4, label="steady state")
    ax.barh([i - 0.2 for i in y], [r["views_per_s_total"] for r in rows], height=0.4,
            label="whole command (cluster start included)")
    ax.set_yticks(list(y), [r["config"] for r in rows], fontsize=8)
    s3 = d.get("s3_run")
    ax.set(xlabel="views / s (256², default quality)",
           title=f"Scale-out on {d['machine']['cpus']} cores (stores identical: {d['stores_identical']})"
           + (f"\nS3 rows: {s3['svbrdfs']} SVBRDFs, moto on loopback, load {s3['machine']['loadavg_1min']}"
              if s3 else ""))
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7)
    if loader:
        bx = axes[0][1]
        kinds = [("local_samples_per_s", "local disk"), ("s3_cold_cache_samples_per_s", "S3, cold cache"),
                 ("s3_warm_cache_samples_per_s", "S3, warm cache")]
        for j, (key, label) in enumerate(kinds):
            bx.bar([i + (j - 1) * 0.27 for i in range(len(loader))], [r[key] for r in loader], width=0.27, label=label)
        bx.set_xticks(range(len(loader)), [f"{r['loader_workers']} loader workers" for r in loader], fontsize=8)
        bx.set(ylabel="samples / s", title="Training loader: local store vs S3 store")
        bx.title.set_fontsize(9)
        bx.legend(fontsize=7)
    return _save(fig, "chart_scaleout.png")


def chart_stress() -> Path | None:
    """The pipeline's own evaluations (``dvc repro``: runs/eval, runs/eval_stress): every stress category beside the
    held-out test set, model against both baselines."""
    paths = {"heldout": ROOT / "runs" / "eval" / "eval.json", "stress": ROOT / "runs" / "eval_stress" / "eval.json"}
    if not all(p.exists() for p in paths.values()):
        return None
    from train.eval_chart import groups_of, plot_eval

    groups = {}
    for name, p in paths.items():
        groups.update({f"{name}: {g}" if name == "heldout" else g: r
                       for g, r in groups_of(json.loads(p.read_text())).items()})
    write_csv(CSV / "chart_stress.csv", [{"group": g, "method": m, **r[m]} for g, r in groups.items()
                                          for m in ("model", "input_as_diffuse", "dataset_mean")])
    return plot_eval(groups, IMG / "chart_stress.png", "Stress categories beside the held-out test set "
                     "(dvc repro default model; bar labels: views)")


def _external(module: str | Path, func: str, json_name: str, png: str, results: Path | None = None) -> Path | None:
    """Charts whose plotting lives beside their benchmark: ``func(json_path, png_path)`` of ``module`` (a module
    name, or a finished experiment's chart file); ``results`` is the folder of ``json_name`` (default
    benchmarks/results)."""
    src = (results or RESULTS) / json_name
    if not src.exists():
        return None
    if isinstance(module, Path):
        spec = importlib.util.spec_from_file_location(module.stem, module)
        spec.loader.exec_module(mod := importlib.util.module_from_spec(spec))
    else:
        mod = importlib.import_module(module)
    getattr(mod, func)(src, IMG / png)
    return IMG / png


def _save(fig, name: str) -> Path:
    return save_figure(fig, IMG / name, dpi=110)


def main(argv=None) -> int:
    global IMG, CSV
    ap = parser(__doc__, note=False)
    ap.add_argument("--out", type=Path, default=None, help="write PNGs and CSVs into this folder")
    args = ap.parse_args(argv)
    if args.out is not None:
        IMG = CSV = args.out.resolve()
        IMG.mkdir(parents=True, exist_ok=True)
    made = {"render": chart_render(), "training": _external("charts.training", "plot", "train_budget.json",
                                                            "chart_training.png", TRAIN_BUDGET),
            "scale-out": chart_scaleout(),
            "agreement": _external("charts.agreement", "chart_agreement", "agreement.json",
                                       "chart_agreement.png"),
            "stress": chart_stress(),
            "codecs": _external(STORE_CODECS / "chart_codecs.py", "plot", "codecs.json", "chart_codecs.png",
                                STORE_CODECS / "results"),
            "ablation": _external(ABLATION / "chart_ablation.py", "plot", "ablation.json", "chart_ablation.png",
                                  ABLATION / "results")}
    for name, p in made.items():
        print(f"{name:10s} {p if p else 'skipped: run its benchmark first'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
