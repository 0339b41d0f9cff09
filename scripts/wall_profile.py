#!/usr/bin/env python3
"""Where the wall clock goes, kernel by kernel, from a `perf record` of
`penumbra render` (`make profile-wall`): the complement of `make profile`.

Usage: scripts/wall_profile.py PERF_DATA BINARY [--top N]

`make profile` counts instructions at the AVX2 level under valgrind: the
same on every run, but blind to what an instruction waits for (a pass that
streams memory counts few instructions and takes long) and to the wider
level this CPU may run. This samples the real run instead, at the level the
binary picks. Samples are grouped by the function they land in: the hot
loops run through `penumbra_isa::run`, whose per-level clones are
functions of their own but all share one name, so each function is named
by the most common site of its samples, found in their inlined frames: the
frame just inside `crates/isa/src/lib.rs` (the kernel's `run` body, e.g.
`spatial.rs` for the à-trous levels), or else the outermost frame of the
project's code. Samples outside the binary are counted by shared object
(Embree, libc, the kernel).

Shares are of all samples of the run (its start-up included: render enough
frames that it is small). They are CPU time, not wall time per stage:
`penumbra bench` gives the stages' wall clock.
"""

import bisect
import collections
import os
import re
import subprocess
import sys

# The repository's root: debug paths of its own files start with it (or are
# relative to it already).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + "/"


def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True, check=True).stdout


def text_mapping(perf_data, binary):
    """(map start, file offset) of the binary's executable mapping, and the
    text segment's (virtual address - file offset)."""
    name = binary.split("/")[-1]
    start = pgoff = None
    for line in run(["perf", "script", "-i", perf_data, "--show-mmap-events"]).splitlines():
        if "PERF_RECORD_MMAP" in line and "r-xp" in line and line.rstrip().endswith(name):
            m = re.search(r"\[(0x[0-9a-f]+)\((0x[0-9a-f]+)\) @ (0x[0-9a-f]+|0) ", line)
            if m:
                start, pgoff = int(m.group(1), 16), int(m.group(3), 16)
                break
    if start is None:
        sys.exit(f"wall_profile: no executable mapping of {name} in {perf_data}")
    shift = None
    for line in run(["readelf", "-lW", binary]).splitlines():
        f = line.split()
        # LOAD offset vaddr paddr filesz memsz flags... align
        if f and f[0] == "LOAD" and any("E" in flag for flag in f[6:-1]):
            shift = int(f[2], 16) - int(f[1], 16)
            break
    if shift is None:
        sys.exit(f"wall_profile: no executable segment in {binary}")
    return start, pgoff, shift


def site(frames):
    """The kernel site of one sample from its inlined frames, innermost
    first (`file:line`, project files only)."""
    own = [f for f in frames if f.startswith("crates/") or f.startswith("src/")]
    for i, f in enumerate(own):
        if f.startswith("crates/isa/src/lib.rs"):
            return own[i - 1] if i > 0 else f
    return own[-1] if own else "(no line)"


def main():
    args = sys.argv[1:]
    top = 25
    if "--top" in args:
        i = args.index("--top")
        top = int(args[i + 1])
        del args[i : i + 2]
    if len(args) != 2:
        sys.exit(__doc__)
    perf_data, binary = args
    start, pgoff, shift = text_mapping(perf_data, binary)
    samples = collections.Counter()
    outside = collections.Counter()
    for line in run(["perf", "script", "-i", perf_data, "-F", "ip,dso"]).splitlines():
        f = line.split()
        if len(f) < 2:
            continue
        ip, dso = int(f[0], 16), f[1].strip("()")
        if dso.endswith(binary.split("/")[-1]):
            samples[ip - start + pgoff + shift] += 1
        else:
            outside[dso.split("/")[-1]] += 1
    total = sum(samples.values()) + sum(outside.values())
    if total == 0:
        sys.exit("wall_profile: no samples")
    addrs = list(samples)
    out = run(["addr2line", "-i", "-a", "-e", binary] + [hex(a) for a in addrs])
    frames, cur = {}, None
    for line in out.splitlines():
        if line.startswith("0x"):
            cur = int(line, 16)
            frames[cur] = []
        elif cur is not None:
            path = line.split(" ")[0]
            # The standard library's and the dependencies' lines are not
            # the project's (`/rustc/...`, `~/.cargo/registry/...`).
            if not (path.startswith("/") and not path.startswith(ROOT)):
                frames[cur].append(path.removeprefix(ROOT))
    # Samples by the function they land in (every per-level clone of a
    # kernel is a function of its own), each function named by its most
    # common site.
    syms = []
    for line in run(["nm", "-C", "-n", "--defined-only", binary]).splitlines():
        f = line.split(" ", 2)
        if len(f) == 3 and f[1] in "tTwW":
            syms.append((int(f[0], 16), f[2]))
    starts = [a for a, _ in syms]
    sites = collections.defaultdict(collections.Counter)
    for a, n in samples.items():
        i = bisect.bisect_right(starts, a) - 1
        sites[i][site(frames.get(a, []))] += n
    by_site = collections.Counter()
    for i, c in sites.items():
        name = syms[i][1] if i >= 0 else "?"
        label = c.most_common(1)[0][0]
        if not name.startswith("penumbra_isa::"):
            label = f"{label} in {re.sub(r'<[^<>]*>', '', name)}"
        by_site[label] += sum(c.values())
    rows = [(s, n) for s, n in by_site.items()] + [(f"[{d}]", n) for d, n in outside.items()]
    rows.sort(key=lambda r: -r[1])
    print(f"{total} samples; share of all samples by kernel site (project) or shared object [..]")
    for s, n in rows[:top]:
        print(f"{100.0 * n / total:6.2f} %  {s}")
    rest = sum(n for _, n in rows[top:])
    print(f"{100.0 * rest / total:6.2f} %  (the rest, {len(rows) - top} sites)")


if __name__ == "__main__":
    main()
