"""Write the bad-input corpus under fixtures/bad/ (run: python3 tools/make_bad_fixtures.py).

Standard library only: the EXRs are written byte by byte (scanline, uncompressed), so each file
is exactly the defect it is named after and nothing else. tests/bad_input.rs runs every tool on
these files.
"""

import math
import struct
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "fixtures" / "bad"
UINT, HALF, FLOAT = 0, 1, 2
SIZE = {UINT: 4, HALF: 2, FLOAT: 4}


def attr(name, kind, value):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def exr(width, height, channels, pixels=True, header_only_height=None):
    """channels: list of (name, type, values as a flat row-major list)."""
    channels = sorted(channels, key=lambda c: c[0])
    chlist = b"".join(
        n.encode() + b"\0" + struct.pack("<iB3xii", t, 0, 1, 1) for n, t, _ in channels
    ) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    head = b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
    head += attr("channels", "chlist", chlist)
    head += attr("compression", "compression", b"\0")
    head += attr("dataWindow", "box2i", box)
    head += attr("displayWindow", "box2i", box)
    head += attr("lineOrder", "lineOrder", b"\0")
    head += attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    head += attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
    head += attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    head += b"\0"
    if not pixels:
        return head
    fmt = {UINT: "<I", HALF: "<e", FLOAT: "<f"}
    chunks = []
    for y in range(height):
        data = b"".join(
            struct.pack(fmt[t], v[y * width + x]) for _, t, v in channels for x in range(width)
        )
        chunks.append(struct.pack("<ii", y, len(data)) + data)
    offset = len(head) + 8 * height
    table = b""
    for c in chunks:
        table += struct.pack("<Q", offset)
        offset += len(c)
    return head + table + b"".join(chunks)


def aov(width=8, height=8, override=None, drop=(), rename=None):
    """An OMC-like AOV image: R,G,B, direct.*, indirect.*, Z, N.*, matid (two materials)."""
    n = width * height
    ch = {}
    for prefix in ("", "direct.", "indirect."):
        for c, v in zip("RGB", (0.5, 0.4, 0.3)):
            ch[prefix + c] = (FLOAT, [v * (1 + (i % 3)) for i in range(n)])
    ch["Z"] = (FLOAT, [2.0] * n)
    for c, v in zip("XYZ", (0.0, 0.0, -1.0)):
        ch["N." + c] = (FLOAT, [v] * n)
    ch["matid"] = (FLOAT, [float(i % width >= width // 2) for i in range(n)])
    for k, v in (override or {}).items():
        ch[k] = v
    for k in drop:
        del ch[k]
    for old, new in (rename or {}).items():
        ch[new] = ch.pop(old)
    return exr(width, height, [(k, t, v) for k, (t, v) in ch.items()])


def mask(width, height, value=0.5, at=None):
    alpha = [value] * (width * height)
    if at is not None:
        alpha[at[0]] = at[1]
    return exr(width, height, [("alpha", FLOAT, alpha)])


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    files = {}
    good = aov()
    files["aov-8x8.exr"] = good
    files["aov-4x4.exr"] = aov(4, 4)
    files["truncated.exr"] = good[: len(good) // 2]
    # The offset table points far beyond the end of the file.
    head_len = good.index(b"\0\0", good.index(b"screenWindowWidth")) + 6
    files["corrupt-offsets.exr"] = good[:head_len] + b"\xff" * 64 + good[head_len + 64 :]
    files["not-an-exr.exr"] = b"this is a text file, not an image\n"
    files["empty.exr"] = b""
    # 1,000,000 x 1,000,000 pixels of 3 floats: 12 TB if anyone believed the header.
    files["terabytes.exr"] = exr(1_000_000, 1_000_000, [(c, FLOAT, None) for c in "RGB"], pixels=False)
    nan = [float("nan") if i in (9, 10) else 0.2 for i in range(64)]
    inf = [math.inf if i == 27 else 0.2 for i in range(64)]
    files["nan-indirect.exr"] = aov(override={"indirect.G": (FLOAT, nan), "indirect.B": (FLOAT, inf)})
    files["nan-beauty.exr"] = aov(override={"R": (FLOAT, nan)})
    files["missing-indirect.exr"] = aov(drop=("indirect.R", "indirect.G", "indirect.B"))
    files["misnamed-channels.exr"] = aov(
        rename={"indirect.R": "Indirect.R", "indirect.G": "Indirect.G", "indirect.B": "Indirect.B"}
    )
    files["u32-indirect.exr"] = aov(
        override={f"indirect.{c}": (UINT, [7] * 64) for c in "RGB"}
    )
    files["u32-matid.exr"] = aov(override={"matid": (UINT, [i % 8 >= 4 for i in range(64)])})
    files["half-aov.exr"] = aov(override={f"indirect.{c}": (HALF, [0.25] * 64) for c in "RGB"})
    files["mask-8x8.exr"] = mask(8, 8)
    files["mask-4x4.exr"] = mask(4, 4)
    files["mask-nan.exr"] = mask(8, 8, at=(5, float("nan")))
    files["mask-out-of-range.exr"] = mask(8, 8, at=(5, 1.5))
    files["mask-u32.exr"] = exr(8, 8, [("alpha", UINT, [1] * 64)])
    for name, data in files.items():
        (OUT / name).write_bytes(data)
    print(f"wrote {len(files)} files to {OUT}")


if __name__ == "__main__":
    main()
