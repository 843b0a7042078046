"""Side-by-side speed and efficiency of Lightlab's and Mitsuba 3's path (or light) tracers, in one run.

    pip install mitsuba numpy OpenEXR
    cargo build --release -p lightlab-cli
    python3 benches/peers/mitsuba_speed.py [--spp 64] [--trials 4] [--threads 1 2] [--reference-spp 1024]
                                           [--resolution 256] [--scenes cornell-box caustic-sphere]

For each scene, Lightlab renders scenes/<scene>.ron as shipped (`lightlab render -i 'Path()'`, a
child process; more with --lightlab-integrator) and Mitsuba 3 renders its translation
benches/peers/<scene>.xml (`path`, max_depth −1, rr_depth 5, box filter; with --mitsuba-integrator
ptracer its light tracer instead, max_depth −1, rr_depth 5, against --lightlab-integrator 'Light()',
which traces as many light paths, width × height × spp) in the variants scalar_rgb and llvm_ad_rgb,
with the scene files' independent sampler (and each --mitsuba-sampler, e.g. multijitter or
ldsampler, beside --lightlab-integrator 'Path(sampler: Sobol)'), each on every --threads count, all at
the same spp and resolution, --trials times
with seeds 1, 2, … The trials go round-robin: trial 1 of every renderer, then trial 2, …, so a
drift of this VM's speed during the run (runs on different days moved one renderer's rate by 10 %
against another's) falls on all of them alike. Each Mitsuba trial runs in its own Python process
(this script with --worker), its thread count set by drjit.set_thread_count(T) before the scene
loads: Dr.Jit's nanothread pool, which both the LLVM backend's kernels and the scalar variant's
parallel render loop use (T − 1 workers plus the calling thread). DRJIT_LIBLLVM_PATH is set if
unset.

Timed region: the render alone, in both programs. Mitsuba: mi.render + drjit.eval +
drjit.sync_thread, after a 1-spp warm-up render in the same process; not timed are Python start-up,
the variant's import (for llvm: loading libLLVM), scene loading with Embree's BVH build, and the
warm-up, which compiles the llvm kernel (or loads it from Dr.Jit's disk cache); the kernel does not
depend on spp or seed, so the timed render runs it from the in-memory cache (the JSON records each
render's kernels and how many were not cache hits). Mitsuba's tracing of the integrator into a
kernel on each render (a few ms) is inside. Its CPU seconds are RUSAGE_SELF deltas in its worker
(all threads), its wall perf_counter. Lightlab: a 1-spp warm-up process per configuration (one
sample per replicate with `replicates`), then
each trial a child process whose JSON gives the render's own CPU seconds (`render_cpu_seconds`,
/proc/self/stat deltas around the render call, all threads, 10 ms ticks) and wall seconds; the
process's remaining CPU time (start-up, scene parsing and BVH build, writing EXR/PNG/JSON) is
printed apart. A row whose CPU/wall falls below 0.85 per thread is flagged ⚠: other processes held
the CPUs.

Error. One reference per scene, rendered by Lightlab with `-i 'Bdpt()' --spp R` (all cores) and
cached in --out by scene, resolution, spp and seed, so reruns skip it (delete it after changing
Lightlab). relMSE = mean over pixels and channels of (x − ref)² / (ref² + 0.01), Lightlab's
REL_EPSILON (crates/experiments/src/metrics.rs), averaged over the trials, less the reference's
own noise as Lightlab's experiments subtract it: mean(v_ref / (ref² + 0.01)) (printed; v_ref is its
EXR `variance` layer, the variance of its mean) and the first-order bias of dividing by the noisy
ref. relMSE × spp is then the variance per sample, comparable across spp for these unbiased
estimators. Efficiency = 1 / (relMSE × CPU s);
the ratios divide by Mitsuba llvm_ad_rgb's value on the same scene and thread count. Paths = width ×
height × spp. The same seed gives the same image on any thread count in both programs.

Prints a Markdown table and writes it, with every raw number, to --out (default /tmp/mitsuba-speed):
speed.md, speed.json, and each render's EXR.
"""
import argparse
import datetime
import glob
import json
import os
import platform
import re
import resource
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PEERS = os.path.join(ROOT, "benches", "peers")
REL_EPSILON = 1e-2  # crates/experiments/src/metrics.rs
VARIANTS = ("scalar_rgb", "llvm_ad_rgb")
WARMUP_SEED, REFERENCE_SEED = 0, 1000  # the timed renders take seeds 1, 2, …, --trials


def find_libllvm():
    """Dr.Jit's LLVM backend needs libLLVM's path: keep DRJIT_LIBLLVM_PATH, else the newest found."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    preferred = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
    if os.path.exists(preferred):
        return preferred
    found = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"))
    return found[-1] if found else None


def cpu_seconds(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def worker(spec):
    """One Mitsuba configuration in this process: load, warm up, time the renders, save the images."""
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(spec["variant"])
    dr.set_thread_count(spec["threads"])
    llvm = spec["variant"].startswith("llvm")
    if llvm:
        dr.set_flag(dr.JitFlag.KernelHistory, True)
    t0 = time.perf_counter()
    scene = mi.load_file(spec["scene"], res=spec["resolution"], sampler=spec["sampler"])
    # The scene file's own integrator is `path`; another replaces it with the same depth settings.
    integrator = (None if spec["integrator"] == "path" else
                  mi.load_dict({"type": spec["integrator"], "max_depth": -1, "rr_depth": 5}))
    load_seconds = time.perf_counter() - t0

    def render(spp, seed):
        c0, t0 = cpu_seconds(resource.RUSAGE_SELF), time.perf_counter()
        img = mi.render(scene, integrator=integrator, spp=spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        return img, time.perf_counter() - t0, cpu_seconds(resource.RUSAGE_SELF) - c0

    def jit(hist):
        js = [k for k in hist if str(k.get("type")) == "KernelType.JIT"]
        return {"launched": len(js), "not_cached": sum(1 for k in js if not k.get("cache_hit")),
                "from_disk_cache": sum(1 for k in js if k.get("cache_disk")),
                "execution_ms": sum(k.get("execution_time", 0.0) for k in js),
                "codegen_ms": sum(k.get("codegen_time", 0.0) for k in js),
                "backend_compile_ms": sum(k.get("backend_time", 0.0) for k in js)}

    if llvm:
        dr.kernel_history()  # returns and clears the history
    _, warm_wall, warm_cpu = render(1, WARMUP_SEED)
    result = {"mitsuba_version": mi.__version__, "drjit_version": dr.__version__,
              "thread_count": dr.thread_count(), "load_seconds": load_seconds,
              "warmup_wall_seconds": warm_wall, "warmup_cpu_seconds": warm_cpu, "trials": []}
    if llvm:
        result["warmup_kernels"] = jit(dr.kernel_history())
    images = []
    for seed in spec["seeds"]:
        img, wall, cpu = render(spec["spp"], seed)
        # A sampler may round the count it was given (orthogonal: to a prime's square).
        result["spp"] = scene.sensors()[0].sampler().sample_count()
        trial = {"seed": seed, "wall_seconds": wall, "cpu_seconds": cpu}
        if llvm:
            trial["kernels"] = jit(dr.kernel_history())
        result["trials"].append(trial)
        images.append(np.array(img, dtype=np.float32)[..., :3])
    # Not mi.Bitmap.write: Mitsuba's OpenEXR writer waits on a thread pool that has no workers after
    # drjit.set_thread_count(1) and never returns. The parent writes the EXRs.
    np.save(spec["output"], np.stack(images))
    # On a line of its own: the scalar light tracer's progress bar ends without a newline.
    print("\n" + json.dumps(result))


def read_exr(path, part="radiance"):
    """An EXR's RGB as float64 (H, W, 3): Lightlab's named part (`radiance`, `variance`) or the only one."""
    import OpenEXR

    with OpenEXR.File(path) as f:
        parts = f.parts
        chosen = next((p for p in parts if p.name() == part), None)
        if chosen is None:
            if len(parts) != 1:
                raise ValueError(f"{path}: no part {part!r}")
            chosen = parts[0]
        ch = chosen.channels
        if "RGB" in ch:
            return np.array(ch["RGB"].pixels, dtype=np.float64)[..., :3]
        return np.stack([np.array(ch[c].pixels, dtype=np.float64) for c in "RGB"], axis=-1)


def write_exr(path, rgb):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, dtype=np.float32)}) as f:
        f.write(path)


def rel_mse(x, ref, ref_var):
    """Lightlab's relMSE (`errors` in crates/experiments/src/metrics.rs): ((x − r)² − v_r)/(r² + ε),
    less the first-order bias of dividing by the noisy r, averaged over pixels and channels."""
    denominator = ref * ref + REL_EPSILON
    relative = ((x - ref) ** 2 - ref_var) / denominator
    from_denominator = (relative * (3 * ref * ref - REL_EPSILON) + 4 * ref * (x - ref)) * ref_var / denominator ** 2
    return float(np.mean(relative - from_denominator))


def warmup_spp(integrator):
    """The fewest samples per pixel the Lightlab integrator takes: one per replicate
    (`replicates: R` needs multiples of R), else 1."""
    m = re.search(r"replicates:\s*(\d+)", integrator)
    return int(m.group(1)) if m else 1


def run_lightlab(args, scene, integrator, spp, threads, seed, output):
    cmd = [args.lightlab, "render", scene, "-i", integrator, "--spp", str(spp), "--seed", str(seed),
           "--resolution", f"{args.resolution}x{args.resolution}", "-o", output]
    if threads:
        cmd += ["--threads", str(threads)]
    c0, t0 = cpu_seconds(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"lightlab failed ({' '.join(cmd)}):\n{done.stderr}")
    wall, cpu = time.perf_counter() - t0, cpu_seconds(resource.RUSAGE_CHILDREN) - c0
    with open(os.path.splitext(output)[0] + ".json") as f:
        stats = json.load(f)
    return wall, cpu, stats


def run_mitsuba(args, variant, sampler, scene, threads, seeds, outputs):
    """Runs one Mitsuba configuration in a worker process; writes each trial's image to `outputs`."""
    npy = os.path.splitext(outputs[0])[0] + ".npy"
    spec = {"variant": variant, "integrator": args.mitsuba_integrator, "threads": threads, "scene": scene,
            "sampler": sampler, "spp": args.spp,
            "resolution": args.resolution, "seeds": seeds, "output": npy}
    c0 = cpu_seconds(resource.RUSAGE_CHILDREN)
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", json.dumps(spec)],
                       check=True, stdout=subprocess.PIPE, text=True)
    result = json.loads(p.stdout.strip().splitlines()[-1])
    result["process_cpu_seconds"] = cpu_seconds(resource.RUSAGE_CHILDREN) - c0
    for image, output in zip(np.load(npy), outputs):
        write_exr(output, image)
    os.remove(npy)
    return result


def git_state():
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return head + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return None


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            return next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor()


def fmt(x, spec):
    return "–" if x is None else format(x, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="\n".join(__doc__.split("\n")[1:]))
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "caustic-sphere"],
                    help="scene names: scenes/NAME.ron and benches/peers/NAME.xml")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of every timed render")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="thread counts to run")
    ap.add_argument("--trials", type=int, default=4,
                    help="timed renders per configuration, seeds 1..TRIALS: relMSE is their mean (± its "
                         "standard error), times are means; the caustic's relMSE from one render is noisy")
    ap.add_argument("--resolution", type=int, default=256, help="square image size (the scenes' own: 256)")
    ap.add_argument("--reference-spp", type=int, default=1024, help="samples per pixel of the BDPT reference")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), help="Mitsuba variants")
    ap.add_argument("--lightlab-integrator", action="append", metavar="RON",
                    help="Lightlab integrator(s) to time (repeatable; default 'Path()', as shipped; "
                         "'Path(russian_roulette: 5, roulette_threshold: 1.0)' plays roulette as Mitsuba's "
                         "rr_depth 5 does, without its 0.95 cap on survival)")
    ap.add_argument("--mitsuba-integrator", default="path", choices=["path", "ptracer"],
                    help="Mitsuba's integrator: its path tracer (the scene files') or its light tracer "
                         "(compare with --lightlab-integrator 'Light()')")
    ap.add_argument("--mitsuba-sampler", action="append", metavar="NAME",
                    help="Mitsuba sampler(s) (repeatable; default independent, the scene files' own): "
                         "stratified, multijitter, ldsampler, orthogonal (which rounds spp to a prime's "
                         "square; its row counts the samples it took). The ratios stay ÷ llvm_ad_rgb "
                         "with the independent sampler, which is always run")
    ap.add_argument("--lightlab", default=os.path.join(ROOT, "target", "release", "lightlab"))
    ap.add_argument("--out", default="/tmp/mitsuba-speed")
    args = ap.parse_args()

    llvm_path = find_libllvm()
    if llvm_path:
        os.environ["DRJIT_LIBLLVM_PATH"] = llvm_path
    if args.worker:
        worker(json.loads(args.worker))
        return
    integrators = args.lightlab_integrator or ["Path()"]
    # The ratios' base (llvm_ad_rgb, independent) is always run.
    args.mitsuba_sampler = ["independent"] + [m for m in args.mitsuba_sampler or [] if m != "independent"]
    seeds = list(range(1, args.trials + 1))
    os.makedirs(args.out, exist_ok=True)
    started = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    load_before = os.getloadavg()
    t_start = time.perf_counter()
    rows, references = [], {}

    for name in args.scenes:
        ron = os.path.join(ROOT, "scenes", name + ".ron")
        xml = os.path.join(PEERS, name + ".xml")
        out = os.path.join(args.out, name)
        os.makedirs(out, exist_ok=True)

        # The common reference, cached.
        ref_path = os.path.join(args.out, f"reference-{name}-{args.resolution}px-bdpt-"
                                          f"{args.reference_spp}spp-seed{REFERENCE_SEED}.exr")
        if not os.path.exists(ref_path):
            print(f"{name}: rendering the reference (Bdpt, {args.reference_spp} spp)", file=sys.stderr)
            run_lightlab(args, ron, "Bdpt()", args.reference_spp, None, REFERENCE_SEED, ref_path)
        ref = read_exr(ref_path)
        ref_var = read_exr(ref_path, "variance")
        references[name] = {"path": ref_path, "spp": args.reference_spp, "integrator": "Bdpt()",
                            "mean": ref.mean(axis=(0, 1)).tolist(),
                            "mean_variance_of_mean": float(ref_var.mean()),
                            "rel_mse_subtracted": float(np.mean(ref_var / (ref * ref + REL_EPSILON)))}

        for threads in args.threads:
            mitsuba_rows = {(variant, sampler): {
                "scene": name, "threads": threads, "spp": args.spp, "images": [], "wall": [], "cpu": [],
                "busy_wall": [], "raw": {"processes": []},
                "renderer": f"Mitsuba {variant}" + ("" if sampler == "independent" else f" {sampler}")}
                for variant in args.variants for sampler in args.mitsuba_sampler}
            lightlab_rows = {}
            for integrator in integrators:
                warm_spp = warmup_spp(integrator)
                warm_wall, warm_cpu, warm = run_lightlab(args, ron, integrator, warm_spp, threads,
                                                         WARMUP_SEED, os.path.join(out, "warmup.exr"))
                lightlab_rows[integrator] = {
                    "scene": name, "renderer": f"Lightlab {integrator}", "threads": threads,
                    "spp": args.spp, "images": [], "wall": [], "cpu": [], "busy_wall": [],
                    "raw": {"integrator": warm["integrator"],
                            "warmup": {"spp": warm_spp, "process_wall_seconds": warm_wall, "cpu_seconds": warm_cpu,
                                       "render_wall_seconds": warm["stats"]["wall_seconds"]},
                            "trials": []}}
            # Trials round-robin over the renderers (trial k of each, then trial k + 1), so a drift of
            # the machine's speed during the run falls on every renderer alike.
            for seed in seeds:
                for (variant, sampler), row in mitsuba_rows.items():
                    print(f"{name}: {row['renderer']}, {threads} thread(s), seed {seed}", file=sys.stderr)
                    stem = f"mitsuba-{variant}" + ("" if sampler == "independent" else f"-{sampler}")
                    image = os.path.join(out, f"{stem}-{threads}t-{args.spp}spp-seed{seed}.exr")
                    r = run_mitsuba(args, variant, sampler, xml, threads, [seed], [image])
                    row["spp"] = r["spp"]
                    trial = r["trials"][0]
                    row["images"].append(image)
                    row["wall"].append(trial["wall_seconds"])
                    row["cpu"].append(trial["cpu_seconds"])
                    row["busy_wall"].append(trial["wall_seconds"])
                    row["raw"]["processes"].append(r)
                for integrator, row in lightlab_rows.items():
                    print(f"{name}: Lightlab {integrator}, {threads} thread(s), seed {seed}", file=sys.stderr)
                    stem = "lightlab-" + "".join(c if c.isalnum() else "_" for c in integrator).strip("_")
                    image = os.path.join(out, f"{stem}-{threads}t-{args.spp}spp-seed{seed}.exr")
                    wall, cpu, stats = run_lightlab(args, ron, integrator, args.spp, threads, seed, image)
                    st = stats["stats"]
                    # The render's own CPU time (Lightlab's JSON, /proc/self/stat around the render
                    # call): the same timed region as Mitsuba's render, without start-up, loading and
                    # writing, which the process's CPU time includes.
                    render_cpu = stats["render_cpu_seconds"]
                    row["images"].append(image)
                    row["wall"].append(st["wall_seconds"])
                    row["cpu"].append(render_cpu)
                    row["busy_wall"].append(st["wall_seconds"])
                    row["raw"]["trials"].append({"seed": seed, "process_wall_seconds": wall,
                                                 "process_cpu_seconds": cpu, "cpu_seconds": render_cpu,
                                                 "lightlab_overhead_seconds": wall - st["wall_seconds"],
                                                 "stats": st})
            rows += list(mitsuba_rows.values()) + list(lightlab_rows.values())

    for row in rows:
        ref_path = references[row["scene"]]["path"]
        ref, ref_var = read_exr(ref_path), read_exr(ref_path, "variance")
        errors = [rel_mse(read_exr(image), ref, ref_var) for image in row["images"]]
        k = len(errors)
        row["trials"] = k
        row["paths"] = ref.shape[0] * ref.shape[1] * row["spp"]
        row["wall_seconds"] = float(np.mean(row["wall"]))
        # A render shorter than the 10 ms tick of Lightlab's CPU clock reads 0 s: no rates then.
        row["cpu_seconds"] = float(np.mean(row["cpu"])) or float("nan")
        row["m_paths_per_cpu_second"] = row["paths"] / row["cpu_seconds"] / 1e6
        row["cpu_per_wall"] = row["cpu_seconds"] / row["wall_seconds"]
        # Whole timed region's CPU over its wall (for Lightlab the process's): below 0.85 per thread, the
        # threads did not each get a CPU (other processes were running) and the row is flagged.
        row["contended"] = sum(row["cpu"]) / sum(row["busy_wall"]) < 0.85 * row["threads"]
        row["rel_mse_trials"] = errors
        row["rel_mse"] = float(np.mean(errors))
        row["rel_mse_se"] = float(np.std(errors, ddof=1) / np.sqrt(k)) if k > 1 else None
        row["rel_mse_x_spp"] = row["rel_mse"] * row["spp"]
        row["efficiency"] = 1.0 / (row["rel_mse"] * row["cpu_seconds"])
    for row in rows:
        base = next((b for b in rows if b["scene"] == row["scene"] and b["threads"] == row["threads"]
                     and b["renderer"] == "Mitsuba llvm_ad_rgb"), None)
        row["efficiency_ratio_to_llvm"] = row["efficiency"] / base["efficiency"] if base else None
        row["speed_ratio_to_llvm"] = (row["m_paths_per_cpu_second"] / base["m_paths_per_cpu_second"]
                                      if base else None)

    mitsuba_version = next((p["mitsuba_version"] for r in rows for p in r["raw"].get("processes", [])), None)
    lines = [
        f"Mitsuba {mitsuba_version} (`{args.mitsuba_integrator}`, max_depth −1, rr_depth 5) against Lightlab "
        f"{git_state()} ({', '.join(integrators)}; defaults russian_roulette 1, roulette_threshold 0.5 unless set), {args.resolution}², "
        f"{args.spp} spp, {args.trials} trial(s) each (seeds {seeds[0]}–{seeds[-1]}; times are means); "
        f"{started}, {os.cpu_count()} × {cpu_model()}, load average before {load_before[0]:.2f}. "
        f"Trials round-robin over the renderers. CPU s: all threads, user + sys, the render alone: "
        f"Mitsuba's without scene loading or its 1-spp warm-up (llvm kernel compilation), Lightlab's "
        f"`render_cpu_seconds` (/proc/self/stat, 10 ms ticks) after a warm-up process of 1 spp (one per replicate with `replicates`). relMSE ε = {REL_EPSILON} (± one standard error over the trials, less the reference's noise) against Lightlab "
        f"Bdpt() at {args.reference_spp} spp; efficiency = 1/(relMSE × CPU s); ratios ÷ Mitsuba "
        f"llvm_ad_rgb's, same scene and threads.",
        "",
        "| scene | renderer | threads | spp | wall s | CPU s | CPU/wall | M paths/CPU-s | relMSE | relMSE×spp "
        "| efficiency | efficiency ÷ llvm | paths/CPU-s ÷ llvm |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        err = f"{r['rel_mse']:.4g}" + (f" ± {r['rel_mse_se']:.2g}" if r["rel_mse_se"] is not None else "")
        threads = f"{r['threads']}{' ⚠' if r['contended'] else ''}"
        lines.append(f"| {r['scene']} | {r['renderer']} | {threads} | {r['spp']} | {r['wall_seconds']:.3f} "
                     f"| {r['cpu_seconds']:.3f} | {r['cpu_per_wall']:.2f} | {r['m_paths_per_cpu_second']:.3f} "
                     f"| {err} | {r['rel_mse_x_spp']:.4g} | {r['efficiency']:.4g} "
                     f"| {fmt(r['efficiency_ratio_to_llvm'], '.3f')} | {fmt(r['speed_ratio_to_llvm'], '.3f')} |")
    lines.append("")
    if any(r["contended"] for r in rows):
        lines.append("- ⚠: CPU/wall of the timed region below 0.85 × threads: the threads did not each have "
                     "a CPU (other processes were running); its wall time and thread scaling are not clean.")
    for name, ref in references.items():
        lines.append(f"- {name}: reference {os.path.basename(ref['path'])}, mean variance of its mean "
                     f"{ref['mean_variance_of_mean']:.3g}, relMSE its noise adds (subtracted) "
                     f"{ref['rel_mse_subtracted']:.3g}")
    overheads = []
    for r in rows:
        trials = r["raw"].get("trials", [])
        if trials and "process_cpu_seconds" in trials[0]:
            extra = np.mean([t["process_cpu_seconds"] - t["cpu_seconds"] for t in trials])
            overheads.append(f"{r['scene']} {r['renderer']} {r['threads']}t {extra:.3f}")
    if overheads:
        lines.append("- Lightlab's fixed cost per process (start-up, scene loading, writing the images), "
                     "outside the timed region: process CPU s − render CPU s, mean over the trials: "
                     + "; ".join(overheads))
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(args.out, "speed.md"), "w") as f:
        f.write(table + "\n")
    with open(os.path.join(args.out, "speed.json"), "w") as f:
        json.dump({"started": started, "total_seconds": time.perf_counter() - t_start,
                   "machine": {"cpus": os.cpu_count(), "cpu_model": cpu_model(),
                               "load_average_before": load_before, "load_average_after": os.getloadavg()},
                   "lightlab": {"binary": args.lightlab, "git": git_state(), "integrators": integrators},
                   "mitsuba_version": mitsuba_version, "drjit_libllvm_path": llvm_path,
                   "settings": {"spp": args.spp, "threads": args.threads, "resolution": args.resolution,
                                "mitsuba_integrator": args.mitsuba_integrator,
                                "mitsuba_samplers": args.mitsuba_sampler,
                                "reference_spp": args.reference_spp, "variants": args.variants,
                                "trials": args.trials, "seeds": {"warmup": WARMUP_SEED, "timed": seeds,
                                          "reference": REFERENCE_SEED},
                                "rel_mse_epsilon": REL_EPSILON},
                   "references": references, "rows": rows, "table": table}, f, indent=2)


if __name__ == "__main__":
    main()
