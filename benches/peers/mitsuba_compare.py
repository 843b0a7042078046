"""Renders one Mitsuba 3 XML scene with Mitsuba 3 and with Lightlab and compares them pixel by pixel.

    pip install mitsuba numpy
    cargo build --release -p lightlab-cli
    python3 benches/peers/mitsuba_compare.py SCENE.xml [--spp 256] [--passes 32] [-D name=value ...]

Mitsuba (variant scalar_rgb unless --variant) renders `--passes` independent images of spp/passes
samples each (seeds 0, 1, …); their mean is its image and s²/passes its per-pixel variance of the
mean. The film's reconstruction filter is replaced by a box (Lightlab's pixels are box-filtered);
nothing else in the file is changed. Lightlab renders the same file at the same total spp with its
own variance layer. `lightlab compare` then runs the per-pixel z-test z = (a − b)/√(v_a + v_b) with a
Šidák-corrected critical value and a χ² test, and reports the image means' ratio and the relMSE;
its verdict is this script's exit status. Everything is written to --out (default
/tmp/mitsuba-compare/<scene>): both images, the variance, the error images and compare.json.
"""
import argparse
import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import mitsuba as mi

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=256, help="total samples per pixel, each renderer")
    ap.add_argument("--passes", type=int, default=32, help="independent Mitsuba renders")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--lightlab", default=os.path.join(ROOT, "target", "release", "lightlab"))
    ap.add_argument("--integrator", help="Lightlab integrator (default: the file's)")
    ap.add_argument("--out")
    args = ap.parse_args()
    if args.spp % args.passes:
        sys.exit("--spp must be a multiple of --passes")
    name = os.path.splitext(os.path.basename(args.scene))[0]
    out = args.out or os.path.join("/tmp", "mitsuba-compare", name)
    os.makedirs(out, exist_ok=True)
    defines = dict(d.split("=", 1) for d in args.defines)

    # Mitsuba: the file with a box filter, relative paths resolved from the scene's folder.
    mi.set_variant(args.variant)
    mi.file_resolver().prepend(os.path.dirname(os.path.abspath(args.scene)))
    tree = ET.parse(args.scene)
    for film in tree.getroot().iter("film"):
        for f in film.findall("rfilter"):
            film.remove(f)
        ET.SubElement(film, "rfilter", {"type": "box"})
    scene = mi.load_string(ET.tostring(tree.getroot(), encoding="unicode"), **defines)
    per_pass = args.spp // args.passes
    t0 = time.perf_counter()
    images = [np.array(mi.render(scene, seed=s, spp=per_pass), dtype=np.float64)
              for s in range(args.passes)]
    mitsuba_seconds = time.perf_counter() - t0
    stack = np.stack(images)[..., :3]
    mean = stack.mean(axis=0)
    var = stack.var(axis=0, ddof=1) / args.passes
    mi.Bitmap(mean.astype(np.float32)).write(os.path.join(out, "mitsuba.exr"))
    mi.Bitmap(var.astype(np.float32)).write(os.path.join(out, "mitsuba-variance.exr"))

    # Lightlab on the unmodified file.
    cmd = [args.lightlab, "render", args.scene, "--spp", str(args.spp), "--seed", "1",
           "-o", os.path.join(out, "lightlab.exr")]
    for k, v in defines.items():
        cmd += ["-D", f"{k}={v}"]
    if args.integrator:
        cmd += ["--integrator", args.integrator]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    lightlab_seconds = time.perf_counter() - t0

    cmp = subprocess.run([args.lightlab, "compare", os.path.join(out, "lightlab.exr"),
                          os.path.join(out, "mitsuba.exr"), "--variance-b",
                          os.path.join(out, "mitsuba-variance.exr"), "--error",
                          os.path.join(out, "error.exr"), "--json"],
                         capture_output=True, text=True)
    result = json.loads(cmp.stdout)
    result.update({"scene": args.scene, "spp": args.spp, "mitsuba_passes": args.passes,
                   "mitsuba_variant": args.variant, "mitsuba_version": mi.__version__,
                   "mitsuba_seconds": mitsuba_seconds, "lightlab_seconds": lightlab_seconds,
                   "defines": defines})
    with open(os.path.join(out, "compare.json"), "w") as f:
        json.dump(result, f, indent=2)
    print(json.dumps(result, indent=2))
    sys.exit(cmp.returncode)


if __name__ == "__main__":
    main()
