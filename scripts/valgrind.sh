#!/usr/bin/env bash
# Runs valgrind with the given arguments, from a copy that decodes the
# renderer's AVX2 kernels. Debian 12's valgrind 3.19 stops on the register
# form of VEX `vmovq` (opcode 0xD6, "unhandled instruction bytes"), which
# LLVM emits in the AVX2 camera-ray kernel; Debian 13's 3.24 runs it.
#
# - VALGRIND_BIN=path: use that valgrind as it is.
# - Otherwise Debian's valgrind from VALGRIND_SUITE (default trixie) is
#   fetched once into target/valgrind through a private apt configuration
#   (the system's apt sources stay as they are), unpacked, not installed, and
#   run with VALGRIND_LIB pointing at its tools.
#
# Any failure to fetch exits non-zero with one line saying what failed.
set -euo pipefail

if [[ -n ${VALGRIND_BIN:-} ]]; then
    exec "$VALGRIND_BIN" "$@"
fi

PREFIX=target/valgrind
SUITE=${VALGRIND_SUITE:-trixie}

fail() {
    echo "valgrind.sh: FAILED: $*" >&2
    exit 1
}

if [[ ! -f $PREFIX/.complete || $(cat "$PREFIX/.complete") != "$SUITE" ]]; then
    rm -rf "$PREFIX"
    mkdir -p "$PREFIX/apt/lists/partial" "$PREFIX/apt/cache/archives/partial" "$PREFIX/deb"
    echo "deb http://deb.debian.org/debian $SUITE main" >"$PREFIX/apt/sources.list"
    apt=(apt-get -q
        -o "Dir::Etc::sourcelist=$PWD/$PREFIX/apt/sources.list"
        -o "Dir::Etc::sourceparts=-"
        -o "Dir::State::lists=$PWD/$PREFIX/apt/lists"
        -o "Dir::Cache=$PWD/$PREFIX/apt/cache"
        -o "APT::Sandbox::User=root")
    "${apt[@]}" update >"$PREFIX/fetch.log" 2>&1 ||
        fail "apt-get update for $SUITE (see $PREFIX/fetch.log)"
    (cd "$PREFIX/deb" && "${apt[@]}" download valgrind >>"../fetch.log" 2>&1) ||
        fail "apt-get download valgrind from $SUITE (see $PREFIX/fetch.log)"
    deb=$(ls "$PREFIX"/deb/valgrind_*.deb 2>/dev/null | head -n 1)
    [[ -n $deb ]] || fail "no valgrind package in $PREFIX/deb"
    dpkg-deb -x "$deb" "$PREFIX/root" || fail "unpacking $deb"
    [[ -x $PREFIX/root/usr/bin/valgrind ]] || fail "no usr/bin/valgrind in $deb"
    echo "$SUITE" >"$PREFIX/.complete"
fi

export VALGRIND_LIB=$PWD/$PREFIX/root/usr/libexec/valgrind
exec "$PREFIX/root/usr/bin/valgrind" "$@"
