"""Pictures of the association graph: a PNG and a self-contained interactive HTML page.

Layout: x is the frame, one lane per tracklet (lanes grouped by output
track, then by start frame), a bar per tracklet from its first to its last
frame. Links the solver took are solid green; candidates it could have taken
are thin grey; rejected candidates are dashed and coloured by the first rule
that rejected them. So that the picture stays readable, besides the taken
links only the most similar allowed and the most similar rejected candidate
leaving each tracklet are drawn (the GraphML/JSON files hold all of them). The HTML page draws the same picture as SVG; clicking (or
hovering) a bar or a link shows its numbers, and for a tracklet the crops of
its first and last box; check boxes hide links by the rule that rejected them.
It needs no network access.
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

import networkx as nx
import numpy as np

from sotmot.boxes import pixel_bounds
from sotmot.association.rules import CONSTRAINTS, RULES
from sotmot.inspect.explain import json_scalar
from sotmot.io import write_bytes_atomic, write_text_atomic

#: Colours as (B, G, R) for OpenCV and hex for SVG.
REJECT_COLOURS = {rule.name: rule.colour for rule in RULES}  # BGR, one per rule of the constraint table
TAKEN = (40, 160, 40)
ALLOWED = (170, 170, 170)
LANE = 16
MARGIN_LEFT, MARGIN_TOP, MARGIN_RIGHT, LEGEND = 100, 40, 20, 80


def _hex(bgr: tuple[int, int, int]) -> str:
    b, g, r = bgr
    return f"#{r:02x}{g:02x}{b:02x}"


def layout(graph: nx.DiGraph, width: int = 1400) -> tuple[dict, dict]:
    """Lane and pixel geometry: ``(node -> (x1, x2, y), picture size and frame scale)``."""
    nodes = sorted(graph.nodes, key=lambda n: (graph.nodes[n].get("track", -1) < 0, graph.nodes[n].get("track", -1),
                                               graph.nodes[n]["start"], n))
    if nodes:
        f0 = min(graph.nodes[n]["start"] for n in nodes)
        f1 = max(graph.nodes[n]["end"] for n in nodes)
    else:
        f0, f1 = 1, 2
    scale = (width - MARGIN_LEFT - MARGIN_RIGHT) / max(1, f1 - f0 + 1)
    pos = {}
    for lane, n in enumerate(nodes):
        d = graph.nodes[n]
        y = MARGIN_TOP + lane * LANE + LANE // 2
        pos[n] = (MARGIN_LEFT + (d["start"] - f0) * scale, MARGIN_LEFT + (d["end"] - f0 + 1) * scale, y)
    height = MARGIN_TOP + max(1, len(nodes)) * LANE + LEGEND
    return pos, {"width": width, "height": height, "f0": f0, "f1": f1, "scale": scale}


#: Which candidate links the picture and the page draw (:func:`shown_edges`), in words.
SHOWN = "every link taken, and per tracklet its most similar allowed and rejected candidates"


def lane_label(n, data: dict) -> str:
    """A lane's label: the tracklet id, then the id of its track in the results file (or why it has none)."""
    track = data.get("track", -1)
    if track < 0:
        return f"{n} short"
    return f"{n} T{track}" if data.get("in_results", True) else f"{n} T{track} dropped"


def shown_note(graph: nx.DiGraph) -> str:
    """How many of the graph's candidate links are drawn, and which."""
    return f"drawn: {len(shown_edges(graph))} of {graph.number_of_edges()} candidate links ({SHOWN})"


def shown_edges(graph: nx.DiGraph, per_node: int = 1) -> list[tuple]:
    """Edges to draw: every taken one, and per tracklet its ``per_node`` most similar outgoing
    candidates that were allowed but not taken, and as many rejected ones."""
    keep = set()
    for n in graph.nodes:
        out = [(d["affinity"], u, v, bool(d.get("allowed"))) for u, v, d in graph.out_edges(n, data=True)
               if not d.get("taken")]
        for allowed in (True, False):
            best = sorted((e for e in out if e[3] == allowed), reverse=True)[:per_node]
            keep.update((u, v) for _, u, v, _ in best)
    return [(u, v, d) for u, v, d in sorted(graph.edges(data=True)) if d.get("taken") or (u, v) in keep]


def edge_kind(data: dict) -> str:
    """``"taken"``, ``"allowed"`` or the first constraint that rejected the link."""
    if data.get("taken"):
        return "taken"
    if data.get("allowed"):
        return "allowed"
    return data["failed"].split(",")[0]


def _edge_points(pos: dict, u, v) -> tuple[tuple[float, float], tuple[float, float]]:
    return (pos[u][1], pos[u][2]), (pos[v][0], pos[v][2])


def draw_png(graph: nx.DiGraph, path: str | Path, width: int = 1400) -> Path:
    """Write the picture as a PNG (atomically)."""
    path = Path(path)
    write_bytes_atomic(path, png_bytes(graph, width))
    return path


def png_bytes(graph: nx.DiGraph, width: int = 1400) -> bytes:
    """The picture, PNG-encoded."""
    import cv2

    pos, geo = layout(graph, width)
    img = np.full((geo["height"], geo["width"], 3), 255, np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX
    step = max(1, int(round(10 ** math.floor(math.log10(max(1, geo["f1"] - geo["f0"]))) / 2)))
    for f in range(geo["f0"] - geo["f0"] % step, geo["f1"] + 1, step):
        if f < geo["f0"]:
            continue
        x = int(MARGIN_LEFT + (f - geo["f0"]) * geo["scale"])
        cv2.line(img, (x, MARGIN_TOP - 6), (x, geo["height"] - LEGEND), (235, 235, 235), 1)
        cv2.putText(img, str(f), (x - 8, MARGIN_TOP - 10), font, 0.35, (90, 90, 90), 1, cv2.LINE_AA)
    order = sorted(shown_edges(graph), key=lambda e: {"taken": 2, "allowed": 1}.get(edge_kind(e[2]), 0))
    for u, v, data in order:
        (x1, y1), (x2, y2) = _edge_points(pos, u, v)
        kind = edge_kind(data)
        p1, p2 = (int(x1), int(y1)), (int(x2), int(y2))
        if kind == "taken":
            cv2.line(img, p1, p2, TAKEN, 2, cv2.LINE_AA)
        elif kind == "allowed":
            cv2.line(img, p1, p2, ALLOWED, 1, cv2.LINE_AA)
        else:
            n = max(2, int(math.hypot(x2 - x1, y2 - y1) / 6))
            xs, ys = np.linspace(x1, x2, n), np.linspace(y1, y2, n)
            for k in range(0, n - 1, 2):
                cv2.line(img, (int(xs[k]), int(ys[k])), (int(xs[k + 1]), int(ys[k + 1])),
                         REJECT_COLOURS[kind], 1, cv2.LINE_AA)
    for n, (x1, x2, y) in pos.items():
        d = graph.nodes[n]
        col = (60, 60, 60) if d.get("sot_boxes", 0) == 0 else (120, 60, 0)
        cv2.rectangle(img, (int(x1), y - 4), (max(int(x1) + 2, int(x2)), y + 4), col, -1)
        tracklet, _, track = lane_label(n, d).partition(" ")
        cv2.putText(img, tracklet, (4, y + 4), font, 0.35, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.putText(img, track, (30, y + 4), font, 0.3, (120, 120, 120), 1, cv2.LINE_AA)
    y = geo["height"] - LEGEND + 20
    items = [("taken", TAKEN), ("allowed, not taken", ALLOWED)] + \
        [(f"rejected: {c}", REJECT_COLOURS[c]) for c in CONSTRAINTS]
    x = MARGIN_LEFT
    for label, col in items:
        cv2.line(img, (x, y), (x + 24, y), col, 2)
        cv2.putText(img, label, (x + 30, y + 4), font, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        x += 40 + 8 * len(label)
    cv2.putText(img, "x: frame; one lane per tracklet (its id, then its track T as in the results file; dropped: "
                "not in the results; short: in no track); blue bars hold SOT boxes",
                (MARGIN_LEFT, y + 28), font, 0.4, (90, 90, 90), 1, cv2.LINE_AA)
    cv2.putText(img, shown_note(graph), (MARGIN_LEFT, y + 48), font, 0.4, (90, 90, 90), 1, cv2.LINE_AA)
    ok, data = cv2.imencode(".png", img)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return data.tobytes()


def write_html(graph: nx.DiGraph, path: str | Path, crops: dict | None = None, title: str = "association graph",
               width: int = 1400) -> Path:
    """Write :func:`html_page` to ``path`` (atomically)."""
    path = Path(path)
    write_text_atomic(path, html_page(graph, crops, title, width))
    return path


def html_page(graph: nx.DiGraph, crops: dict | None = None, title: str = "association graph",
              width: int = 1400) -> str:
    """The interactive page: SVG picture, details panel, rejection filters, all inline.

    ``crops`` maps a tracklet id to ``(first_jpeg_bytes, last_jpeg_bytes)``.
    """
    pos, geo = layout(graph, width)
    crops = crops or {}
    parts = [f'<svg id="graph" xmlns="http://www.w3.org/2000/svg" width="{geo["width"]}" '
             f'height="{geo["height"]}" viewBox="0 0 {geo["width"]} {geo["height"]}">']
    for k, (u, v, data) in enumerate(shown_edges(graph)):
        (x1, y1), (x2, y2) = _edge_points(pos, u, v)
        kind = edge_kind(data)
        colour = _hex(TAKEN if kind == "taken" else ALLOWED if kind == "allowed" else REJECT_COLOURS[kind])
        dash = "" if kind in ("taken", "allowed") else ' stroke-dasharray="5,4"'
        width_px = 3 if kind == "taken" else 1.5
        info = {"link": f"{u} -> {v}", **{key: json_scalar(val, 4) for key, val in data.items()}}
        parts.append(f'<line class="edge {kind}" id="edge-{k}" data-info="{html.escape(json.dumps(info))}" '
                     f'x1="{x1:.1f}" y1="{y1}" x2="{x2:.1f}" y2="{y2}" stroke="{colour}" '
                     f'stroke-width="{width_px}"{dash}/>')
    for n, (x1, x2, y) in pos.items():
        d = graph.nodes[n]
        info = {"tracklet": n, **{key: json_scalar(val, 4) for key, val in d.items()}}
        first, last = crops.get(n, (None, None))
        if first is not None:
            info["crop_first"] = "data:image/jpeg;base64," + base64.b64encode(first).decode()
            info["crop_last"] = "data:image/jpeg;base64," + base64.b64encode(last).decode()
        fill = "#3c3c3c" if d.get("sot_boxes", 0) == 0 else "#003c78"
        parts.append(f'<rect class="node" id="node-{n}" data-info="{html.escape(json.dumps(info))}" '
                     f'x="{x1:.1f}" y="{y - 4}" width="{max(2.0, x2 - x1):.1f}" height="8" fill="{fill}"/>')
        parts.append(f'<text x="4" y="{y + 4}" font-size="10">{html.escape(lane_label(n, d))}</text>')
    parts.append("</svg>")
    compensated = ("<p>The camera moved: every IoU, velocity and gap here was measured after camera-motion "
                   "compensation, in frame 1's pixels.</p>" if graph.graph.get("compensated") else "")
    filters = "".join(f'<label><input type="checkbox" class="filter" value="{c}" checked> rejected by {c}'
                      f' <span style="color:{_hex(REJECT_COLOURS[c])}">&#9473;&#9473;</span></label> '
                      for c in CONSTRAINTS)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: sans-serif; margin: 12px; }}
#panel {{ position: fixed; right: 12px; top: 12px; width: 330px; background: #fafafa; border: 1px solid #ccc;
          padding: 8px; font-size: 12px; max-height: 90vh; overflow: auto; }}
#panel img {{ height: 96px; margin-right: 6px; border: 1px solid #999; }}
.edge {{ cursor: pointer; }} .node {{ cursor: pointer; }}
.edge:hover {{ stroke-width: 4; }}
td {{ padding: 1px 6px; }}
</style></head><body>
<h2>{html.escape(title)}</h2>
<p>x: frame; one lane per tracklet (its id, then its track T as in the results file; "dropped": a track
confirmation dropped, in no results file; "short": a trajectory too short to become a track). Green: links
the solver took; grey: allowed, not taken; dashed: rejected, coloured by the first rule that failed. Dark
blue bars hold boxes from the SOT step. Click a bar or a link for its numbers.</p>
<p>{html.escape(shown_note(graph))}.</p>{compensated}
<div id="filters">{filters}</div>
{''.join(parts)}
<div id="panel"><b>Click a tracklet or a link.</b><div id="details"></div></div>
<script>
function show(el) {{
  const info = JSON.parse(el.getAttribute('data-info'));
  let rows = '';
  for (const [k, v] of Object.entries(info)) {{
    if (k.startsWith('crop_')) continue;
    rows += '<tr><td>' + k + '</td><td class="v-' + k + '">' + v + '</td></tr>';
  }}
  let imgs = '';
  if (info.crop_first) imgs = '<div><img alt="first box" src="' + info.crop_first + '"><img alt="last box" src="'
                              + info.crop_last + '"></div>';
  document.getElementById('details').innerHTML = imgs + '<table>' + rows + '</table>';
}}
document.querySelectorAll('.edge, .node').forEach(el => {{
  el.addEventListener('click', () => show(el));
  el.addEventListener('mouseenter', () => show(el));
}});
// page.html#click=edge-3 (or node-12) opens that element's details on load: a link to one decision
const wanted = new URLSearchParams(location.hash.slice(1)).get('click');
if (wanted && document.getElementById(wanted)) {{
  document.getElementById(wanted).dispatchEvent(new MouseEvent('click', {{bubbles: true}}));
}}
document.querySelectorAll('.filter').forEach(box => box.addEventListener('change', () => {{
  document.querySelectorAll('.edge.' + box.value).forEach(e => {{ e.style.display = box.checked ? '' : 'none'; }});
}}));
</script></body></html>
"""
    return page


def tracklet_crops(result, graph: nx.DiGraph, height: int = 96) -> dict:
    """JPEG crops of the first and last box of every tracklet in ``graph``."""
    import cv2

    from sotmot.io import FrameReader

    reader = FrameReader(result.info, cache_size=16)
    by_id = {t.id: t for t in result.tracklets}
    out = {}
    for n in sorted(graph.nodes, key=lambda n: by_id[n].start):
        t = by_id[n]
        pair = []
        for k in (0, -1):
            img = reader(int(t.frames[k]))
            box = result.detections.boxes[t.det_index[k]]  # the frame's own pixels (tracklets may be compensated)
            x1, y1, x2, y2 = (int(c[0]) for c in pixel_bounds(box[None], img.shape[1], img.shape[0]))
            crop = img[y1:y2, x1:x2]
            crop = cv2.resize(crop, (max(1, int(height * crop.shape[1] / crop.shape[0])), height))
            pair.append(cv2.imencode(".jpg", crop, [cv2.IMWRITE_JPEG_QUALITY, 80])[1].tobytes())
        out[n] = tuple(pair)
    return out
