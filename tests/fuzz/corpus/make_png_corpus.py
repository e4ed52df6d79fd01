#!/usr/bin/env python3
"""Writes the tiny seed PNGs in png_fuzz/ (one per colour type / depth / chunk hdrd reads).
Run from this directory; the outputs are committed, this script documents how they were made."""
import struct
import zlib


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png(w, h, depth, ctype, rows, extra=(), interlace=0):
    ihdr = struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace)
    raw = b"".join(b"\x00" + r for r in rows)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
    for kind, data in extra:
        out += chunk(kind, data)
    return out + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


seeds = {
    "palette_trns.png": png(2, 2, 8, 3, [b"\x00\x01", b"\x01\x00"],
                            [(b"PLTE", bytes([255, 0, 0, 0, 128, 255])), (b"tRNS", bytes([64]))]),
    "grey1.png": png(9, 1, 1, 0, [bytes([0b10100000, 0b10000000])]),
    "grey16.png": png(1, 2, 16, 0, [b"\x80\x00", b"\xff\xff"]),
    "grey_alpha8.png": png(2, 1, 8, 4, [bytes([51, 204, 0, 255])]),
    "rgb8_trns.png": png(2, 1, 8, 2, [bytes([10, 20, 30, 10, 20, 31])], [(b"tRNS", bytes([0, 10, 0, 20, 0, 30]))]),
    "rgba16.png": png(1, 1, 16, 6, [bytes([0xff, 0xff, 0, 1, 0x12, 0x34, 0x80, 0])]),
    "hdr10_chunks.png": png(2, 1, 16, 2, [bytes(range(12))],
                            [(b"cICP", bytes([9, 16, 0, 1])),
                             (b"mDCV", bytes.fromhex("84d03e8033c286c41d4c0bb83d13404200989680" "00000032")),
                             (b"cLLI", bytes.fromhex("009896800012d644"))]),
}
# Adam7, 8-bit RGB, 5x5: pass order per PNG 3rd edition §8.2.
w = h = 5
px = [[bytes([x * 40, y * 40, 7]) for x in range(w)] for y in range(h)]
passes = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]
raw = b""
for x0, y0, dx, dy in passes:
    if x0 >= w:
        continue
    for y in range(y0, h, dy):
        raw += b"\x00" + b"".join(px[y][x] for x in range(x0, w, dx))
ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 1)
seeds["adam7_rgb8.png"] = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9))
                           + chunk(b"IEND", b""))

for name, data in seeds.items():
    with open("png_fuzz/" + name, "wb") as f:
        f.write(data)
