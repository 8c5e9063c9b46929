"""`svgen gallery`: the page opened in headless Chromium draws every thumbnail where its layout puts it (pixels of
the screenshot against the thumbnail files, thumbnails against the store), the class filter from the URL hash,
seeded sampling of a large store, reading in blocks, and bad input (one line, nothing written)."""
from __future__ import annotations

import json
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import tree_digest
from import_fixtures import ambientcg, bumpy_normals
from pipeline import gallery as G
from pipeline.gallery.page import MAP_ORDER, PER_ROW, Layout
from svcore.config import build

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="headless Chromium is absent (Debian: apt-get install chromium; scripts/setup.sh "
                             "installs it)")
WIDTH, HEIGHT = 1760, 1000  # two columns of 880 px: three cards per row


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """4 variants (2 paint, 2 wood) at 64², their renders (2 views at 64²) and a 2-material imported reference."""
    from pipeline.config import ImportConfig, RenderConfig, SampleConfig
    from pipeline.importer.job import run_import
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample

    d = tmp_path_factory.mktemp("gallery")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"),
                                   per_preset=2), workers=0)
    run_render(d / "v.zarr", d / "r.zarr", build(RenderConfig, "tiny", views=2), workers=0)
    rng = np.random.default_rng(3)
    for name in ("Planks001", "Planks002"):
        ambientcg(d / "src", name, 64, rng, {"GL": bumpy_normals(64, rng)})
    run_import(d / "ref.zarr", build(ImportConfig, sources=(str(d / "src"),), size=64, category="wood"), workers=0)
    return d


@pytest.fixture(scope="module")
def page(stores):
    """The gallery of the renders and variants stores beside the reference, thumbnails at the stores' 64 px."""
    from pipeline.gallery import gallery

    return gallery([stores / "r.zarr", stores / "v.zarr"], stores / "g", [stores / "ref.zarr"])


class _Cards(HTMLParser):
    """Sections (kind, views row or not, reference or not) and their cards (classes, index, hidden or not, img
    sources); the class filter's options (value, text)."""

    def __init__(self):
        super().__init__()
        self.sections: list[dict] = []
        self.options: list[list[str]] = []
        self._in_option = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "section":
            self.sections.append({"views": a["class"] == "with-views", "store": a["data-store"], "cards": []})
        elif tag == "div" and a.get("class") == "card":
            self.sections[-1]["cards"].append({"classes": a["data-classes"].split("|"), "hidden": "hidden" in a,
                                               "index": int(a["data-index"]), "imgs": []})
        elif tag == "img":
            self.sections[-1]["cards"][-1]["imgs"].append(a["src"])
        elif tag == "option":
            self.options.append([a["value"], ""])
        self._in_option = tag == "option"

    def handle_endtag(self, tag):
        self._in_option = False

    def handle_data(self, data):
        if self._in_option:
            self.options[-1][1] += data


def _parse(page: Path | str, options: bool = False):
    """The sections of a page (a file, or its HTML as a str); with ``options``, (sections, options) instead."""
    p = _Cards()
    p.feed(page if isinstance(page, str) else page.read_text())
    return (p.sections, p.options) if options else p.sections


def _shoot(page: Path, out: Path, fragment: str = "") -> np.ndarray:
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--force-device-scale-factor=1", f"--window-size={WIDTH},{HEIGHT}", "--virtual-time-budget=10000",
                    f"--screenshot={out}", page.as_uri() + fragment], check=True, capture_output=True, timeout=180)
    return np.asarray(Image.open(out).convert("RGB"), np.float64)


def _check_drawn(shot: np.ndarray, page: Path, wanted: str = "") -> int:
    """Every thumbnail of every card the filter ``wanted`` keeps is drawn in its layout box, equal to its file;
    where the next card would be, only background. Returns the number of cards checked."""
    layout, sections = Layout(), _parse(page)
    ref = [s for s in sections if s["store"].endswith("ref.zarr")]
    columns = [(0, WIDTH // 2, [s for s in sections if s not in ref]), (WIDTH // 2, WIDTH // 2, ref)]
    checked = 0
    for col_x, col_w, secs in columns:
        y = layout.header
        for s in secs:
            visible = [c for c in s["cards"] if not wanted or wanted in c["classes"]]
            for pos, card in enumerate(visible):
                assert len(card["imgs"]) == PER_ROW + (2 if s["views"] else 0)  # 4 maps (+ the 2 views)
                for k, src in enumerate(card["imgs"]):
                    x0, y0, x1, y1 = layout.thumb_box(col_x, col_w, pos, *divmod(k, PER_ROW), s["views"], y)
                    got = shot[y0:y1, x0:x1]
                    want = np.asarray(Image.open(page.parent / src).convert("RGB"), np.float64)
                    # Chromium draws an untagged PNG at 1:1 unchanged here (0 diff); 2 levels leave room for a
                    # colour-managed build, far below what another thumbnail or a misplaced box gives
                    assert np.abs(got - want).max() <= 2, f"{s['store']} #{card['index']} {src}: not drawn at " \
                                                          f"({x0}, {y0}) (max diff {np.abs(got - want).max():.0f})"
                    assert np.abs(got - 255).mean() > 10, f"{src} is blank (white as the card)"
                checked += 1
            if len(visible) % layout.per_row(col_w):  # the next place in the last row: background only
                x0, y0, x1, y1 = layout.thumb_box(col_x, col_w, len(visible), 0, 0, s["views"], y)
                assert shot[y0:y1, x0:x1].std(axis=(0, 1)).max() == 0, f"{s['store']}: a card beyond {len(visible)}"
            y += layout.section_height(len(visible), col_w, s["views"])
    return checked


@needs_chromium
def test_chromium_draws_every_thumbnail_in_its_box(page, tmp_path):
    shot = _shoot(page, tmp_path / "all.png")
    assert _check_drawn(shot, page) == 4 + 4 + 2


@needs_chromium
def test_class_filter_from_the_url_hash(page, tmp_path):
    sections = _parse(page)
    wood = sum("wood" in c["classes"] for s in sections for c in s["cards"])
    assert 0 < wood < sum(len(s["cards"]) for s in sections)
    shot = _shoot(page, tmp_path / "wood.png", "#class=wood")
    assert _check_drawn(shot, page, "wood") == wood == 2 + 2 + 2


def test_class_filter_options_are_the_cards_classes(page):
    """Every option of the class filter (but "all") has as its value a class the cards carry, and every class a
    card carries has an option: the filter compares the value with the cards' ``data-classes``."""
    sections, options = _parse(page, options=True)
    classes = {c for s in sections for card in s["cards"] for c in card["classes"]}
    assert options[0] == ["", "all classes"] and len(classes) > 1
    assert [v for v, _ in options[1:]] == sorted(classes)
    assert all(v == text for v, text in options[1:])  # the name a user reads is the one the filter uses


@needs_chromium
def test_choosing_a_class_in_the_select_shows_its_cards(page, tmp_path):
    """The ``<select>`` driven in Chromium as a user does: pick the option that reads "wood", fire ``change``;
    the page then shows exactly the cards of class wood (the others ``hidden``), in every section."""
    pick = ("<script>(function(){var s = document.getElementById('cls');"
            "var o = Array.prototype.find.call(s.options, function(o){return o.text.toLowerCase() === 'wood';});"
            "s.value = o.value; s.dispatchEvent(new Event('change'));})();</script></body>")
    driven = tmp_path / "driven.html"  # beside the page's own script, after it: as if the page were open
    driven.write_text(page.read_text().replace("</body>", pick))
    dom = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=10000",
                          "--dump-dom", driven.as_uri()], check=True, capture_output=True, text=True,
                         timeout=180).stdout
    cards = [c for s in _parse(dom) for c in s["cards"]]
    wood = [not c["hidden"] for c in cards if "wood" in c["classes"]]
    other = [not c["hidden"] for c in cards if "wood" not in c["classes"]]
    assert len(wood) == 6 and all(wood), f"{wood.count(False)} of {len(wood)} wood cards hidden"
    assert other and not any(other), "cards of other classes shown"
    assert dom.count(" of class wood</span>") == 3  # each section's count names the class chosen


def test_thumbnails_are_the_maps_and_views_for_display(page, stores):
    """Diffuse/specular/views sRGB-encoded from linear (colour-science), normals (n + 1) / 2, roughness grey."""
    import colour

    from storage.renders_store import RendersReader
    from storage.svbrdf_store import SVBRDFStore

    def png(rel):
        return np.asarray(Image.open(page.parent / rel).convert("RGB"), np.float64) / 255

    r, v = RendersReader(stores / "r.zarr"), SVBRDFStore(stores / "v.zarr")
    for s in _parse(page)[:2]:
        for card in s["cards"]:
            i = card["index"]
            m = r.base_maps(i) if s["views"] else v.maps(i)
            want = {"normal": (m.normal + 1) / 2, "diffuse": colour.cctf_encoding(m.diffuse, function="sRGB"),
                    "roughness": np.repeat(m.roughness, 3, -1),
                    "specular": colour.cctf_encoding(m.specular, function="sRGB")}
            for name, src in zip(MAP_ORDER, card["imgs"]):
                assert np.abs(png(src) - want[name]).max() <= 1 / 255 + 1e-6, (i, name)
            for k, src in enumerate(card["imgs"][PER_ROW:]):
                view = colour.cctf_encoding(r.image(i * r.views + k), function="sRGB")
                assert np.abs(png(src) - view).max() <= 1 / 255 + 1e-6, (i, k)


def test_page_states_stores_and_what_made_each(page, stores):
    text = page.read_text()
    assert "<title>svgen gallery: " in text and "r.zarr" in text.split("</title>")[0]
    assert "reference: " in text.split("</title>")[0] and "ref.zarr" in text.split("</title>")[0]
    assert "http://" not in text and "https://" not in text  # no external assets: the page works offline
    assert "orange_peel=" in text and "planks=" in text  # the variants' parameters
    assert "source: Planks001" in text  # the reference's source material
    meta = json.loads((page.parent / G.MARKER).read_text())
    assert [s["n"] for s in meta["stores"]] == [4, 4, 2] and not any(s["sampled"] for s in meta["stores"])


def test_a_store_above_max_is_a_seeded_sample_listed_on_the_page(stores, svgen_cli, tmp_path):
    code, out = svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "g", "--max", "3", "--seed", "7")
    assert code == 0, out
    meta = json.loads((tmp_path / "g" / G.MARKER).read_text())["stores"][0]
    assert meta["sampled"] and meta["indices"] == G.pick(4, 3, 7)[0]
    sec = _parse(tmp_path / "g" / "index.html")[0]
    assert [c["index"] for c in sec["cards"]] == meta["indices"]
    assert "a sample of 3 of 4 SVBRDFs (--max 3, --seed 7" in (tmp_path / "g" / "index.html").read_text()


def test_pick_on_a_store_of_20000():
    a, sampled = G.pick(20000, 200, 0)
    assert sampled and len(a) == len(set(a)) == 200 and a == sorted(a) and 0 <= a[0] and a[-1] < 20000
    assert G.pick(20000, 200, 0)[0] == a and G.pick(20000, 200, 1)[0] != a
    assert G.pick(5, 200, 0) == ([0, 1, 2, 3, 4], False)


def test_reading_in_blocks_changes_no_byte(stores, tmp_path, monkeypatch):
    assert list(G.blocks([0, 1, 2, 5, 6, 9], 2)) == [[0, 1], [2], [5, 6], [9]]
    assert list(G.blocks([0, 1, 2, 5, 6, 9], 4, 2)) == [[0, 1, 2], [5, 6], [9]]
    assert list(G.blocks([0, 1, 2, 5, 6, 9], 10, 2)) == [[0, 1, 2, 5, 6, 9]]
    assert list(G.blocks([0, 1, 2, 5, 6, 9], 10, 1)) == [[0, 1, 2], [5, 6], [9]]
    G.gallery([stores / "r.zarr"], tmp_path / "big", max_n=3, seed=6)  # indices with a gap bridged in one read
    assert G.pick(4, 3, 6)[0] == [0, 2, 3]
    monkeypatch.setattr(G, "BLOCK_BYTES", 1)  # one SVBRDF per read
    G.gallery([stores / "r.zarr"], tmp_path / "one", max_n=3, seed=6)
    big, one = tree_digest(tmp_path / "big" / "thumbs"), tree_digest(tmp_path / "one" / "thumbs")
    assert big == one and len(big) == 3 * (4 + 2)


def _one_line(code, out, expect):
    assert code == 2 and out.count("\n") == 1 and out.startswith("svgen: error: ") and expect in out, out


def test_unfinished_store_one_line_nothing_written(stores, svgen_cli, tmp_path):
    (tmp_path / "x.zarr.partial").mkdir()  # an interrupted run's leftover
    _one_line(*svgen_cli("gallery", tmp_path / "x.zarr", "--out", tmp_path / "g"), "incomplete")
    _one_line(*svgen_cli("gallery", tmp_path / "x.zarr.partial", "--out", tmp_path / "g"), "unfinished store")
    shutil.copytree(stores / "v.zarr", tmp_path / "holed.zarr")
    shard = next(p for p in sorted((tmp_path / "holed.zarr" / "diffuse" / "c").rglob("*")) if p.is_file())
    shard.unlink()
    _one_line(*svgen_cli("gallery", stores / "v.zarr", tmp_path / "holed.zarr", "--out", tmp_path / "g"), "holed.zarr")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["holed.zarr", "x.zarr.partial"]


def test_existing_output_refused_unless_force_on_a_gallery(stores, svgen_cli, tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    _one_line(*svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "mine"), "already exists")
    _one_line(*svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "mine", "--force"), "is not a gallery")
    assert [p.name for p in (tmp_path / "mine").iterdir()] == ["notes.txt"]
    assert svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "g")[0] == 0
    _one_line(*svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "g"), "already exists")
    code, out = svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "g", "--max", "2", "--force")
    assert code == 0, out
    assert json.loads((tmp_path / "g" / G.MARKER).read_text())["max"] == 2
    assert not (tmp_path / "g.partial").exists()
    _one_line(*svgen_cli("gallery", stores / "v.zarr", "--out", stores / "v.zarr" / "g"), "lies inside input")


def test_an_interrupted_gallery_is_redone_a_foreign_partial_kept(stores, svgen_cli, tmp_path):
    (tmp_path / "g.partial" / "thumbs").mkdir(parents=True)  # as a killed run leaves it
    (tmp_path / "g.partial" / G.PARTIAL_MARKER).touch()
    assert svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "g")[0] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g"] and not (tmp_path / "g" / G.PARTIAL_MARKER).exists()
    (tmp_path / "h.partial").mkdir()
    (tmp_path / "h.partial" / "notes.txt").write_text("keep")
    _one_line(*svgen_cli("gallery", stores / "v.zarr", "--out", tmp_path / "h"), "is not an interrupted gallery")
    assert [p.name for p in (tmp_path / "h.partial").iterdir()] == ["notes.txt"]
