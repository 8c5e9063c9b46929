"""The gallery's HTML page: one self-contained file (inline CSS and plain JS, no external assets) that shows
the thumbnails :mod:`pipeline.gallery` wrote beside it.

The layout is fixed in pixels (:class:`Layout`): every card has the same size and every thumbnail the same place
in its card, so a screenshot can be checked box by box (tests/test_gallery.py computes the boxes from the same
:class:`Layout`). Stores are laid out in two columns when a reference is given (procedural left, reference
right), one column otherwise; each store is one section.

The class filter is a ``<select>`` that writes the URL hash (``#class=wood``); the hash is applied on load and
on every change, so a filtered view can be bookmarked or opened directly.
"""
from __future__ import annotations

import html
import json
from dataclasses import dataclass, field

#: map order on a card (left to right)
MAP_ORDER = ("normal", "diffuse", "roughness", "specular")
#: thumbnails per row (the maps row; the views row holds at most as many)
PER_ROW = len(MAP_ORDER)


@dataclass(frozen=True)
class Layout:
    """Pixel sizes of the page (CSS px; a screenshot at device scale 1 has the same numbers).

    Attributes:
        thumb: thumbnail side.
        gap: space between thumbnails and the card's padding.
        card_gap: space between cards.
        pad: a section's side padding.
        header: the page header's height.
        section_head: a section title block's height.
        text: a card's text block height (the same in cards with and without a views row).
        details: the height of a section's closed "indices shown" line.
    """

    thumb: int = 64
    gap: int = 4
    card_gap: int = 8
    pad: int = 8
    header: int = 76
    section_head: int = 44
    text: int = 64
    details: int = 20

    @property
    def card_w(self) -> int:
        return PER_ROW * self.thumb + (PER_ROW + 1) * self.gap

    def card_h(self, views: bool = True) -> int:
        """A card's height: with a views row (renders stores) or without."""
        return (2 if views else 1) * self.thumb + self.text + (4 if views else 3) * self.gap

    def per_row(self, column_width: int) -> int:
        """Cards per row in a column ``column_width`` px wide."""
        return max(1, (column_width - 2 * self.pad + self.card_gap) // (self.card_w + self.card_gap))

    def section_height(self, cards: int, column_width: int, views: bool) -> int:
        """Height of a section with ``cards`` visible cards (its indices line closed)."""
        rows = -(-cards // self.per_row(column_width))
        body = rows * self.card_h(views) + (rows - 1) * self.card_gap if rows else 0
        return self.section_head + body + self.pad + self.details

    def thumb_box(self, column_x: int, column_width: int, card: int, row: int, slot: int, views: bool = True,
                  section_y: int | None = None) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) of a thumbnail in page px (x1, y1 exclusive).

        Args:
            column_x, column_width: the column holding the section.
            card: the card's position among the section's visible cards.
            row: 0: maps row, 1: views row.
            slot: position in the row (MAP_ORDER for maps).
            views: whether the section's cards have a views row (their height).
            section_y: top of the section (default: the first section of a column, right under the header).
        """
        y = self.header if section_y is None else section_y
        r, c = divmod(card, self.per_row(column_width))
        x0 = column_x + self.pad + c * (self.card_w + self.card_gap) + self.gap + slot * (self.thumb + self.gap)
        y0 = y + self.section_head + r * (self.card_h(views) + self.card_gap) + self.gap + row * (self.thumb + self.gap)
        return x0, y0, x0 + self.thumb, y0 + self.thumb


@dataclass
class Card:
    """One SVBRDF on the page.

    Attributes:
        index: its index in the store.
        title: preset(s) or source material name.
        classes: the classes the filter knows it by.
        lines: further facts (parameters, source, seed), one per line.
        maps: map name -> thumbnail path relative to the page.
        views: thumbnail paths of its views (renders stores), relative to the page.
    """

    index: int
    title: str
    classes: list[str]
    lines: list[str]
    maps: dict[str, str]
    views: list[str] = field(default_factory=list)


@dataclass
class Section:
    """One store on the page.

    Attributes:
        name: the store's path as given.
        kind: variants, blends, stress or renders.
        n: SVBRDFs in the store.
        reference: a --reference store (right column).
        indices: the shown SVBRDFs' indices, ascending.
        sampled: whether ``indices`` is a seeded sample (the store holds more than --max).
        cards: one per index.
    """

    name: str
    kind: str
    n: int
    reference: bool
    indices: list[int]
    sampled: bool
    cards: list[Card]


CSS = """
html,body{margin:0;padding:0;background:#e8e8e8;color:#222;font:12px/16px sans-serif}
header{height:{header}px;box-sizing:border-box;padding:6px 8px;overflow:hidden;background:#d4d4d4}
header h1{margin:0;font-size:15px;line-height:20px;white-space:nowrap;overflow:hidden;text-overflow:ellipsis}
header p{margin:2px 0;white-space:nowrap;overflow:hidden;text-overflow:ellipsis}
#cols{display:flex;align-items:flex-start}
.col{flex:1 1 0;min-width:0}
.col.ref{background:#dfe6ee}
section>.head{height:{section_head}px;box-sizing:border-box;padding:4px {pad}px;overflow:hidden;white-space:nowrap}
section>.head h2{margin:0;font-size:13px;line-height:18px;overflow:hidden;text-overflow:ellipsis}
.cards{display:flex;flex-wrap:wrap;gap:{card_gap}px;padding:0 {pad}px {pad}px {pad}px}
.card{width:{card_w}px;height:{card_h}px;box-sizing:border-box;padding:{gap}px;background:#fff;
  display:flex;flex-direction:column;gap:{gap}px;overflow:hidden}
.maps-only .card{height:{card_h_maps}px}
.card[hidden]{display:none!important}
.row{display:flex;gap:{gap}px;height:{thumb}px;flex:none}
.row img{width:{thumb}px;height:{thumb}px;display:block;flex:none}
.txt{flex:1 1 0;min-height:0;overflow:auto;font-size:11px;line-height:14px;word-break:break-word}
.txt b{font-size:12px}
details{padding:0 {pad}px;font-size:11px;line-height:{details}px}
details:not([open]){height:{details}px;overflow:hidden}
"""

JS = """
(function(){
  var sel = document.getElementById('cls');
  function wanted(){
    var m = /(?:^#|&)class=([^&]*)/.exec(location.hash);
    return m ? decodeURIComponent(m[1]) : '';
  }
  function apply(c){
    document.querySelectorAll('section').forEach(function(s){
      var shown = 0, cards = s.querySelectorAll('.card');
      cards.forEach(function(e){
        var ok = !c || e.getAttribute('data-classes').split('|').indexOf(c) >= 0;
        e.hidden = !ok; if (ok) shown++;
      });
      s.querySelector('.shown').textContent = shown + ' of ' + cards.length + ' cards' + (c ? ' of class ' + c : '');
    });
    sel.value = c;
  }
  sel.addEventListener('change', function(){
    location.hash = sel.value ? 'class=' + encodeURIComponent(sel.value) : '';
  });
  window.addEventListener('hashchange', function(){ apply(wanted()); });
  apply(wanted());
})();
"""


def _e(s) -> str:
    return html.escape(str(s), quote=True)


def _card(c: Card, layout: Layout) -> str:
    maps = "".join(f'<img src="{_e(c.maps[m])}" alt="{m}" title="{m}" width="{layout.thumb}" '
                   f'height="{layout.thumb}" loading="lazy">' for m in MAP_ORDER)
    rows = [f'<div class="row maps">{maps}</div>']
    if c.views:
        views = "".join(f'<img src="{_e(v)}" alt="view {k}" title="view {k} (flash render, sRGB)" '
                        f'width="{layout.thumb}" height="{layout.thumb}" loading="lazy">'
                        for k, v in enumerate(c.views))
        rows.append(f'<div class="row views">{views}</div>')
    lines = "".join(f"<br>{_e(x)}" for x in c.lines)
    text = f'<div class="txt"><b>#{c.index} {_e(c.title)}</b><br>class: {_e(", ".join(c.classes))}{lines}</div>'
    return (f'<div class="card" data-classes="{_e("|".join(c.classes))}" data-index="{c.index}">'
            + "".join(rows) + text + "</div>")


def _section(s: Section, seed: int, max_n: int, layout: Layout) -> str:
    how = (f"a sample of {len(s.indices)} of {s.n} SVBRDFs (--max {max_n}, --seed {seed}; indices below)"
           if s.sampled else f"all {s.n} SVBRDFs")
    role = "reference " if s.reference else ""
    head = (f'<div class="head"><h2>{_e(s.name)}</h2>{role}{_e(s.kind)} store: {how}; '
            f'<span class="shown"></span></div>')
    cards = "".join(_card(c, layout) for c in s.cards)
    idx = ", ".join(map(str, s.indices))
    views = any(c.views for c in s.cards)
    return (f'<section class="{"with-views" if views else "maps-only"}" data-store="{_e(s.name)}" '
            f'data-kind="{_e(s.kind)}">{head}<div class="cards">{cards}</div>'
            f"<details><summary>indices shown ({len(s.indices)})</summary>{idx}</details></section>")


def page(sections: list[Section], seed: int, max_n: int, layout: Layout, meta: dict) -> str:
    """The whole HTML page.

    Args:
        sections: stores in command-line order (references after the others).
        seed, max_n: the sampling settings (stated on the page).
        layout: pixel sizes.
        meta: what the page records about itself (stores, indices, seed; gallery.json holds the same), embedded
            as JSON for scripts.
    """
    procedural = [s for s in sections if not s.reference]
    reference = [s for s in sections if s.reference]
    title = "svgen gallery: " + ", ".join(s.name for s in procedural)
    if reference:
        title += " | reference: " + ", ".join(s.name for s in reference)
    classes = sorted({c for s in sections for card in s.cards for c in card.classes})
    options = '<option value="">all classes</option>' + "".join(
        f'<option value="{_e(c)}">{_e(c)}</option>' for c in classes)
    css = CSS
    for k, v in {"header": layout.header, "section_head": layout.section_head, "pad": layout.pad,
                 "card_gap": layout.card_gap, "card_w": layout.card_w, "card_h": layout.card_h(True),
                 "card_h_maps": layout.card_h(False), "gap": layout.gap, "details": layout.details,
                 "thumb": layout.thumb}.items():
        css = css.replace("{" + k + "}", str(v))
    cols = [f'<div class="col">{"".join(_section(s, seed, max_n, layout) for s in procedural)}</div>']
    if reference:
        cols.append(f'<div class="col ref">{"".join(_section(s, seed, max_n, layout) for s in reference)}</div>')
    # JSON inside <script>: "</" must not end the element early
    data = json.dumps(meta, sort_keys=True).replace("</", "<\\/")
    return (
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{_e(title)}</title><style>{css}</style></head><body>"
        f"<header><h1>{_e(title)}</h1>"
        f'<p><label>filter by class: <select id="cls">{options}</select></label> '
        "(or open the page with #class=NAME)</p>"
        "<p>each card: maps normal ((n+1)/2), diffuse (sRGB), roughness (grey), specular (sRGB); "
        "then up to four flash views (sRGB) for renders stores</p></header>"
        f'<div id="cols">{"".join(cols)}</div>'
        f'<script type="application/json" id="gallery-data">{data}</script>'
        f"<script>{JS}</script></body></html>\n")
