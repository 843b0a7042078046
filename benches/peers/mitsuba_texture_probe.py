"""Prints Mitsuba 3's texture lookups and shape texture coordinates, the values Lightlab's texture
and parameterisation tests hold (crates/materials/src/texture.rs, crates/geometry/src/sphere.rs,
crates/scene/tests/textures.rs, crates/scene/src/image.rs).

    pip install mitsuba numpy && python3 benches/peers/mitsuba_texture_probe.py

Writes its probe images to a temporary directory: a 2 × 2 OpenEXR image (red, green / blue,
yellow; row 0 at the top) looked up with every filter and wrap mode and through to_uv transforms,
an 8-bit PNG for the sRGB decoding, the checkerboard, and the (u, v) and dp_du of rays hitting a
rectangle, sphere (plain and rotated), cube, disk, OBJ (with and without texture coordinates and
flip_tex_coords) and PLY.
"""
import os
import tempfile

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f
os.chdir(tempfile.mkdtemp(prefix="mitsuba-texture-probe-"))


def rounded(v, k=4):
    return [round(float(x), k) for x in v]


def lookups(tex, uvs):
    si = mi.SurfaceInteraction3f()
    out = []
    for uv in uvs:
        si.uv = mi.Point2f(*uv)
        out.append((uv, rounded(tex.eval(si))))
    return out


mi.Bitmap(np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 0]]], dtype=np.float32)).write("t.exr")
uvs = [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.5, 0.5), (0.1, 0.1), (1.1, 0.25), (-0.1, 0.25), (1.6, 0.25)]
for filt in ["nearest", "bilinear"]:
    for wrap in ["repeat", "mirror", "clamp"]:
        tex = mi.load_dict({"type": "bitmap", "filename": "t.exr", "filter_type": filt, "wrap_mode": wrap})
        print("bitmap", filt, wrap, lookups(tex, uvs))
for name, t in [("scale 2 3", T().scale([2, 3, 1])), ("translate x 0.5", T().translate([0.5, 0, 0])),
                ("rotate z 90", T().rotate([0, 0, 1], 90))]:
    tex = mi.load_dict({"type": "bitmap", "filename": "t.exr", "filter_type": "nearest", "to_uv": t})
    print("to_uv", name, lookups(tex, [(0.1, 0.1), (0.3, 0.2), (0.1, 0.3)]))

mi.Bitmap(np.array([[[128, 64, 255]]], dtype=np.uint8), pixel_format=mi.Bitmap.PixelFormat.RGB).write("s.png")
for raw in [False, True]:
    tex = mi.load_dict({"type": "bitmap", "filename": "s.png", "raw": raw})
    print("png (128, 64, 255) raw =", raw, lookups(tex, [(0.5, 0.5)]))

rgb = lambda c: {"type": "rgb", "value": c}
ch = mi.load_dict({"type": "checkerboard", "color0": rgb([1, 0, 0]), "color1": rgb([0, 1, 0])})
print("checkerboard", lookups(ch, [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75), (1.25, 0.25), (-0.25, 0.25), (0.5, 0.25)]))
print("checkerboard defaults", lookups(mi.load_dict({"type": "checkerboard"}), [(0.1, 0.1), (0.6, 0.1)]))

with open("tri.obj", "w") as f:
    f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
with open("triuv.obj", "w") as f:
    f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n")
with open("tri.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n")
down = [0, 0, -1]
for name, shape, o, d in [
    ("rectangle", {"type": "rectangle"}, [0.5, -0.5, 2], down),
    ("rectangle", {"type": "rectangle"}, [-0.5, 0.5, 2], down),
    ("rectangle rotate z 90", {"type": "rectangle", "to_world": T().rotate([0, 0, 1], 90)}, [0.5, -0.5, 2], down),
    ("sphere", {"type": "sphere"}, [3, 0.01, 0.3], [-1, 0, 0]),
    ("sphere", {"type": "sphere"}, [0.01, 3, -0.3], [0, -1, 0]),
    ("sphere", {"type": "sphere"}, [-3, 0.01, 0], [1, 0, 0]),
    ("sphere rotate x 90", {"type": "sphere", "to_world": T().rotate([1, 0, 0], 90)}, [0, 0, 3], down),
    ("sphere rotate x 90", {"type": "sphere", "to_world": T().rotate([1, 0, 0], 90)}, [3, 0.3, 0.01], [-1, 0, 0]),
    ("cube", {"type": "cube"}, [0.2, -3, 0.6], [0, 1, 0]),
    ("cube", {"type": "cube"}, [3, 0.2, 0.6], [-1, 0, 0]),
    ("cube", {"type": "cube"}, [0.2, 0.6, 3], down),
    ("disk", {"type": "disk"}, [0.3, 0.4, 2], down),
    ("obj without vt", {"type": "obj", "filename": "tri.obj"}, [0.2, 0.3, 2], down),
    ("obj", {"type": "obj", "filename": "triuv.obj"}, [0.2, 0.3, 2], down),
    ("obj flip_tex_coords false", {"type": "obj", "filename": "triuv.obj", "flip_tex_coords": False}, [0.2, 0.3, 2], down),
    ("ply u v", {"type": "ply", "filename": "tri.ply"}, [0.2, 0.3, 2], down),
]:
    si = mi.load_dict({"type": "scene", "s": shape}).ray_intersect(mi.Ray3f(o, d))
    print(f"{name}: ray {o} → uv {rounded(si.uv)}, dp_du {rounded(si.dp_du)}")
