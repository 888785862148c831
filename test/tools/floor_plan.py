#!/usr/bin/env python3
"""A simulator world's floor plan as a map_server map, for localization tests.

    floor_plan.py WORLD.yaml OUT_PREFIX [--resolution M] [--margin M]

Writes OUT_PREFIX.pgm and OUT_PREFIX.yaml (trinary: occupied 0, free 254, unknown 205): the
cells within half a cell of an object's outline (polylines, polygons, landmark discs) are
occupied; the cells inside the first object (the arena's outer wall) and outside every solid
(polygons, discs) are free; the rest unknown. The map covers the objects' bounding box plus the
margin. What a robot would be given as a building's plan: the true walls, nothing it mapped.
"""
import argparse
import math
import os

import yaml


def to_segment(p, a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length2))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def inside(p, poly):
    crossings = False
    for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1]):
        if (ay > p[1]) != (by > p[1]) and p[0] < ax + (p[1] - ay) * (bx - ax) / (by - ay):
            crossings = not crossings
    return crossings


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("world")
    parser.add_argument("out_prefix")
    parser.add_argument("--resolution", type=float, default=0.01)
    parser.add_argument("--margin", type=float, default=0.1)
    args = parser.parse_args()
    world = yaml.safe_load(open(args.world))
    outlines, solids = [], []
    for o in world.get("objects", []):
        points = [tuple(p) for p in (o.get("polyline") or o.get("polygon") or [])]
        outlines.append(points)
        if "polygon" in o:
            solids.append(points)
    if not outlines:
        raise SystemExit("%s: no objects to draw" % args.world)
    discs = [(l["x_m"], l["y_m"], l["radius_m"]) for l in world.get("landmarks", []) if l.get("radius_m", 0) > 0]
    segments = [s for o in outlines for s in zip(o, o[1:])]
    xs = [p[0] for o in outlines for p in o] + [x + s * r for x, _, r in discs for s in (-1, 1)]
    ys = [p[1] for o in outlines for p in o] + [y + s * r for _, y, r in discs for s in (-1, 1)]
    res = args.resolution
    x0, y0 = min(xs) - args.margin, min(ys) - args.margin
    width = int(math.ceil((max(xs) + args.margin - x0) / res))
    height = int(math.ceil((max(ys) + args.margin - y0) / res))
    arena = outlines[0]
    rows = []
    for j in range(height):
        row = bytearray()
        for i in range(width):
            p = (x0 + (i + 0.5) * res, y0 + (j + 0.5) * res)
            d = min([to_segment(p, a, b) for a, b in segments] +
                    [abs(math.hypot(p[0] - x, p[1] - y) - r) for x, y, r in discs])
            floor = (inside(p, arena) and not any(inside(p, s) for s in solids) and
                     not any(math.hypot(p[0] - x, p[1] - y) < r for x, y, r in discs))
            row.append(0 if d <= 0.5 * res else 254 if floor else 205)
        rows.append(row)
    with open(args.out_prefix + ".pgm", "wb") as f:
        f.write(b"P5\n# floor plan of %s\n%d %d\n255\n" % (os.path.basename(args.world).encode(), width, height))
        for row in reversed(rows):  # the image's first row is the map's top
            f.write(row)
    with open(args.out_prefix + ".yaml", "w") as f:
        f.write("image: %s.pgm\nresolution: %r\norigin: [%r, %r, 0.0]\nnegate: 0\n"
                "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
                % (os.path.basename(args.out_prefix), res, round(x0, 9), round(y0, 9)))
    print("%s: %d x %d cells, %d occupied" % (args.out_prefix, width, height, sum(r.count(0) for r in rows)))


if __name__ == "__main__":
    main()
