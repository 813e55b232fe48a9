#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the large ESRI ASCII DEM of the terrain-file measurements (docs/benchmarks.md,
"Terrain files"): SIZE x SIZE points, 1 m cells, projected coordinates (CH1903+/LV95),
a 30 degree hillside with ridges and gullies. 2000 x 2000 points (the default) make a
31 MB file. Deterministic: the same SIZE gives the same bytes.

    python3 bench/terrain/big_dem.py OUT.asc [--size 2000]
"""
import argparse
import math
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out")
    parser.add_argument("--size", type=int, default=2000, help="points per side (default 2000)")
    args = parser.parse_args()
    n = args.size
    slope = math.tan(math.radians(30.0))
    with open(args.out, "w") as f:
        f.write(f"ncols {n}\nnrows {n}\nxllcorner 2600000.0\nyllcorner 1180000.0\ncellsize 1.0\n"
                "NODATA_value -9999\n")
        for j in range(n - 1, -1, -1):      # north row first
            y = j + 0.5
            ridge = 4.0 * math.sin(y / 37.0)
            f.write(" ".join("%.2f" % (1500.0 - slope * x + ridge * math.sin(x / 53.0) + 0.3 * math.sin(x * 1.7 + y))
                             for x in (i + 0.5 for i in range(n))))
            f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
