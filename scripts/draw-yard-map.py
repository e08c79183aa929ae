#!/usr/bin/env python3
"""Draws scenarios/maps/yard.pgm: a 50 m x 30 m yard between buildings, 0.1 m per pixel, in the
ROS map_server convention (0 occupied, 205 unknown, 254 free; top row = north). Issue 16."""
import math, pathlib

RES, W, H = 0.1, 500, 300
buildings = [(10, 0, 20, 12), (12, 18, 22, 30), (30, 8, 38, 22)]      # x0, y0, x1, y1, m
trees = [(6, 23, 1.0), (26, 12.5, 1.0), (45, 24, 1.0), (26, 3.5, 1.0)]     # x, y, r, m
fence = ((42.0, 0.0), (42.0, 14.0), 0.3)                              # ends, thickness, m
unknown = (0, 0, 4, 5)                                                  # never surveyed

def seg_dist(p, a, b):
    ex, ey = b[0] - a[0], b[1] - a[1]
    t = max(0.0, min(1.0, ((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / (ex * ex + ey * ey)))
    return math.hypot(p[0] - a[0] - t * ex, p[1] - a[1] - t * ey)

rows = []
for row in range(H):
    j = H - 1 - row                      # image row 0 is the northern edge
    line = bytearray()
    for i in range(W):
        x, y = (i + 0.5) * RES, (j + 0.5) * RES
        v = 254
        if unknown[0] <= x <= unknown[2] and unknown[1] <= y <= unknown[3]:
            v = 205
        if any(b[0] <= x <= b[2] and b[1] <= y <= b[3] for b in buildings):
            v = 0
        if any(math.hypot(x - tx, y - ty) <= r for tx, ty, r in trees):
            v = 0
        if seg_dist((x, y), fence[0], fence[1]) <= fence[2] / 2:
            v = 0
        line.append(v)
    rows.append(bytes(line))
out = pathlib.Path(__file__).resolve().parent.parent / "scenarios/maps/yard.pgm"
out.write_bytes(f"P5\n# yard between buildings, drawn by scripts/draw-yard-map.py\n{W} {H}\n255\n".encode() + b"".join(rows))
print("wrote", out)
