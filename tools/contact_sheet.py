#!/usr/bin/env python3
"""Contact sheet of the scene library (DESIGN §4): render each scene briefly and tile the
previews, labelled, into one PNG, so the look of every scene can be checked at a glance and the
docs show what each scene is.

  contact_sheet.py [--spp N] [--method bpt|ibpt|pt|lt] [--out docs/scenes.png] [SCENE ...]

Scenes are names under fixtures/scenes/ (default: the paper's four and the stress scene).
Renders use the release build of mixmc-omc (run `cargo build --release` first), one at a time:
the point is a recognisable picture in about a minute, not a converged one.
"""
import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parent.parent
SCENES = ["cornell-torus", "cornell-water", "room", "bathroom", "stress"]
COLUMNS = 3
LABEL = 22  # pixels of caption under each tile


def render(scene, spp, method, tmp):
    """Render one scene and return its sRGB preview as a float array (H, W, 3) in [0, 1]."""
    png = Path(tmp) / f"{scene}.png"
    cmd = [
        str(ROOT / "target/release/mixmc-omc"),
        str(ROOT / "fixtures/scenes" / f"{scene}.json"),
        "-o", str(Path(tmp) / f"{scene}.exr"),
        "--png", str(png),
        "--spp", str(spp),
        "--method", method,
        "-q",
    ]
    subprocess.run(cmd, check=True)
    buf = oiio.ImageBuf(str(png))
    pixels = buf.get_pixels(oiio.FLOAT)
    if pixels is None or buf.has_error:
        sys.exit(f"cannot read {png}: {buf.geterror()}")
    return np.asarray(pixels)[:, :, :3]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", default=SCENES)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--method", default="bpt", choices=["pt", "lt", "ibpt", "bpt"])
    ap.add_argument("--out", default=str(ROOT / "docs/scenes.png"))
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        tiles = [render(s, args.spp, args.method, tmp) for s in args.scenes]
    h = max(t.shape[0] for t in tiles)
    w = max(t.shape[1] for t in tiles)
    cols = min(COLUMNS, len(tiles))
    rows = (len(tiles) + cols - 1) // cols
    sheet = oiio.ImageBuf(oiio.ImageSpec(cols * w, rows * (h + LABEL), 3, oiio.FLOAT))
    for i, (name, tile) in enumerate(zip(args.scenes, tiles)):
        x, y = (i % cols) * w, (i // cols) * (h + LABEL)
        roi = oiio.ROI(x, x + tile.shape[1], y, y + tile.shape[0], 0, 1, 0, 3)
        sheet.set_pixels(roi, np.ascontiguousarray(tile, dtype=np.float32))
        caption = f"{name}  ({args.method}, {args.spp} spp)"
        if not oiio.ImageBufAlgo.render_text(sheet, x + 6, y + h + LABEL - 6, caption, 14, "", [1, 1, 1]):
            sys.exit(f"cannot draw caption: {oiio.geterror()}")
    if not sheet.write(args.out, oiio.UINT8):
        sys.exit(f"cannot write {args.out}: {sheet.geterror()}")
    print(args.out)


if __name__ == "__main__":
    main()
