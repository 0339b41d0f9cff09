#!/usr/bin/env bash
# The Embree 4 leg (`make test-embree4`): fetches Embree 4 into target/embree4
# (scripts/embree4-fetch.sh), builds penumbra against Debian's Embree 3 and
# then against Embree 4 in the same target dir (only the crates that depend
# on the binding are built again: penumbra-embree, penumbra-render and the
# application; the dependencies and the kernels are reused), runs the
# binding's tests against Embree 4, renders every shipped scene in every mode
# with both builds (same seed) and checks that the frames agree
# (examples/embree_agree.rs). Exits non-zero, with a line saying what
# failed, on any failure, a failed fetch included.
set -euo pipefail
cd "$(dirname "$0")/.."

CARGO=${CARGO:-cargo}
E4_DIR=${EMBREE4_DIR:-target/embree4}
OUT=${EMBREE4_COMPARE_DIR:-target/embree4-compare}
WIDTH=160
HEIGHT=90
SEED=7
# reference: spp is the total; the other modes take this many per frame.
REF_SPP=16
SPP=2

fail() {
    echo "embree4-test: FAILED: $*" >&2
    exit 1
}
step() { echo "== embree4-test: $*"; }

step "fetch Embree 4"
scripts/embree4-fetch.sh "$E4_DIR" || fail "could not fetch Embree 4 (see above); the Embree 4 leg cannot run"
E4_DIR=$(cd "$E4_DIR" && pwd)
rm -rf "$OUT"
mkdir -p "$OUT/e3" "$OUT/e4" "$OUT/bin"

step "build against Debian's Embree 3 (default) and the comparison tool"
env -u EMBREE_DIR nice -n 10 "$CARGO" build --release --bin penumbra --example embree_agree ||
    fail "default (Embree 3) build"
# Kept aside: the Embree 4 build below replaces them in target/release.
cp target/release/penumbra "$OUT/bin/penumbra-embree3"
cp target/release/examples/embree_agree "$OUT/bin/embree_agree"
E3_BIN=$OUT/bin/penumbra-embree3
AGREE=$OUT/bin/embree_agree

step "build against Embree 4 from $E4_DIR"
e4() { EMBREE_DIR=$E4_DIR "$@"; }
e4 nice -n 10 "$CARGO" build --release --bin penumbra || fail "Embree 4 build"
cp target/release/penumbra "$OUT/bin/penumbra-embree4"
E4_BIN=$OUT/bin/penumbra-embree4

# Each binary must load the Embree it was built for, found without help.
ldd "$E3_BIN" | grep 'libembree3\.so' >/dev/null || fail "$E3_BIN does not link libembree3"
e4_lib=$(env -u LD_LIBRARY_PATH ldd "$E4_BIN" | awk '/libembree4/ {print $3}')
[[ $e4_lib == "$E4_DIR"/lib/* ]] || fail "$E4_BIN loads libembree4 from '$e4_lib', not $E4_DIR/lib"
echo "$E4_BIN loads $e4_lib"

step "Embree tests against Embree 4"
e4 nice -n 10 "$CARGO" test --release -p penumbra-embree ||
    fail "the binding's tests (crates/embree: unit, binding/, doc) against Embree 4"

step "render every shipped scene with both builds (${WIDTH}x${HEIGHT}, seed $SEED)"
pairs=()
render_both() { # name, render arguments...
    local name=$1
    shift
    "$E3_BIN" render "$@" --width $WIDTH --height $HEIGHT --seed $SEED --threads 2 --out "$OUT/e3/$name.exr" >/dev/null ||
        fail "Embree 3 render $name: penumbra render $*"
    "$E4_BIN" render "$@" --width $WIDTH --height $HEIGHT --seed $SEED --threads 2 --out "$OUT/e4/$name.exr" >/dev/null ||
        fail "Embree 4 render $name: penumbra render $*"
    pairs+=("$OUT/e4/$name.exr" "$OUT/e3/$name.exr")
}
scenes=(builtin scenes/*.toml)
for scene in "${scenes[@]}"; do
    if [[ $scene == builtin ]]; then
        args=()
        base=builtin
    else
        args=("$scene")
        base=$(basename "$scene" .toml)
    fi
    for mode in ratio stochastic soft-shadow unshadowed; do
        render_both "$base-$mode" "${args[@]}" --mode $mode --spp $SPP
    done
    render_both "$base-reference" "${args[@]}" --mode reference --spp $REF_SPP
    # Temporal reprojection and jitter over a few frames.
    render_both "$base-ratio-4frames" "${args[@]}" --mode ratio --spp 1 --frames 4
done

step "the check rejects frames that differ only in seed"
other=()
for mode in ratio stochastic reference; do
    spp=$SPP
    [[ $mode == reference ]] && spp=$REF_SPP
    "$E3_BIN" render --mode $mode --spp $spp --width $WIDTH --height $HEIGHT --seed $((SEED + 1)) --threads 2 \
        --out "$OUT/e3/builtin-$mode-seed$((SEED + 1)).exr" >/dev/null || fail "Embree 3 render with seed $((SEED + 1))"
    other+=("$OUT/e3/builtin-$mode-seed$((SEED + 1)).exr" "$OUT/e3/builtin-$mode.exr")
done
"$AGREE" --expect-disagree "${other[@]}" ||
    fail "embree_agree accepted frames rendered with different seeds: the comparison is not discriminating"

step "Embree 4 frames against Embree 3 frames"
"$AGREE" "${pairs[@]}" || fail "Embree 4 frames differ from Embree 3 frames beyond the bounds (see above)"
echo "embree4-test: passed (Embree 4: $(cat "$E4_DIR/SOURCES" | tr '\n' ';'))"
