#!/usr/bin/env python3
"""The cohort report OUT/index.html in a headless browser (issue 19).

    python .ci/report_check.py OUT [--screenshot PNG]

Opens file://OUT/index.html in the system Chromium through Playwright
(no `playwright install`: the browser is /usr/bin/chromium, or
$UNFOLD_CHROMIUM), waits for the load, and checks: every <img> is complete
with naturalWidth > 0, no request failed, no console error, no request left
the file system, one <section class="subject"> per subject of
OUT/subjects.csv. Prints a one-line summary; exits 1 with the problems
otherwise.
"""

import csv
import os
import sys
from pathlib import Path

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
        ids = [row["id"] for row in csv.DictReader(f)]

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
    print(f"index.html: {len(sections)} sections, {len(images)} images, all loaded")
    return 0


if __name__ == "__main__":
    sys.exit(main())
