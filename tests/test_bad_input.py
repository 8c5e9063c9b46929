"""Bad input across every command, table-driven: one clear line on stderr, a non-zero exit, no traceback,
and nothing written where the output would have gone."""
from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import torch
import zarr
from PIL import Image

from pipeline.cli import cli
from svcore.cli import run_cli
from train.cli import svtrain

SMALL = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
         "--set", "data.crop=32", "--set", "data.synthetic_size=40", "--set", "data.synthetic_samples=8",
         "--set", "data.synthetic_materials=4", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
         "--workers", "0", "--no-compile"]


def call(group, prog, args) -> tuple[int, str]:
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = run_cli(group, prog, [str(a) for a in args])
    return code, err.getvalue()


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """Stores and files of every kind that the bad inputs point at."""
    from pipeline.config import SampleConfig
    from svcore.config import build
    from pipeline.config import RenderConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample

    d = tmp_path_factory.mktemp("world")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"),
                                   per_preset=1), workers=0)
    run_render(d / "v.zarr", d / "r.zarr", build(RenderConfig, "tiny", views=1), workers=0)
    g = zarr.open_group(d / "foreign.zarr", mode="w", zarr_format=3)
    g.create_array("x", shape=(2,), dtype="f4")
    zarr.consolidate_metadata(d / "foreign.zarr")
    (d / "partial.zarr.partial").mkdir()
    (d / "exists.zarr").mkdir()
    (d / "bad.yaml").write_text("sample: [unclosed\n")
    (d / "unknown_key.yaml").write_text("sample:\n  per_preset: 2\n  colour: red\n")
    (d / "bool_views.yaml").write_text("render:\n  views: true\n")
    (d / "list_top.yaml").write_text("- sample\n- render\n")
    (d / "quoted_sigma.yaml").write_text('sample:\n  sigma: "0.25"\n')
    (d / "list_section.yaml").write_text("sample:\n  - per_preset\n")
    (d / "train_bool_lr.yaml").write_text("train:\n  optim:\n    lr: true\n")
    (d / "eval_limit.yaml").write_text("eval:\n  limit: -5\n  extra_stores: []\n")
    (d / "notes.png").write_text("this is not an image")
    Image.fromarray(np.zeros((4, 300, 3), np.uint8)).save(d / "thin.png")
    (d / "photo.jpg").write_bytes(b"")
    (d / "empty").mkdir()
    code, err = call(svtrain, "svtrain", ["fit", "--out", d / "run", "--iterations", 1, *SMALL])
    assert code == 0, err
    Image.fromarray(np.full((64, 64, 3), 128, np.uint8)).save(d / "ok.png")
    # checkpoints that carry a pickled object whose unpickling runs code (creates the file d / PWNED)
    evil = {**torch.load(d / "run" / "checkpoint.pt", weights_only=True), "note": RunsCode(d / PWNED)}
    torch.save(evil, d / "evil.pt")
    (d / "evil_run").mkdir()
    torch.save(evil, d / "evil_run" / "checkpoint.pt")
    return d


PWNED = "pwned-by-checkpoint"


class RunsCode:
    """Unpickling an instance calls ``open(path, "w")``: a stand-in for any code a downloaded checkpoint can run."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return open, (self.path, "w")


S, T = (cli, "svgen"), (svtrain, "svtrain")
CASES = [  # (id, command group, args with {d} = the world dir, expected words in the message)
    ("unknown command", S, ["frobnicate"], "No such command"),
    ("unknown option", S, ["sample", "{d}/o.zarr", "--colour", "red"], "No such option"),
    ("unknown material class", S, ["materials", "--class", "cheese"], "unknown material class"),
    ("unknown preset", S, ["sample", "{d}/o.zarr", "--preset", "paint/nope"], "unknown preset"),
    ("size too large", S, ["sample", "{d}/o.zarr", "--size", "2000"], "size must be"),
    ("zero variants", S, ["sample", "{d}/o.zarr", "--per-preset", "0"], "sample.per_preset must be >= 1, got 0"),
    ("negative seed", S, ["sample", "{d}/o.zarr", "--seed", "-1"], "sample.seed must be >= 0"),
    ("seed beyond 64 bits", S, ["sample", "{d}/o.zarr", "--set", "seed=18446744073709551616"], "sample.seed must be <"),
    ("unknown config preset", S, ["sample", "{d}/o.zarr", "--config-preset", "huge"], "'huge' is not one of"),
    ("unknown config preset in --set", S, ["sample", "{d}/o.zarr", "--set", "config_preset=huge"],
     "unknown config preset 'huge'"),
    ("invalid YAML", S, ["sample", "{d}/o.zarr", "--params", "{d}/bad.yaml"], "not valid YAML"),
    ("unknown params key", S, ["sample", "{d}/o.zarr", "--params", "{d}/unknown_key.yaml"],
     "unknown config key 'sample.colour'"),
    ("params: boolean for an integer", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--params", "{d}/bool_views.yaml"],
     "render.views must be an integer, got True"),
    ("params: top level is a list", S, ["sample", "{d}/o.zarr", "--params", "{d}/list_top.yaml"],
     "the top level must be a mapping"),
    ("params: quoted number", S, ["sample", "{d}/o.zarr", "--params", "{d}/quoted_sigma.yaml"],
     "sample.sigma must be a number, got '0.25'"),
    ("params: section is a list", S, ["sample", "{d}/o.zarr", "--params", "{d}/list_section.yaml"],
     "section 'sample' must be a mapping"),
    ("params: boolean for a float (train)", T, ["fit", "--out", "{d}/o.zarr", "--params", "{d}/train_bool_lr.yaml"],
     "train.optim.lr must be a number, got True"),
    ("--set: unknown key", S, ["blend", "{d}/v.zarr", "{d}/o.zarr", "--set", "colour=red"],
     "unknown config key 'blend.colour'"),
    ("--set: not KEY=VALUE", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--set", "views"], "is not KEY=VALUE"),
    ("store URL: misspelt scheme", S, ["sample", "s4://bucket/o.zarr"], "unknown storage scheme 's4'"),
    ("store URL: no store in the bucket", S, ["sample", "s3://bucket"], "names no store inside the bucket"),
    ("store URL: input with a misspelt scheme", S, ["render", "s4://bucket/v.zarr", "{d}/o.zarr"],
     "unknown storage scheme 's4'"),
    ("--storage-option: not KEY=VALUE", S, ["sample", "{d}/o.zarr", "--storage-option", "endpoint_url"],
     "must be KEY=VALUE"),
    ("train store URL: misspelt scheme", T, ["fit", "--out", "{d}/run", "--store", "s4://bucket/r.zarr"],
     "unknown storage scheme 's4'"),
    ("--set: text for a number", S, ["stress", "{d}/o.zarr", "--set", "per_category=many"],
     "stress.per_category must be an integer, got 'many'"),
    ("--set: alpha range reversed", S, ["blend", "{d}/v.zarr", "{d}/o.zarr", "--set", "alpha_low=0.9"],
     "need alpha_low <= alpha_high"),
    ("missing output argument", S, ["sample", "--config-preset", "tiny"], "Missing argument 'OUT'"),
    ("--only-from without imported stores", S, ["sample", "{d}/o.zarr", "--only-from"],
     "only_from needs imported stores"),
    ("--from a renders store", S, ["sample", "{d}/o.zarr", "--from", "{d}/r.zarr"],
     "is a renders store, expected a variants store"),
    ("import: no source", S, ["import", "{d}/o.zarr"], "no source folder given"),
    ("import: category with a slash", S, ["import", "{d}", "{d}/o.zarr", "--category", "a/b"], "must not contain '/'"),
    ("import: quoted size", S, ["import", "{d}", "{d}/o.zarr", "--set", "size='64'"],
     "import.size must be an integer, got '64'"),
    ("scheduler address that is not one", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--scheduler-address", "notaurl"],
     "scheduler address 'notaurl' is not a dask address"),
    ("output exists", S, ["sample", "{d}/exists.zarr", "--config-preset", "tiny"], "already exists"),
    ("missing input store", S, ["blend", "{d}/nothing.zarr", "{d}/o.zarr"], "no store at"),
    ("wrong store kind", S, ["blend", "{d}/r.zarr", "{d}/o.zarr"], "is a renders store, expected a variants store"),
    ("foreign zarr store", S, ["render", "{d}/foreign.zarr", "{d}/o.zarr"], "not an svgen store"),
    ("not a zarr store", S, ["render", "{d}/exists.zarr", "{d}/o.zarr"], "not a zarr v3 store"),
    ("interrupted input store", S, ["render", "{d}/partial.zarr", "{d}/o.zarr"], "incomplete"),
    ("render resolution", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--res", "8"], "res must be"),
    ("zoom range upside down", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--set", "zoom=[2, 1]"],
     "zoom must be a range [min, max]"),
    ("non-square spp for pixel centres", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--spp", "2"], "square spp"),
    ("unknown light model", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--light", "laser"], "Invalid value"),
    ("unreachable scheduler", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--config-preset", "tiny",
                                  "--scheduler-address", "tcp://127.0.0.1:9"], "cannot reach the dask scheduler"),
    ("unknown export format", S, ["export", "{d}/r.zarr", "{d}/o.zarr", "--format", "tiff"], "Invalid value"),
    ("export of a variants store", S, ["export", "{d}/v.zarr", "{d}/o.zarr"], "expected a renders store"),
    ("card: missing store", S, ["card", "{d}/nothing.zarr"], "no store at"),
    ("card: interrupted store", S, ["card", "{d}/partial.zarr"], "incomplete"),
    ("card: the .partial itself", S, ["card", "{d}/partial.zarr.partial"], "unfinished store"),
    ("card: foreign zarr store", S, ["card", "{d}/foreign.zarr"], "not an svgen store"),
    ("card: not a zarr store", S, ["card", "{d}/exists.zarr"], "not a zarr v3 store"),
    ("card --write: missing store", S, ["card", "{d}/nothing.zarr", "--write"], "no store at"),
    ("gallery: interrupted store", S, ["gallery", "{d}/partial.zarr", "--out", "{d}/g"], "incomplete"),
    ("gallery: the .partial itself", S, ["gallery", "{d}/partial.zarr.partial", "--out", "{d}/g"], "unfinished store"),
    ("gallery: foreign zarr store", S, ["gallery", "{d}/v.zarr", "{d}/foreign.zarr", "--out", "{d}/g"],
     "not an svgen store"),
    ("gallery: output exists", S, ["gallery", "{d}/v.zarr", "--out", "{d}/exists.zarr"], "already exists"),
    ("gallery --force: output not a gallery", S, ["gallery", "{d}/v.zarr", "--out", "{d}/exists.zarr", "--force"],
     "is not a gallery"),
    ("gallery: output inside the store", S, ["gallery", "{d}/r.zarr", "--out", "{d}/r.zarr/g"], "lies inside input"),
    ("unknown stress category", S, ["stress", "{d}/o.zarr", "--category", "haunted"], "unknown stress category"),
    ("fit: unknown config key", T, ["fit", "--out", "{d}/o.zarr", "--set", "model.colour=red"], "unknown"),
    ("fit: impossible depth", T, ["fit", "--out", "{d}/o.zarr", "--set", "model.levels=99"], "levels"),
    ("fit: negative normal term", T, ["fit", "--out", "{d}/o.zarr", "--set", "optim.normal_l2=-1"], "normal_l2"),
    ("fit: missing store", T, ["fit", "--out", "{d}/o.zarr", "--store", "{d}/nothing.zarr"], "does not exist"),
    ("eval: missing checkpoint", T, ["eval", "--checkpoint", "{d}/nothing", "--out", "{d}/o.zarr"], "checkpoint"),
    ("eval: stress without store", T, ["eval", "--checkpoint", "{d}/run", "--suite", "stress",
                                       "--out", "{d}/o.zarr"], "needs --store"),
    ("eval: unknown suite", T, ["eval", "--checkpoint", "{d}/run", "--suite", "party", "--out", "{d}/o.zarr"],
     "unknown eval suite"),
    ("predict: not an image", T, ["predict", "{d}/notes.png", "--checkpoint", "{d}/run", "--out", "{d}/o.zarr"],
     "cannot read image"),
    ("predict: wrong shape", T, ["predict", "{d}/thin.png", "--checkpoint", "{d}/run", "--out", "{d}/o.zarr"],
     "need at least"),
    ("predict: empty JPEG", T, ["predict", "{d}/photo.jpg", "--checkpoint", "{d}/run", "--out", "{d}/o.zarr"],
     "cannot read image"),
    # issue 15: resource bounds, seeds, leftovers, outputs inside inputs
    ("huge chunk", S, ["sample", "{d}/o.zarr", "--config-preset", "tiny", "--chunk", "100000000"], "lower the chunk"),
    ("huge render chunk", S,
     ["render", "{d}/v.zarr", "{d}/o.zarr", "--config-preset", "tiny", "--chunk", "10000000"], "lower the chunk"),
    ("astronomical per-preset", S,
     ["sample", "{d}/o.zarr", "--config-preset", "tiny", "--per-preset", "1000000000000"], "make fewer samples"),
    ("astronomical stress count", S, ["stress", "{d}/o.zarr", "--per-category", "1000000000000"],
     "make fewer samples"),
    ("500 workers", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--config-preset", "tiny", "--workers", "500"],
     "--workers 500 needs about"),
    ("seed above 2^64", S, ["sample", "{d}/o.zarr", "--seed", str(2**64)],
     "seed must be < 18446744073709551616"),
    ("render seed above 2^64", S, ["render", "{d}/v.zarr", "{d}/o.zarr", "--seed", str(2**64)],
     "seed must be < 18446744073709551616"),
    ("stress seed above 2^64", S, ["stress", "{d}/o.zarr", "--seed", str(2**64)],
     "seed must be < 18446744073709551616"),
    ("a .partial directory as input", S, ["render", "{d}/partial.zarr.partial", "{d}/o.zarr"],
     "is an unfinished store"),
    ("output inside the input", S, ["render", "{d}/v.zarr", "{d}/v.zarr/out.zarr", "--config-preset", "tiny"],
     "lies inside input"),
    ("blend output inside the input", S, ["blend", "{d}/v.zarr", "{d}/v.zarr/b.zarr"], "lies inside input"),
    ("sample --from: output inside the imported store", S,
     ["sample", "{d}/v.zarr/s.zarr", "--from", "{d}/v.zarr", "--only-from", "--size", "64"], "lies inside input"),
    ("export into the store", S, ["export", "{d}/r.zarr", "{d}/r.zarr/png"], "lies inside input"),
    ("fit: batch larger than the data", T, ["fit", "--out", "{d}/o.zarr", *SMALL, "--batch-size", "1000"],
     "larger than the 4 training samples"),
    ("fit: zero iterations", T, ["fit", "--out", "{d}/o.zarr", *SMALL, "--iterations", "0"], "iterations must be >= 1"),
    ("fit: seed above 2^64", T, ["fit", "--out", "{d}/o.zarr", *SMALL, "--seed", str(2**64)],
     "seed must be < 18446744073709551616"),
    ("fit: leftover .partial store", T, ["fit", "--out", "{d}/o.zarr", *SMALL, "--store", "{d}/partial.zarr"],
     "incomplete"),
    ("fit: output inside the store", T, ["fit", "--out", "{d}/r.zarr/run", *SMALL, "--store", "{d}/r.zarr"],
     "lies inside input"),
    ("eval: output inside the store", T, ["eval", "--checkpoint", "{d}/run", "--store", "{d}/r.zarr",
                                          "--out", "{d}/r.zarr/eval"], "lies inside input"),
    ("predict: unsupported format", T, ["predict", "{d}/bad.yaml", "--checkpoint", "{d}/run", "--out", "{d}/o.zarr"],
     "unsupported format"),
    # devices, precisions, data-parallel width (issue #10)
    ("fit: unknown device", T, ["fit", "--out", "{d}/o.zarr", "--device", "tpu"], "unknown device 'tpu'"),
    *([("fit: absent CUDA", T, ["fit", "--out", "{d}/o.zarr", "--device", "cuda"], "CUDA is not available"),
       ("fit: absent CUDA device index", T, ["fit", "--out", "{d}/o.zarr", "--device", "cuda:1"], "CUDA")]
      if not torch.cuda.is_available() else
      [("fit: more processes than GPUs", T, ["fit", "--out", "{d}/o.zarr", "--device", "cuda", "--nproc", "999"],
        "needs 999 CUDA devices")]),
    *([("fit: absent MPS", T, ["fit", "--out", "{d}/o.zarr", "--device", "mps"], "no Apple GPU")]
      if not torch.backends.mps.is_available() else []),
    ("fit: fp16 on the CPU", T, ["fit", "--out", "{d}/o.zarr", "--device", "cpu", "--precision", "fp16"],
     "fp16 is refused on the CPU"),
    ("fit: unknown device in params", T, ["fit", "--out", "{d}/o.zarr", "--set", "compute.device=tpu"],
     "train.compute.device: unknown device 'tpu'"),
    ("fit: unknown precision", T, ["fit", "--out", "{d}/o.zarr", "--precision", "fp8"],
     "Invalid value for '--precision'"),
    ("fit: unknown precision in params", T, ["fit", "--out", "{d}/o.zarr", "--set", "compute.precision=fp8"],
     "train.compute.precision must be one of"),
    ("fit: zero processes", T, ["fit", "--out", "{d}/o.zarr", "--nproc", "0"], "train.compute.nproc must be >= 1"),
    ("fit: uneven global batch", T, ["fit", "--out", "{d}/o.zarr", "--device", "cpu", "--nproc", "2",
                                     "--global-batch", "5"], "does not split over 2 processes"),
    ("fit: data-parallel on a missing store", T, ["fit", "--out", "{d}/o.zarr", "--device", "cpu", "--nproc", "2",
                                                  "--store", "{d}/nothing.zarr"], "does not exist"),
    ("eval: unknown device", T, ["eval", "--checkpoint", "{d}/run", "--device", "gpu0", "--out", "{d}/o.zarr"],
     "unknown device"),
    ("predict: size off the stride", T, ["predict", "{d}/thin.png", "--checkpoint", "{d}/run", "--size", "100",
                                         "--out", "{d}/o.zarr"], "not a positive multiple of the network's stride 8"),
    ("predict: folder without photos", T, ["predict", "{d}/empty", "--checkpoint", "{d}/run", "--out", "{d}/o.zarr"],
     "holds no PNG, JPEG or EXR photos"),
    ("predict: checkpoint with a pickled object", T, ["predict", "{d}/ok.png", "--checkpoint", "{d}/evil.pt",
                                                      "--out", "{d}/o.zarr"], "refused (loading it could run"),
    ("eval: checkpoint with a pickled object", T, ["eval", "--checkpoint", "{d}/evil.pt", "--out", "{d}/o.zarr"],
     "refused (loading it could run"),
    ("fit --resume: checkpoint with a pickled object", T, ["fit", "--out", "{d}/evil_run", *SMALL],
     "refused (loading it could run"),
    # issue #25 item 7: every bound is in the config field or the option's type, so it is named before any work
    ("size below the generators' range, --print-config", S, ["sample", "--size", "63", "--print-config"],
     "sample.size must be >= 64, got 63"),
    ("stress size above the generators' range", S, ["stress", "{d}/o.zarr", "--set", "size=1025"],
     "stress.size must be <= 1024, got 1025"),
    ("eval: negative --limit", T, ["eval", "--checkpoint", "{d}/run", "--limit", "-5", "--out", "{d}/o.zarr"],
     "Invalid value for '--limit': -5 is not in the range x>=1"),
    ("eval-extra: negative eval.limit", T, ["eval-extra", "--checkpoint", "{d}/run", "--params", "{d}/eval_limit.yaml",
                                           "--out", "{d}/o.zarr"], "eval.limit must be an integer >= 1 (or null), got -5"),
    ("predict: zero --batch", T, ["predict", "{d}/ok.png", "--checkpoint", "{d}/run", "--batch", "0", "--out",
                                 "{d}/o.zarr"], "Invalid value for '--batch': 0 is not in the range x>=1"),
    ("predict: unknown input space", T, ["predict", "{d}/thin.png", "--checkpoint", "{d}/run", "--input-space",
                                         "gamma", "--out", "{d}/o.zarr"], "Invalid value"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_nonzero_and_writes_nothing(case, world):
    _, (group, prog), args, expect = case
    before = sorted(p.name for p in world.iterdir())
    code, err = call(group, prog, [a.format(d=world) for a in args])
    assert code != 0
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"{prog}: ") and expect in err, err
    assert sorted(p.name for p in world.iterdir()) == before, "a failed command left files behind"
    assert list((world / "exists.zarr").iterdir()) == []


def test_a_checkpoint_that_runs_code_is_refused_before_it_runs(world, tmp_path):
    """The checkpoints in the world would create PWNED if unpickled freely (checked on a copy here); through
    svtrain they are refused with exit 2 and the file is never written."""
    torch.load(world / "evil.pt", weights_only=False)  # the guarantee's premise: a free load runs the code
    assert (world / PWNED).exists()
    (world / PWNED).unlink()
    for args in (["predict", world / "ok.png", "--checkpoint", world / "evil.pt", "--out", tmp_path / "p"],
                 ["fit", "--out", world / "evil_run", *SMALL]):
        code, err = call(svtrain, "svtrain", args)
        assert code == 2 and "refused" in err and err.count("\n") == 1, err
        assert not (world / PWNED).exists()


def test_the_table_covers_every_command_and_twenty_kinds():
    assert len(CASES) >= 20
    commands = {(c[1][1], c[2][0]) for c in CASES}
    for cmd in ("materials", "sample", "blend", "render", "export", "stress"):
        assert ("svgen", cmd) in commands
    for cmd in ("fit", "eval", "predict"):
        assert ("svtrain", cmd) in commands
