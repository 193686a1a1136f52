"""Load time of viewer.html pages in headless Chromium (issue 28).

For each page: its size, and over --repeat loads from disk (file://) the
median time from navigation start to the viewer built (`window.viewer`
created: data parsed, every chart and the scene drawn) and to its first
frame shown (two animation frames later), as the page's own
performance.now() reads them. One Chromium, the pages loaded in turn.

    python3 bench/viewer_load.py /tmp/v20/viewer.html /tmp/v200/viewer.html --repeat 7
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "browser"))
from cdp import Browser  # noqa: E402


def load(browser, page):
    browser.open(page.resolve().as_uri())
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        r = browser.eval("window.viewer && window.viewer.firstFrameMs ? "
                         "[window.viewer.loadMs, window.viewer.firstFrameMs] : null")
        if r:
            errors = browser.errors()
            if errors:
                raise SystemExit(f"{page}: {errors}")
            return r
        time.sleep(0.01)
    raise SystemExit(f"{page}: the viewer did not start")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("pages", nargs="+", type=Path)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    print("| page | size [kB] | built [ms] (median) | first frame [ms] (median) | loads |")
    print("| --- | ---: | ---: | ---: | ---: |")
    with Browser() as b:
        for page in args.pages:
            load(b, page)  # warm-up: Chromium's own start-up is not the page's
            runs = [load(b, page) for _ in range(args.repeat)]
            built = statistics.median(r[0] for r in runs)
            frame = statistics.median(r[1] for r in runs)
            size = page.stat().st_size / 1000
            print(f"| {page} | {size:.0f} | {built:.0f} | {frame:.0f} | {args.repeat} |")


if __name__ == "__main__":
    main()
