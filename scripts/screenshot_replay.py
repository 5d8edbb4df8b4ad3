"""Screenshots of a Meshcat HTML replay in headless Chromium (Playwright).

    .venv/bin/python scripts/screenshot_replay.py replay.html --times 0 10 --out shots/

For each time t [s] of the animation (paused and scrubbed to t) one PNG
`<out>/<stem>_t<t>.png` is written, seen from the replay's own default camera. Needs
Playwright (`pip install playwright`) and a Chromium: `--chromium` (default
/usr/bin/chromium, Debian's `apt-get install chromium`). WebGL runs on SwiftShader (CPU).
Console errors of the page (e.g. three.js animation-binding warnings) are printed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]


def screenshot_replay(
    html: Path,
    times: list[float],
    out_dir: Path,
    chromium: str = "/usr/bin/chromium",
    size: tuple[int, int] = (1280, 800),
    camera: tuple[list[float], list[float]] | None = None,
) -> tuple[list[Path], list[str]]:
    """Open `html`, pause its animation, and screenshot it at each time in `times` [s].

    `camera`: (position, target) [m, world frame, z up] of the viewer's camera instead of
    the replay's default view. Returns the written PNG paths and the page's console
    warnings/errors."""
    out_dir.mkdir(parents=True, exist_ok=True)
    shots: list[Path] = []
    messages: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": size[0], "height": size[1]})
        page.on(
            "console",
            lambda m: (
                messages.append(f"{m.type}: {m.text}") if m.type in ("warning", "error") else None
            ),
        )
        page.on("pageerror", lambda e: messages.append(f"pageerror: {e}"))
        page.goto(html.resolve().as_uri(), timeout=180_000)
        # the embedded scene is applied by fetch() promises after load: wait for the animation
        page.wait_for_function(
            "() => window.viewer && viewer.animator.actions.length > 0", timeout=60_000
        )
        page.wait_for_timeout(500)
        duration = page.evaluate("() => viewer.animator.duration")
        if camera is not None:  # Meshcat's three.js frame is y up: world (x, y, z) → (x, z, −y)
            (px, py, pz), (tx, ty, tz) = camera
            page.evaluate(
                "([p, t]) => { viewer.handle_command({type: 'set_property', path: "
                "'/Cameras/default/rotated/<object>', property: 'position', value: p});"
                " viewer.set_camera_target(t); viewer.set_dirty(); }",
                [[px, pz, -py], [tx, tz, -ty]],
            )
        for t in times:
            page.evaluate(
                "(t) => { const a = viewer.animator; a.pause(); a.seek(t); a.display_progress(t);"
                " viewer.set_dirty(); }",
                min(t, duration),
            )
            page.wait_for_timeout(400)
            path = out_dir / f"{html.stem}_t{t:g}.png"
            page.screenshot(path=str(path))
            shots.append(path)
        browser.close()
    return shots, messages


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("html", type=Path, help="a replay written by `emonav sim --record`")
    p.add_argument("--times", type=float, nargs="+", default=[0.0], help="animation times [s]")
    p.add_argument("--out", type=Path, default=Path("."), help="directory for the PNGs")
    p.add_argument("--chromium", default="/usr/bin/chromium", help="the Chromium executable")
    p.add_argument(
        "--camera",
        type=float,
        nargs=6,
        metavar=("PX", "PY", "PZ", "TX", "TY", "TZ"),
        help="the viewer's camera position and target [m, world, z up]",
    )
    args = p.parse_args(argv)
    camera = None if args.camera is None else (args.camera[:3], args.camera[3:])
    shots, messages = screenshot_replay(
        args.html, args.times, args.out, args.chromium, camera=camera
    )
    for m in messages:
        print(m, file=sys.stderr)
    for s in shots:
        print(s)
    return 0


if __name__ == "__main__":
    sys.exit(main())
