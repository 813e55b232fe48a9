#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the sample inputs of samples/ (samples/README.md), deterministically.

    python3 samples/make_samples.py [--check]

The files are committed; this script says how they were made and remakes them
byte for byte (Python's own seeded generator, fixed decimals, no third-party module).
--check compares instead of writing and exits 1 when a file differs.

  quickstart/dem.asc            160 x 140 m valley slope (ESRI ASCII, 2 m cells, projected coordinates)
  quickstart/rock-scan.ply      scanned-like rock, 1 m^3, 320 triangles (ASCII PLY, metres, z up)
  quickstart/release-zones.geojson  two release zones on the cliff band with weights, and
  quickstart/fences.geojson     a fence and a ditch edge, as drawn in a GIS (GeoJSON, LV95)
  quickstart/ground-zones.geojson  ground material zones drawn in a GIS (field "material")
  quickstart/release-cells.asc  release cells as a raster (relative densities 0, 1, 2)
  site/dem.tif                  600 x 500 m slope of docs/tutorial-site.md (GeoTIFF, 5 m cells,
                                WGS 84 / UTM zone 32N), and its release zones, nets and
  site/*.geojson                ground materials as drawn in QGIS
  terrain/site-dem.tif          800 x 700 m hillside (GeoTIFF, 10 m cells, CH1903+/LV95)
  terrain/bench-floor.obj       quarry survey, one file per ground material (y up,
  terrain/face.obj              projected coordinates): upper bench, overhanging face,
  terrain/scree.stl             scree apron (ASCII STL)
  terrain/ground.xyz            LiDAR ground points of a 35 degree slope (x y z per line)
  terrain/ground.las            LiDAR survey of such a slope: ground, vegetation and noise
                                returns (LAS 1.2, format 1, EPSG:2056 in its GeoTIFF keys)
  blocks/boulder.xyz            points on a boulder's surface (x y z per line, metres)
  blocks/boulder_scan.ply       photogrammetric boulder scan in millimetres, y up, with one
                                hole and three flipped faces (for the repair settings)
"""
import argparse
import io
import math
import os
import random
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))

# Every coordinate below is in CH1903+/LV95 (EPSG:2056), metres: east 26xxxxx, north 11xxxxx.
EAST0, NORTH0 = 2601000.0, 1180000.0


def fmt(x, decimals):
    s = "%.*f" % (decimals, x)
    return "0." + "0" * decimals if s == "-0." + "0" * decimals else s


# --- rasters ------------------------------------------------------------------------------

def quickstart_dem():
    """A cliff band over 30 m of 35 degree talus, a flattening run-out and the opposite
    slope, falling towards +x, with a shallow gully along y = 70 m, in a valley 140 m wide
    (its sides 8 m higher than its axis) and 160 m long, so that the blocks stay on it;
    survey noise of a few centimetres."""
    rng = random.Random(12)
    ncols, nrows, cell = 80, 70, 2.0
    t60, t35 = math.tan(math.radians(60.0)), math.tan(math.radians(35.0))

    def z_of(x, y):
        if x < 10.0:                      # cliff band, 60 degrees
            z = 56.0 - x * t60
        elif x < 40.0:                    # talus, 35 degrees
            z = 56.0 - 10.0 * t60 - (x - 10.0) * t35
        else:                             # run-out, flattening, then the opposite slope from x = 90 m
            z = 56.0 - 10.0 * t60 - 30.0 * t35 - 0.7 * 10.0 * (1.0 - math.exp(-(x - 40.0) / 10.0))
            if x > 90.0:
                z += 6.0 * ((min(x, 150.0) - 90.0) / 30.0) ** 2 + 0.8 * max(x - 150.0, 0.0)
        return z - 2.0 * math.exp(-((y - 70.0) / 10.0) ** 2) + 8.0 * ((y - 70.0) / 70.0) ** 2 + 100.0

    out = io.StringIO()
    out.write("ncols %d\nnrows %d\nxllcorner %.1f\nyllcorner %.1f\ncellsize %.1f\nNODATA_value -9999\n"
              % (ncols, nrows, EAST0, NORTH0, cell))
    for j in range(nrows - 1, -1, -1):    # north row first
        y = (j + 0.5) * cell
        row = [z_of((i + 0.5) * cell, y) + rng.uniform(-0.03, 0.03) for i in range(ncols)]
        out.write(" ".join(fmt(v, 2) for v in row) + "\n")
    return out.getvalue().encode()


def geojson(name, features):
    """A GeoJSON FeatureCollection in CH1903+/LV95, one feature per line. The "crs" member
    (GeoJSON 2008) says so: without it a GeoJSON file is WGS 84 by definition (RFC 7946)
    and dda-run refuses it for a terrain in LV95."""
    def coords(c):
        if isinstance(c[0], (int, float)):
            return "[" + fmt(c[0], 1) + ", " + fmt(c[1], 1) + "]"
        return "[" + ", ".join(coords(x) for x in c) + "]"
    lines = []
    for properties, kind, c in features:
        props = ", ".join('"%s": %s' % (k, ('"%s"' % v) if isinstance(v, str) else fmt(v, 1))
                          for k, v in properties)
        lines.append('{"type": "Feature", "properties": {%s}, "geometry": {"type": "%s", "coordinates": %s}}'
                     % (props, kind, coords(c)))
    return ('{"type": "FeatureCollection", "name": "%s",\n'
            '"crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::2056"}},\n'
            '"features": [\n%s\n]}\n' % (name, ",\n".join(lines))).encode()


def quickstart_release_zones():
    """Two release zones on the cliff band of quickstart/dem.asc (x 2-7 m from its west
    edge): the northern one, a pentagon across the gully, sheds twice as many blocks as
    the southern rectangle (field "weight", relative)."""
    def ring(points):
        return [[EAST0 + x, NORTH0 + y] for x, y in points + points[:1]]
    return geojson("release-zones", [
        ([("name", "north"), ("weight", 2.0)], "Polygon", [ring([(2, 74), (6, 73), (7, 84), (6, 94), (2, 92)])]),
        ([("name", "south"), ("weight", 1.0)], "Polygon", [ring([(2, 48), (6, 48), (6, 64), (2, 64)])]),
    ])


def quickstart_fences():
    """The fence of my-scene.yaml at x = 70 m, and a ditch edge along the talus toe."""
    def line(points):
        return [[EAST0 + x, NORTH0 + y] for x, y in points]
    return geojson("fences", [
        ([("name", "ditch")], "LineString", line([(42, 41), (44, 70), (42, 99)])),
        ([("name", "fence")], "LineString", line([(70, 40), (70, 100)])),
    ])


def quickstart_release_cells():
    """Release cells of quickstart/dem.asc as a raster (ESRI ASCII, 2 m cells on the DEM's
    grid, its first 10 m): density 1 on the cliff band from y = 46 to 94 m, 2 in the gully
    (y 64-76 m), where the rock is more broken; 0 elsewhere."""
    ncols, nrows, cell = 5, 70, 2.0
    out = io.StringIO()
    out.write("ncols %d\nnrows %d\nxllcorner %.1f\nyllcorner %.1f\ncellsize %.1f\nNODATA_value -9999\n"
              % (ncols, nrows, EAST0, NORTH0, cell))
    for j in range(nrows - 1, -1, -1):    # north row first
        y = (j + 0.5) * cell
        row = []
        for i in range(ncols):
            x = (i + 0.5) * cell
            on_band = 2.0 < x < 8.0 and 46.0 < y < 94.0
            row.append(0 if not on_band else 2 if 64.0 < y < 76.0 else 1)
        out.write(" ".join(str(v) for v in row) + "\n")
    return out.getvalue().encode()


def quickstart_ground_zones():
    """Ground material zones of quickstart/dem.asc as drawn in QGIS (field "material",
    names of my-terrain.yaml): a rock outcrop in the talus, with a pocket of talus in it,
    and a rock rib along the cliff foot south of the gully."""
    def ring(points):
        return [[EAST0 + x, NORTH0 + y] for x, y in points + points[:1]]
    return geojson("ground-zones", [
        ([("material", "rock")], "Polygon",
         [ring([(22, 80), (30, 78), (32, 90), (26, 96), (20, 90)]), ring([(24, 84), (28, 84), (27, 89)])]),
        ([("material", "rock")], "Polygon", [ring([(10, 40), (14, 40), (14, 60), (10, 60)])]),
    ])


def site_profile(north):
    """Elevation (m) along the fall line of the site: a cliff band above 1180750, talus down
    to the road at 1180480, forest run-out below."""
    t = north - NORTH0
    if t >= 900.0:
        return 1260.0 + (t - 900.0) * 0.2
    if t >= 750.0:
        return 1260.0 - (900.0 - t) * math.tan(math.radians(58.0))
    if t >= 480.0:
        return site_profile(NORTH0 + 750.0) - (750.0 - t) * math.tan(math.radians(36.0))
    return site_profile(NORTH0 + 480.0) - (480.0 - t) * math.tan(math.radians(12.0))


def site_dem():
    """81 x 71 points, 10 m cells: the site of configs/terrain/dem-zones.yaml, with ribs
    and gullies across the slope."""
    cell = 10.0
    west, north = EAST0 + 100.0 - cell / 2, NORTH0 + 1000.0 + cell / 2
    rows = dem_rows(81, 71, cell, west, north, random.Random(2056), 0.2,
                    lambda e, n: site_profile(n) + 6.0 * math.sin((e - EAST0) / 70.0) * math.sin((n - NORTH0) / 110.0))
    return geotiff(rows, west, north, cell)


def dem_rows(ncols, nrows, cell, west, north, rng, noise, z_of):
    """The rows of a north-up DEM, north row first: z_of(east, north) at each cell centre
    plus survey noise uniform in +-noise (m), rounded to centimetres."""
    rows = []
    for j in range(nrows):
        n = north - (j + 0.5) * cell
        rows.append([round(z_of(west + (i + 0.5) * cell, n) + rng.uniform(-noise, noise), 2) for i in range(ncols)])
    return rows


def geotiff(rows, west, north, cell, epsg=2056):
    """A single-band float32 GeoTIFF, uncompressed (so that the bytes do not depend on a
    compressor's version), pixel-is-area, EPSG:`epsg` (default CH1903+ / LV95), nodata
    -9999."""
    nrows, ncols = len(rows), len(rows[0])
    raw = b"".join(struct.pack("<%df" % ncols, *r) for r in rows)
    data = raw
    scale = struct.pack("<3d", cell, cell, 0.0)
    tie = struct.pack("<6d", 0.0, 0.0, 0.0, west, north, 0.0)
    keys = [1, 1, 0, 4,
            1024, 0, 1, 1,      # GTModelType: projected
            1025, 0, 1, 1,      # GTRasterType: pixel is area
            3072, 0, 1, epsg,   # ProjectedCSType: CH1903+ / LV95 by default
            3076, 0, 1, 9001]   # ProjLinearUnits: metre
    geokeys = struct.pack("<%dH" % len(keys), *keys)
    nodata = b"-9999\0"
    # (tag, type, count, value or bytes); types: 3 SHORT, 4 LONG, 12 DOUBLE, 2 ASCII
    entries = [
        (256, 3, 1, ncols), (257, 3, 1, nrows), (258, 3, 1, 32), (259, 3, 1, 1), (262, 3, 1, 1),
        (273, 4, 1, None), (277, 3, 1, 1), (278, 3, 1, nrows), (279, 4, 1, len(data)), (284, 3, 1, 1),
        (339, 3, 1, 3), (33550, 12, 3, scale), (33922, 12, 6, tie), (34735, 3, len(keys), geokeys),
        (42113, 2, len(nodata), nodata),
    ]
    ifd_size = 2 + 12 * len(entries) + 4
    extra_at = 8 + ifd_size
    extra = b""
    body = struct.pack("<H", len(entries))
    fixups = []
    for tag, typ, count, value in entries:
        if isinstance(value, bytes):
            if len(value) <= 4:
                body += struct.pack("<HHI", tag, typ, count) + value.ljust(4, b"\0")
            else:
                body += struct.pack("<HHII", tag, typ, count, extra_at + len(extra))
                extra += value + (b"\0" if len(value) % 2 else b"")
        elif value is None:
            fixups.append(len(body) + 8)
            body += struct.pack("<HHII", tag, typ, count, 0)
        elif typ == 3:
            body += struct.pack("<HHIHH", tag, typ, count, value, 0)
        else:
            body += struct.pack("<HHII", tag, typ, count, value)
    body += struct.pack("<I", 0)
    strip_at = extra_at + len(extra)
    for at in fixups:
        body = body[:at] + struct.pack("<I", strip_at) + body[at + 4:]
    return b"II*\0" + struct.pack("<I", 8) + body + extra + data


# --- the site of docs/tutorial-site.md (WGS 84 / UTM zone 32N) ---------------------------

SITE_E, SITE_N = 412000.0, 5140000.0   # the DEM's south-west corner (EPSG:32632, m)


def tutorial_profile(t):
    """Elevation (m) t metres north of the DEM's south edge: a counter-slope, the valley
    floor with its road, 160 m of 35 degree talus, a 60 degree cliff band 40 m deep and
    the plateau above it."""
    t60, t35 = math.tan(math.radians(60.0)), math.tan(math.radians(35.0))
    floor = 1180.0 + 50.0 * max(110.0 - t, 0.0) ** 2 / 12100.0
    if t < 200.0:
        return floor + 6.0 * math.exp(-(200.0 - t) / 15.0)
    if t < 360.0:
        return floor + 6.0 + (t - 200.0) * t35
    if t < 400.0:
        return floor + 6.0 + 160.0 * t35 + (t - 360.0) * t60
    return floor + 6.0 + 160.0 * t35 + 40.0 * t60 + (t - 400.0) * 0.1


def tutorial_dem():
    """121 x 101 points, 5 m cells, EPSG:32632: a south-facing cliff and talus over a
    valley floor, with ribs and gullies across the slope."""
    cell = 5.0
    west, north = SITE_E - cell / 2, SITE_N + 500.0 + cell / 2

    def z_of(e, n):
        t = n - SITE_N
        return tutorial_profile(t) + 4.0 * math.sin((e - SITE_E) / 45.0) * min(max((t - 150.0) / 60.0, 0.0), 1.0)
    rows = dem_rows(121, 101, cell, west, north, random.Random(32632), 0.1, z_of)
    return geotiff(rows, west, north, cell, epsg=32632)


def utm_geojson(name, features):
    """A GeoJSON FeatureCollection in WGS 84 / UTM zone 32N, as QGIS writes one."""
    text = geojson(name, features).decode()
    return text.replace("urn:ogc:def:crs:EPSG::2056", "urn:ogc:def:crs:EPSG::32632").encode()


def site_xy(points):
    return [[SITE_E + x, SITE_N + y] for x, y in points]


def tutorial_release():
    """Two release zones drawn on the cliff band: the western one in a gully, twice as
    active (field "weight")."""
    def ring(points):
        return site_xy(points + points[:1])
    return utm_geojson("release", [
        ([("zone", "west gully"), ("weight", 2.0)], "Polygon", [ring([(170, 375), (260, 370), (265, 395), (175, 398)])]),
        ([("zone", "east face"), ("weight", 1.0)], "Polygon", [ring([(330, 370), (430, 375), (425, 396), (335, 396)])]),
    ])


def tutorial_barriers():
    """A net across the talus (drawn east to west) and one above the road (west to east)."""
    return utm_geojson("barriers", [
        ([("name", "talus net")], "LineString", site_xy([(460, 282), (300, 275), (140, 282)])),
        ([("name", "road net")], "LineString", site_xy([(100, 205), (300, 200), (500, 205)])),
    ])


def tutorial_ground():
    """Ground materials drawn in QGIS (field "material"): the cliff band, the road and
    the forest floor of the valley; the talus is the terrain's first material."""
    def ring(points):
        return [site_xy(points + points[:1])]
    return utm_geojson("ground", [
        ([("material", "rock")], "Polygon", ring([(-5, 355), (605, 355), (605, 405), (-5, 405)])),
        ([("material", "forest floor")], "Polygon", ring([(-5, -5), (605, -5), (605, 160), (-5, 160)])),
        ([("material", "road")], "Polygon", ring([(-5, 166), (605, 166), (605, 174), (-5, 174)])),
    ])


# --- surveyed quarry (TIN) ----------------------------------------------------------------

QUARRY_E, QUARRY_N, QUARRY_Z = EAST0 + 520.0, NORTH0 + 640.0, 700.0


def quarry_point(x, y, z):
    """Local quarry coordinates (x downslope = east, y = north, z up) to the file's y-up
    projected coordinates (E, up, -N)."""
    return (QUARRY_E + x, QUARRY_Z + z, -(QUARRY_N + y))


def grid_faces(nx, ny):
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i
            faces += [(a, b, c), (a, c, d)] if (i + j) % 2 == 0 else [(a, b, d), (b, c, d)]
    return faces


def obj_text(title, verts, faces):
    out = io.StringIO()
    out.write("# %s\n# y up, projected coordinates (CH1903+/LV95, m); samples/make_samples.py\n" % title)
    for v in verts:
        out.write("v %s %s %s\n" % (fmt(v[0], 3), fmt(v[1], 3), fmt(v[2], 3)))
    for f in faces:
        out.write("f %d %d %d\n" % (f[0] + 1, f[1] + 1, f[2] + 1))
    return out.getvalue().encode()


def bench_floor():
    """The upper bench, x 0-20 m, y 0-30 m, 2 m survey grid, gently tilted."""
    rng = random.Random(101)
    ys = [2.0 * j for j in range(16)]
    xs = [2.0 * i for i in range(11)]
    verts = [quarry_point(x, y, 40.0 + 0.03 * (20.0 - x) + (rng.uniform(-0.02, 0.02) if 0 < x < 20 else 0.0))
             for y in ys for x in xs]
    return obj_text("quarry: upper bench floor", verts, grid_faces(len(xs), len(ys)))


FACE_PROFILE = [(20.0, 40.0), (21.5, 31.0), (20.8, 24.0), (22.5, 16.0), (23.0, 10.0)]  # (x, z); 31 -> 24 m overhangs


def face():
    """The quarry face from the bench edge (z 40 m) to the scree (z 10 m), with an
    overhanging band between 31 and 24 m."""
    rng = random.Random(102)
    ys = [2.0 * j for j in range(16)]
    verts = []
    for y in ys:
        for k, (x, z) in enumerate(FACE_PROFILE):
            inner = 0 < k < len(FACE_PROFILE) - 1
            verts.append(quarry_point(x + (rng.uniform(-0.05, 0.05) if inner else 0.0), y, z))
    return obj_text("quarry: face", verts, grid_faces(len(FACE_PROFILE), len(ys)))


def scree():
    """The scree apron below the face, 23-55 m, falling 10 m to the quarry floor (ASCII STL)."""
    rng = random.Random(103)
    xs = [23.0 + 4.0 * i for i in range(9)]
    ys = [30.0 * j / 8 for j in range(9)]

    def z_of(x):
        return max(0.0, 10.0 - (x - 23.0) * math.tan(math.radians(26.0)))

    pts = [quarry_point(x, y, z_of(x) + (rng.uniform(-0.03, 0.03) if x > 23.0 else 0.0)) for y in ys for x in xs]
    out = io.StringIO()
    out.write("solid scree\n")
    for a, b, c in grid_faces(len(xs), len(ys)):
        p, q, r = pts[a], pts[b], pts[c]
        u = [q[k] - p[k] for k in range(3)]
        v = [r[k] - p[k] for k in range(3)]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        ln = math.sqrt(sum(c * c for c in n))
        out.write("facet normal %s %s %s\n outer loop\n" % tuple(fmt(c / ln, 4) for c in n))
        for w in (p, q, r):
            out.write("  vertex %s %s %s\n" % tuple(fmt(c, 3) for c in w))
        out.write(" endloop\nendfacet\n")
    out.write("endsolid scree\n")
    return out.getvalue().encode()


def ground_points():
    """1500 LiDAR ground returns on a 60 x 40 m, 35 degree slope falling east, with a
    small terrace; scattered in plan like a real scan (no two share x and y)."""
    rng = random.Random(35)
    e0, n0 = EAST0 + 250.0, NORTH0 + 330.0
    out = io.StringIO()
    out.write("# LiDAR ground points, CH1903+/LV95 (m): x y z; samples/make_samples.py\n")
    for _ in range(1500):
        x, y = rng.uniform(0.0, 60.0), rng.uniform(0.0, 40.0)
        z = 900.0 - x * math.tan(math.radians(35.0)) + 3.0 * math.exp(-((x - 30.0) / 3.0) ** 2)
        z += 0.6 * math.sin(y / 6.0) + rng.uniform(-0.05, 0.05)
        out.write("%s %s %s\n" % (fmt(e0 + x, 2), fmt(n0 + y, 2), fmt(z, 2)))
    return out.getvalue().encode()


def ground_las():
    """An airborne-like LiDAR survey of the same kind of slope as ground.xyz (35 degrees,
    falling east, with a terrace), as LAS 1.2, point data record format 1, 1 cm
    quantization, CH1903+/LV95 in its GeoTIFF keys: 1200 ground returns (class 2), 300
    returns of shrubs and trees 0.5 to 12 m above the ground (classes 3 to 5) and 20 low
    noise returns 2 to 8 m below it (class 7). No two points share x and y."""
    rng = random.Random(1212)
    e0, n0 = EAST0 + 250.0, NORTH0 + 330.0

    def ground_z(x, y):
        z = 900.0 - x * math.tan(math.radians(35.0)) + 3.0 * math.exp(-((x - 30.0) / 3.0) ** 2)
        return z + 0.6 * math.sin(y / 6.0)

    points, taken = [], set()
    kinds = [(1200, 2, 0.0, 0.0), (100, 3, 0.5, 2.0), (100, 4, 2.0, 5.0), (100, 5, 5.0, 12.0), (20, 7, -8.0, -2.0)]
    for count, cls, lo, hi in kinds:
        made = 0
        while made < count:
            ix, iy = round(rng.uniform(0.0, 60.0) * 100), round(rng.uniform(0.0, 40.0) * 100)
            if (ix, iy) in taken:
                continue
            taken.add((ix, iy))
            x, y = ix / 100.0, iy / 100.0
            dz = rng.uniform(-0.05, 0.05) if cls == 2 else rng.uniform(lo, hi)
            points.append((ix, iy, round((ground_z(x, y) + dz) * 100), cls))
            made += 1
    scale, offset = (0.01, 0.01, 0.01), (e0, n0, 0.0)
    # GeoTIFF key directory: projected, CH1903+ / LV95 (EPSG:2056), metres.
    keys = [1, 1, 0, 3, 1024, 0, 1, 1, 3072, 0, 1, 2056, 3076, 0, 1, 9001]
    vlr_data = struct.pack("<%dH" % len(keys), *keys)
    vlr = struct.pack("<H16sHH32s", 0, b"LASF_Projection", 34735, len(vlr_data), b"GeoTIFF GeoKeyDirectoryTag")
    vlr += vlr_data
    offset_to_points = 227 + len(vlr)
    xs = [p[0] * scale[0] + offset[0] for p in points]
    ys = [p[1] * scale[1] + offset[1] for p in points]
    zs = [p[2] * scale[2] + offset[2] for p in points]
    header = struct.pack("<4sHHIHH8s", b"LASF", 0, 0, 0, 0, 0, bytes(8))
    header += struct.pack("<BB32s32sHHHIIBHI5I", 1, 2, b"samples/make_samples.py", b"samples/make_samples.py",
                          1, 2024, 227, offset_to_points, 1, 1, 28, len(points), len(points), 0, 0, 0, 0)
    header += struct.pack("<3d3d6d", *scale, *offset, max(xs), min(xs), max(ys), min(ys), max(zs), min(zs))
    assert len(header) == 227
    records = b"".join(struct.pack("<iiiHBBbBHd", ix, iy, iz, 0, 0b00001001, cls, 0, 0, 1, 0.0)
                       for ix, iy, iz, cls in points)
    return header + vlr + records


# --- rocks ----------------------------------------------------------------------------------

def icosphere(levels):
    p = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, p, 0), (1, p, 0), (-1, -p, 0), (1, -p, 0), (0, -1, p), (0, 1, p),
             (0, -1, -p), (0, 1, -p), (p, 0, -1), (p, 0, 1), (-p, 0, -1), (-p, 0, 1)]

    def unit(v):
        n = math.sqrt(sum(c * c for c in v))
        return tuple(c / n for c in v)

    verts = [unit(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache = {}

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                verts.append(unit(tuple(verts[i][k] + verts[j][k] for k in range(3))))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return verts, faces


def volume(verts, faces):
    s = 0.0
    for a, b, c in faces:
        p, q, r = verts[a], verts[b], verts[c]
        s += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
              + p[2] * (q[0] * r[1] - q[1] * r[0]))
    return s / 6.0


def rock(seed, dims, target_volume, noise, levels):
    """A scanned-like rock: an icosphere whose radius carries smooth random bumps and
    dents and per-point scan noise, stretched to `dims` (relative) and scaled to
    `target_volume` m^3. A radial graph over the sphere, so closed and never
    self-intersecting."""
    rng = random.Random(seed)
    verts, faces = icosphere(levels)
    r = [1.0] * len(verts)
    for _ in range(20):
        d = (rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1))
        n = math.sqrt(sum(c * c for c in d)) or 1.0
        d = tuple(c / n for c in d)
        width, height = rng.uniform(0.35, 0.8), rng.uniform(-0.08, 0.08)
        for k, v in enumerate(verts):
            ang = math.acos(max(-1.0, min(1.0, sum(v[i] * d[i] for i in range(3)))))
            r[k] += height * math.exp(-(ang / width) ** 2)
    r = [x + rng.uniform(-noise, noise) for x in r]
    pts = [tuple(v[i] * r[k] * dims[i] for i in range(3)) for k, v in enumerate(verts)]
    s = (target_volume / volume(pts, faces)) ** (1.0 / 3.0)
    return [tuple(c * s for c in p) for p in pts], faces


def ply_text(comment, verts, faces, decimals):
    out = io.StringIO()
    out.write("ply\nformat ascii 1.0\ncomment %s\ncomment samples/make_samples.py\n" % comment)
    out.write("element vertex %d\nproperty double x\nproperty double y\nproperty double z\n" % len(verts))
    out.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
    for v in verts:
        out.write("%s %s %s\n" % tuple(fmt(c, decimals) for c in v))
    for f in faces:
        out.write("3 %d %d %d\n" % tuple(f))
    return out.getvalue().encode()


def rock_scan():
    verts, faces = rock(7, (1.25, 1.0, 0.7), 1.0, 0.004, 2)
    return ply_text("scanned-like rock, metres, z up, about 1 m^3", verts, faces, 4)


def boulder_cloud():
    verts, _ = rock(21, (1.3, 1.0, 0.8), 0.8, 0.006, 3)
    out = io.StringIO()
    out.write("# points on a boulder's surface (m): x y z; samples/make_samples.py\n")
    for v in verts:
        out.write("%s %s %s\n" % tuple(fmt(c, 4) for c in v))
    return out.getvalue().encode()


def boulder_scan():
    """A 1.5 m^3 boulder in millimetres, y up, as a photogrammetry export might leave it:
    one triangle missing (a hole) and three faces wound the wrong way."""
    verts, faces = rock(33, (1.4, 0.8, 1.1), 1.5, 0.003, 3)
    verts = [(x * 1000.0, z * 1000.0, -y * 1000.0) for x, y, z in verts]   # z up (m) -> y up (mm)
    faces = list(faces)
    del faces[700]
    for k in (100, 400, 1000):
        a, b, c = faces[k]
        faces[k] = (a, c, b)
    return ply_text("photogrammetric boulder scan, millimetres, y up", verts, faces, 2)


FILES = {
    "quickstart/dem.asc": quickstart_dem,
    "site/dem.tif": tutorial_dem,
    "site/release.geojson": tutorial_release,
    "site/barriers.geojson": tutorial_barriers,
    "site/ground.geojson": tutorial_ground,
    "quickstart/ground-zones.geojson": quickstart_ground_zones,
    "quickstart/release-cells.asc": quickstart_release_cells,
    "quickstart/rock-scan.ply": rock_scan,
    "quickstart/release-zones.geojson": quickstart_release_zones,
    "quickstart/fences.geojson": quickstart_fences,
    "terrain/site-dem.tif": site_dem,
    "terrain/bench-floor.obj": bench_floor,
    "terrain/face.obj": face,
    "terrain/scree.stl": scree,
    "terrain/ground.xyz": ground_points,
    "terrain/ground.las": ground_las,
    "blocks/boulder.xyz": boulder_cloud,
    "blocks/boulder_scan.ply": boulder_scan,
}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true", help="compare with the committed files instead of writing")
    args = parser.parse_args()
    differ = []
    for name, make in FILES.items():
        path = os.path.join(HERE, name)
        data = make()
        if args.check:
            with open(path, "rb") as f:
                if f.read() != data:
                    differ.append(name)
        else:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
            print("%-26s %7d bytes" % (name, len(data)))
    if differ:
        print("differs from what make_samples.py writes: " + ", ".join(differ))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
