#!/usr/bin/env python3
"""Peer comparison of the denoiser: Open Image Denoise (OIDN, through the
`pyoidn` wheel) on penumbra's own raw 1-spp frames, with their albedo and
normal AOVs, beside penumbra's denoiser on the same frames, both against a
`reference` render: relMSE, speckles (`penumbra compare --depth`) and
milliseconds, on the first frame, after a camera cut and after 16 frames.

OIDN is a development tool here, never a dependency of the renderer: run
through `make peer-denoise`, which makes a virtual environment under
target/ with pyoidn, numpy and OpenEXR (docs/first-frame.md).

Rows, per scene:
  frame 1   the first frame (no history); OIDN denoises the raw frame.
  jump      the second frame of a render whose eye turns by --cut-deg about
            the target after the first (a camera jump; TAA off, so that both
            frames are unjittered like frame 1): the denoiser keeps what of
            the first view's history reprojects; OIDN denoises that frame's
            raw composite.
  16 frames the 16th frame of a still, jittered camera; OIDN denoises the
            undenoised TAA-resolved frame (16 jittered 1-spp frames: the
            path tracer at 16 spp it would be given).
penumbra's denoiser time is the wall time the render reports for its
denoiser in that frame (all cores); OIDN's the median of --repeats calls on
the same cores, after a warm-up call.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import time

import numpy as np
import OpenEXR
import pyoidn

SCENES = {
    "room": "scenes/room.toml",
    "shadow-plane": "scenes/shadow-plane.toml",
    "built-in": None,
}


def read_exr(path):
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.ascontiguousarray(ch["RGB"].pixels, dtype=np.float32)
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in "RGB"], -1)


def write_exr(path, rgb):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, dtype=np.float32)}) as f:
        f.write(path)


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 1):
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    return p


class Peer:
    def __init__(self, a):
        self.a = a
        self.bin = a.bin
        os.makedirs(a.out_dir, exist_ok=True)

    def path(self, scene, name):
        return os.path.join(self.a.out_dir, f"{scene}-{self.a.width}x{self.a.height}-{name}.exr")

    def render(self, scene, name, *args):
        """Renders to the row's file; returns (path, denoiser ms)."""
        out = self.path(scene, name)
        cmd = [self.bin, "render"]
        if SCENES[scene]:
            cmd.append(SCENES[scene])
        cmd += ["--width", str(self.a.width), "--height", str(self.a.height), "--out", out]
        cmd += list(args)
        p = run(cmd)
        m = re.search(r"denoiser ([0-9.]+) ms", p.stderr)
        return out, float(m.group(1)) if m else float("nan")

    def reference(self, scene, name, *args):
        out = self.path(scene, name)
        if not os.path.exists(out):
            self.render(scene, name, "--mode", "reference", "--spp", str(self.a.ref_spp), *args)
        return out

    def compare(self, test, ref, depth):
        p = run([self.bin, "compare", test, ref, "--depth", depth])
        rel = float(re.search(r"relMSE\s+(\S+)", p.stdout).group(1))
        speck = float(re.search(r"speckles\s+(\S+) %", p.stdout).group(1))
        return rel, speck

    def oidn(self, raw_path, out_path):
        color = read_exr(raw_path)
        base = raw_path[: -len(".exr")]
        albedo = np.clip(read_exr(base + ".albedo.exr"), 0.0, 1.0)
        normal = np.clip(read_exr(base + ".normal.exr"), -1.0, 1.0)
        kw = dict(hdr=True, quality=self.a.quality)
        pyoidn.denoise(color, albedo, normal, **kw)  # warm-up: filter set-up
        times = []
        for _ in range(self.a.repeats):
            t = time.perf_counter()
            out = pyoidn.denoise(color, albedo, normal, **kw)
            times.append((time.perf_counter() - t) * 1e3)
        write_exr(out_path, out)
        return statistics.median(times)

    def scene(self, scene):
        a = self.a
        rows = []
        ref = self.reference(scene, "ref")
        ref_cut = self.reference(
            scene, f"ref-jump{a.cut_deg:g}", "--frames", "2", "--orbit", str(a.cut_deg)
        )
        aov = ["--aov", "albedo,normal,depth"]
        cases = [
            ("frame 1", ref, ["--frames", "1"]),
            ("jump", ref_cut, ["--frames", "2", "--orbit", str(a.cut_deg), "--taa", "off"]),
            ("16 frames", ref, ["--frames", "16"]),
        ]
        for label, truth, args in cases:
            key = label.replace(" ", "")
            raw, _ = self.render(scene, f"{key}-raw", "--denoise", "off", *aov, *args)
            dn, dn_ms = self.render(scene, f"{key}-dn", *args)
            depth = raw[: -len(".exr")] + ".depth.exr"
            oidn_out = self.path(scene, f"{key}-oidn")
            oidn_ms = self.oidn(raw, oidn_out)
            r_raw, s_raw = self.compare(raw, truth, depth)
            r_dn, s_dn = self.compare(dn, truth, depth)
            r_oi, s_oi = self.compare(oidn_out, truth, depth)
            rows.append((scene, label, r_raw, r_dn, r_oi, s_dn, s_oi, dn_ms, oidn_ms))
        return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/release/penumbra")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=180)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--cut-deg", type=float, default=30.0)
    ap.add_argument("--quality", default="fast", choices=["fast", "balanced", "high"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--out-dir", default="target/peer-denoise")
    a = ap.parse_args()
    peer = Peer(a)
    rows = []
    for s in a.scenes.split(","):
        if s not in SCENES:
            sys.exit(f"unknown scene {s} (expected any of {', '.join(SCENES)})")
        rows += peer.scene(s)
    px = a.width * a.height
    print(f"{a.width}x{a.height}, 1 spp, reference {a.ref_spp} spp, OIDN {a.quality} (albedo + normal)")
    print(
        "| scene | frame | raw relMSE | penumbra relMSE | OIDN relMSE | penumbra / OIDN "
        "| speckles penumbra | speckles OIDN | penumbra ms (ns/px) | OIDN ms (ns/px) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for scene, label, r_raw, r_dn, r_oi, s_dn, s_oi, dn_ms, oi_ms in rows:
        print(
            f"| {scene} | {label} | {r_raw:.3e} | {r_dn:.3e} | {r_oi:.3e} | {r_dn / r_oi:.2f} "
            f"| {s_dn:.3f} % | {s_oi:.3f} % | {dn_ms:.1f} ({dn_ms * 1e6 / px:.0f}) "
            f"| {oi_ms:.1f} ({oi_ms * 1e6 / px:.0f}) |"
        )


if __name__ == "__main__":
    main()
