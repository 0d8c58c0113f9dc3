#!/usr/bin/env python3
"""The cohort report OUT/index.html in a headless browser (issue 19).

    python .ci/report_check.py OUT [--screenshot PNG]

Opens file://OUT/index.html in the system Chromium through Playwright
(no `playwright install`: the browser is /usr/bin/chromium, or
$UNFOLD_CHROMIUM), waits for the load, and checks: every <img> is complete
with naturalWidth > 0, no request failed, no console error, no request left
the file system, one <section class="subject"> per subject of
OUT/subjects.csv; and the linked viewer of the first placenta subject: a
click on the flat image at a template pixel inside the placenta must mark
the scanner point that the run's map gives (the barycentric map through the
tets of OUT/<id>/flattened.vtu and OUT/<id>/original.vtu, computed here with
numpy from the files read by meshio) within one voxel of the scan shown, and
a click on that marker in the scan must give the template point back within
one voxel; and for the first ventricle, a click on its disk must mark its
rendering (some clicks may land on the far side). Prints a one-line summary; exits 1 with the problems otherwise.
"""

import base64
import csv
import json
import os
import sys
from pathlib import Path

import meshio
import numpy as np

from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def barycentric_map(points_from, points_to, tets, p):
    """The point of `points_to` at `p`'s barycentric coordinates in the tet of
    `points_from` containing it (the largest smallest coordinate), or None."""
    corners = points_from[tets]                     # (n, 4, 3)
    m = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))  # (n, 3, 3)
    ok = np.abs(np.linalg.det(m)) > 1e-12
    lam = np.full((len(tets), 3), -np.inf)
    lam[ok] = np.linalg.solve(m[ok], (p - corners[ok, 0])[..., None])[..., 0]
    b = np.concatenate([1.0 - lam.sum(axis=1, keepdims=True), lam], axis=1)
    best = int(np.argmax(b.min(axis=1)))
    if b[best].min() < -1e-9:
        return None
    return (b[best][:, None] * points_to[tets[best]]).sum(axis=0)


def canvas_click(page, canvas, px, py):
    """Clicks canvas pixel (px, py) of `canvas` (a locator)."""
    canvas.scroll_into_view_if_needed()
    x, y = canvas.evaluate(
        "(c, p) => { const r = c.getBoundingClientRect();"
        " return [r.left + c.clientLeft + p[0] * c.clientWidth / c.width,"
        " r.top + c.clientTop + p[1] * c.clientHeight / c.height]; }", [px, py])
    page.mouse.click(x, y)


def mm(text):
    return np.array([float(v) for v in text.split(",")]) if text else None


def check_viewer(page, out, placentas, problems):
    """The first placenta viewer's two clicks (module documentation); returns
    the summary's words, or None when the page has no viewer."""
    viewers = page.locator("div.lv")
    if viewers.count() == 0:
        if placentas:
            problems.append(f"no linked viewer on the page for {len(placentas)} placenta(s)")
        return None
    root = viewers.first
    sid = root.get_attribute("data-subject")
    data = json.loads(root.locator("script.lv-data").text_content())
    flat, scan = data["flat"], data["scan"]
    nx, ny = flat["dims"]
    # the scanner point of each pixel: i16 in units of scanner_scale mm, -32768 outside
    table = np.frombuffer(base64.b64decode(flat["scanner"]), "<i2").reshape(ny, nx, 3)
    inside = table[..., 0] != -32768
    # a pixel inside with its 8 neighbours inside, nearest the middle of them
    core = inside.copy()
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            core &= np.roll(np.roll(inside, dj, 0), di, 1)
    js, is_ = np.nonzero(core)
    if len(js) == 0:
        problems.append(f"linked viewer {sid}: no template pixel inside the placenta")
        return None
    c = np.array([is_.mean(), js.mean()])
    n = int(np.argmin((is_ - c[0]) ** 2 + (js - c[1]) ** 2))
    i, j = int(is_[n]), int(js[n])
    fa = np.array(flat["affine"]).reshape(4, 4)
    template = (fa @ np.array([i, j, flat["k"], 1.0]))[:3]
    flattened = meshio.read(out / sid / "flattened.vtu")
    original = meshio.read(out / sid / "original.vtu")
    tets = flattened.cells_dict["tetra"]
    expected = barycentric_map(flattened.points, original.points, tets, template)
    if expected is None:
        problems.append(f"linked viewer {sid}: template point {template} is in no tet")
        return None
    sa = np.array(scan["affine"]).reshape(4, 4)
    voxel = float(np.linalg.norm(sa[:3, :3], axis=0).max())
    canvases = root.locator("canvas")
    readout = root.locator("p.lv-readout")
    zoom = canvases.nth(0).evaluate("c => c.width") / nx
    canvas_click(page, canvases.nth(0), (i + 0.5) * zoom, (j + 0.5) * zoom)
    shown = mm(readout.get_attribute("data-scanner-mm"))
    if shown is None:
        problems.append(f"linked viewer {sid}: a click at template {template} marked nothing")
        return None
    forward = float(np.linalg.norm(shown - expected))
    if forward > voxel:
        problems.append(f"linked viewer {sid}: template {template} marked scanner {shown}, "
                        f"the map gives {expected} ({forward:.2f} mm > one voxel {voxel:.2f} mm)")
    marker = canvases.nth(1).get_attribute("data-marker-px")
    if not marker:
        problems.append(f"linked viewer {sid}: no marker on the scan")
        return None
    px, py = (float(v) for v in marker.split(","))
    canvas_click(page, canvases.nth(1), px, py)
    back = mm(readout.get_attribute("data-template-mm"))
    if back is None:
        problems.append(f"linked viewer {sid}: the scan's marker maps outside the placenta")
        return None
    backward = float(np.linalg.norm(back - template))
    if backward > voxel:
        problems.append(f"linked viewer {sid}: the scan's marker maps to template {back}, "
                        f"not {template} ({backward:.2f} mm > one voxel {voxel:.2f} mm)")
    return (f"linked viewer {sid}: template->scanner {forward:.3f} mm, back {backward:.3f} mm "
            f"(voxel {voxel:.1f} mm)")


def check_ventricle(page, ventricles, problems):
    """The first ventricle viewer: clicks on the disk (a spiral of pixels from
    the centre) until one shows a marker on the rendering; returns the
    summary's words, or None when the page has no ventricle viewer."""
    viewers = page.locator("div.lvv")
    if viewers.count() == 0:
        if ventricles:
            problems.append(f"no linked viewer on the page for {len(ventricles)} ventricle(s)")
        return None
    root = viewers.first
    sid = root.get_attribute("data-subject")
    n = json.loads(root.locator("script.lv-data").text_content())["disk"]["n"]
    canvases = root.locator("canvas")
    readout = root.locator("p.lv-readout")
    zoom = canvases.nth(0).evaluate("c => c.width") / n
    states = []
    for r, a in ((r, a) for r in (0.1, 0.3, 0.5) for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)):
        i, j = (n / 2) * (1 + r * np.cos(a)), (n / 2) * (1 - r * np.sin(a))
        canvas_click(page, canvases.nth(0), i * zoom, j * zoom)
        states.append(readout.get_attribute("data-state"))
        if canvases.nth(1).get_attribute("data-marker-px"):
            return (f"ventricle {sid}: a disk click marked the rendering "
                    f"({states.count('far')} on the far side before)")
    problems.append(f"linked viewer {sid}: {len(states)} disk clicks marked nothing on the "
                    f"rendering (states {states})")
    return None


def main() -> int:
    args = sys.argv[1:]
    if not args or args[0].startswith("-"):
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    out = Path(args[0]).resolve()
    screenshot = args[args.index("--screenshot") + 1] if "--screenshot" in args else None
    page_path = out / "index.html"
    subjects_csv = out / "subjects.csv"
    for p in (page_path, subjects_csv):
        if not p.is_file():
            print(f"report_check: {p} is missing; run `unfold batch` (or `unfold cohort`) first",
                  file=sys.stderr)
            return 1
    with subjects_csv.open(newline="") as f:
        rows = list(csv.DictReader(f))
    ids = [row["id"] for row in rows]
    placentas = [row["id"] for row in rows if row.get("organ") == "placenta"]
    ventricles = [row["id"] for row in rows if row.get("organ") == "ventricle"]

    chromium = os.environ.get("UNFOLD_CHROMIUM", "/usr/bin/chromium")
    if not Path(chromium).is_file():
        print(f"report_check: no Chromium at {chromium}; install it (apt-get install chromium) "
              "or set UNFOLD_CHROMIUM", file=sys.stderr)
        return 1
    problems = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        page = browser.new_page()
        page.on("console", lambda m: m.type == "error"
                and problems.append(f"console error: {m.text}"))
        page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
        page.on("requestfailed", lambda r: problems.append(
            f"request failed: {r.url} ({r.failure})"))
        page.on("request", lambda r: r.url.startswith("file://")
                or problems.append(f"request outside the folder: {r.url}"))
        page.goto(page_path.as_uri(), wait_until="load")
        images = page.eval_on_selector_all(
            "img", "imgs => imgs.map(i => [i.getAttribute('src'), i.complete, i.naturalWidth])")
        for src, complete, width in images:
            if not complete or width <= 0:
                problems.append(f"image not loaded: {src}")
        sections = page.eval_on_selector_all(
            "section.subject", "ss => ss.map(s => s.id)")
        viewer = check_viewer(page, out, placentas, problems)
        disk = check_ventricle(page, ventricles, problems)
        if screenshot:
            page.screenshot(path=screenshot, full_page=False)
        browser.close()
    want = {f"s-{i}" for i in ids}
    got = set(sections)
    if len(sections) != len(ids) or want != got:
        problems.append(
            f"{len(sections)} subject sections for {len(ids)} subjects in subjects.csv "
            f"(missing: {sorted(want - got)[:5]}, extra: {sorted(got - want)[:5]})")
    if problems:
        for p in problems:
            print(f"report_check: {p}", file=sys.stderr)
        print(f"index.html: {len(problems)} problem(s) in {len(sections)} sections, "
              f"{len(images)} images", file=sys.stderr)
        return 1
    print(f"index.html: {len(sections)} sections, {len(images)} images, all loaded"
          + (f"; {viewer}" if viewer else "") + (f"; {disk}" if disk else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
