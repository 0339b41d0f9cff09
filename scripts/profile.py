#!/usr/bin/env python3
"""Instructions per pixel per frame, stage by stage, from a callgrind run of
`penumbra render` (`make profile`): a count that is the same on every run of
the same binary and inputs, whatever else the machine is doing.

Usage: scripts/profile.py CALLGRIND_OUT PIXELS FRAMES [--json OUT.json]

Each stage is the inclusive count of the functions that open it (they are
kept out of line for this, `#[inline(never)]`); the stages do not call one
another, so they add up, and `other` is what the frame spends outside them
(the band loop, the guides, the resolve's input, buffers). Embree's part is
the inclusive count of its query entry points (`rtcIntersect*` under the
primary stage, `rtcOccluded*` under the shadow stage). The budget column is
the per-stage ceiling the frame is designed to (docs/performance.md).
"""

import json
import re
import sys

# (key, label, function-name patterns (regex on the demangled name), budget)
STAGES = [
    ("primary", "primary rays + material resolve", [r"^penumbra_render::primary::trace_rows$"], 600),
    ("u", "U (analytic, every light)", [r"^penumbra_render::estimate::unshadowed::analytic_u_band$"], 1000),
    ("sampling", "sampling + MIS + shadow-ray set-up", [r"^penumbra_render::estimate::samples::draw_samples$"], 500),
    ("shadow", "shadow rays traced", [r"^penumbra_render::shadow::ShadowBatch::trace$"], None),
    ("denoise", "denoiser", [r"^penumbra_denoise::Denoiser::denoise(_sparse)?$"], 1000),
    ("upsample", "quarter-rate upsampling", [r"^penumbra_render::quads::upsample$"], None),
    ("composite", "composite", [r"^penumbra_render::frame::composite::<impl penumbra_render::frame::Frame>::composite$"], None),
    ("resolve", "temporal resolve", [r"^penumbra_render::frame::composite::<impl penumbra_render::frame::Frame>::resolve_colour$"], None),
]
FRAME = r"^penumbra_render::frame::Frame::render$"
EMBREE = {"primary": r"^rtcIntersect(1|4|8|16)$", "shadow": r"^rtcOccluded(1|4|8|16)$"}
# compose + resolve share one budget, as the design states it.
JOINT_BUDGETS = {("composite", "resolve"): 300}
TOTAL_BUDGET = 4000

def inclusive_counts(path):
    """{function name: inclusive Ir}, read from the callgrind file itself: a
    function's own instructions plus what its calls to other functions cost
    (callgrind records each call's inclusive cost on the line after
    `calls=`). Names are merged across the files their inlined code comes
    from."""
    names = {}

    def name_of(ref):
        m = re.match(r"\((\d+)\)(?: (.*))?$", ref.strip())
        if not m:
            return ref.strip()
        if m.group(2) is not None:
            names[m.group(1)] = m.group(2)
        return names.get(m.group(1), m.group(1))

    own = {}
    calls = {}
    fn = callee = None
    call_line = False
    with open(path) as f:
        for line in f:
            if line.startswith("fn="):
                fn = name_of(line[3:])
            elif line.startswith("cfn="):
                callee = name_of(line[4:])
            elif line.startswith("calls="):
                call_line = True
            elif line[:1].isdigit() or line[:1] in "+-*":
                parts = line.split()
                cost = int(parts[1]) if len(parts) > 1 else 0
                if call_line:
                    if callee != fn:
                        calls[fn] = calls.get(fn, 0) + cost
                    call_line = False
                else:
                    own[fn] = own.get(fn, 0) + cost
    return {k: own.get(k, 0) + calls.get(k, 0) for k in set(own) | set(calls)}


def total_of(counts, pattern):
    rx = re.compile(pattern)
    return sum(v for k, v in counts.items() if rx.search(k))


def main():
    args = sys.argv[1:]
    json_out = None
    if "--json" in args:
        i = args.index("--json")
        json_out = args[i + 1]
        del args[i : i + 2]
    if len(args) != 3:
        sys.exit(__doc__)
    path, pixels, frames = args[0], int(args[1]), int(args[2])
    counts = inclusive_counts(path)
    per = float(pixels * frames)
    frame = total_of(counts, FRAME)
    if frame == 0:
        sys.exit(f"profile: no cost under Frame::render in {path}")
    rows = []
    accounted = 0
    for key, label, patterns, budget in STAGES:
        ir = sum(total_of(counts, p) for p in patterns)
        accounted += ir
        row = {"stage": key, "label": label, "ir_per_pixel": ir / per, "budget": budget}
        if key in EMBREE:
            row["embree_per_pixel"] = total_of(counts, EMBREE[key]) / per
        rows.append(row)
    rows.append({"stage": "other", "label": "other (band loop, guides, buffers)", "ir_per_pixel": (frame - accounted) / per, "budget": None})
    total = {"stage": "frame", "label": "frame", "ir_per_pixel": frame / per, "budget": TOTAL_BUDGET,
             "embree_per_pixel": sum(r.get("embree_per_pixel", 0.0) for r in rows)}

    print(f"{'stage':36s} {'Ir/px':>9s} {'Embree':>8s} {'budget':>7s}")
    for r in rows + [total]:
        emb = f"{r['embree_per_pixel']:8.0f}" if "embree_per_pixel" in r else " " * 8
        bud = f"{r['budget']:7d}" if r["budget"] else " " * 7
        print(f"{r['label']:36s} {r['ir_per_pixel']:9.0f} {emb} {bud}")
    for keys, budget in JOINT_BUDGETS.items():
        joint = sum(r["ir_per_pixel"] for r in rows if r["stage"] in keys)
        print(f"{' + '.join(keys):36s} {joint:9.0f} {'':8s} {budget:7d}")
    if json_out:
        with open(json_out, "w") as f:
            json.dump({"pixels": pixels, "frames": frames, "stages": rows, "frame": total}, f, indent=2)


if __name__ == "__main__":
    main()
