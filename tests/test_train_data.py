"""Dataset: deterministic batches, augmentation that keeps renders and normals consistent, split."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from train.data import PairDataset, augment, make_loader, split_by_source
from train.render import flash_render
from train.synthetic import SyntheticSource


@pytest.fixture(scope="module")
def src():
    return SyntheticSource(24, 40, 6, seed=1)


def _render(maps_hwc, light=(0.0, 0.0)):
    t = torch.from_numpy(np.ascontiguousarray(maps_hwc)).permute(2, 0, 1)[None]
    return flash_render(t, torch.tensor(light), clip=False)[0].permute(1, 2, 0).numpy()


@pytest.mark.parametrize("seed", range(8))
def test_augment_commutes_with_rendering(src, seed):
    """A centred flash is symmetric under the plane's rotations/flips, so render(aug(maps)) == aug(render(maps)):
    this fails if normals are not rotated with the image (or rotated the wrong way)."""
    maps = src.packed(3)
    img = _render(maps)
    a_img, a_maps = augment(img, maps, np.random.default_rng(seed), crop=40)
    np.testing.assert_allclose(_render(a_maps), a_img, atol=1e-5)


def test_augment_without_normal_fix_would_fail(src):
    maps = src.packed(3)
    img = _render(maps)
    rot_img, rot_maps = np.rot90(img, 1), np.rot90(maps, 1).copy()  # rotation without turning normals
    assert np.abs(_render(rot_maps) - rot_img).max() > 1e-3


def test_crop_keeps_alignment(src):
    img, maps = augment(src.image(0), src.packed(0), np.random.default_rng(0), crop=32, flips=False)
    assert img.shape == (32, 32, 3) and maps.shape == (32, 32, 10)
    # the crop is a window of the full render at the same offset
    full = src.image(0)
    hits = [(y, x) for y in range(9) for x in range(9) if np.array_equal(full[y:y + 32, x:x + 32], img)]
    assert len(hits) == 1
    y, x = hits[0]
    np.testing.assert_array_equal(src.packed(0)[y:y + 32, x:x + 32], maps)


def test_centre_crops_are_the_evaluation_window_with_the_same_flips(src):
    """data.crop_at=centre: every training crop is the view's centre window (the one evaluation takes), and the flips
    of each position are those a random-crop run draws (the offsets are drawn, then not used)."""
    tr, _ = split_by_source(src, 0.3, 0)
    centre = PairDataset(src, tr, 24, seed=5, flips=False, centre=True)
    for pos in range(6):
        i = centre.index_of(pos)
        img, maps = centre[pos]
        want_img, want_maps = PairDataset(src, [i], 24, train=False)[0]
        assert torch.equal(img, want_img) and torch.equal(maps, want_maps)
    rand = PairDataset(src, tr, 24, seed=5, flips=False)
    assert any(not torch.equal(rand[p][0], centre[p][0]) for p in range(6))  # random crops do move
    flipped_c, flipped_r = PairDataset(src, tr, 40, seed=5, centre=True), PairDataset(src, tr, 40, seed=5)
    for pos in range(6):  # at crop = the full view both read the whole view: the same flips give the same item
        assert torch.equal(flipped_c[pos][1], flipped_r[pos][1])


def test_batches_pure_function_of_step_and_workers(src):
    tr, _ = split_by_source(src, 0.3, 0)
    ds = PairDataset(src, tr, 32, seed=5)
    a = [b[0] for b in make_loader(ds, 4, 0, 6, workers=0)]
    b = [b[0] for b in make_loader(ds, 4, 0, 6, workers=2)]
    c = [b[0] for b in make_loader(ds, 4, 3, 6, workers=0)]  # resumed at step 3
    for x, y in zip(a, b):
        assert torch.equal(x, y)
    for x, y in zip(a[3:], c):
        assert torch.equal(x, y)
    assert not torch.equal(a[0], a[1])


def test_epoch_covers_every_training_index(src):
    tr, _ = split_by_source(src, 0.3, 0)
    ds = PairDataset(src, tr, 32, seed=5)
    assert sorted(ds.index_of(p) for p in range(len(tr))) == sorted(tr.tolist())


def test_split_by_source_disjoint_presets(src):
    tr, te = split_by_source(src, 0.34, 0)
    names = lambda idx: {src.source(int(i))["presets"][0] for i in idx}  # noqa: E731
    assert len(tr) and len(te)
    assert not names(tr) & names(te)
    assert len(tr) + len(te) == len(src)


class _Blends:
    """Two-source samples: a blend mixing a held-out and a training preset must be dropped."""

    def __init__(self):
        self.src = [("a",), ("b",), ("c",), ("d",), ("a", "b"), ("a", "c"), ("c", "d")] * 3

    def __len__(self):
        return len(self.src)

    def source(self, i):
        return list(self.src[i])


def test_split_drops_mixed_blends():
    s = _Blends()
    tr, te = split_by_source(s, 0.5, 0)
    test_names = {n for i in te for n in s.src[i]}
    train_names = {n for i in tr for n in s.src[i]}
    assert not test_names & train_names
    assert len(tr) + len(te) < len(s)
