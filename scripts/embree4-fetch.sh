#!/usr/bin/env bash
# Fetches an Embree 4 into a prefix (default target/embree4) without
# installing anything: `include/embree4/` and `lib/`, the layout build.rs
# reads from EMBREE_DIR. Nothing outside the prefix is changed; the system's
# apt sources stay as they are.
#
# - Headers: Debian's libembree-dev from EMBREE4_SUITE (default trixie,
#   Embree 4.3.3), via a private apt configuration under the prefix.
# - Library: libembree4 (and the TBB it was built with) from the PyPI wheel
#   embreex==EMBREE4_WHEEL_VERSION. Debian 13's own libembree4 needs glibc
#   2.38 and libstdc++ GLIBCXX_3.4.32, newer than Debian 12's 2.36 / 3.4.30;
#   the wheel's manylinux_2_28 build needs glibc 2.27 at most.
#
# Headers 4.3 with library 4.4 is the direction Embree's ABI allows (one
# soname per major version; minor versions only add). The script refuses a
# header whose major is not 4 or whose version is newer than the library's.
#
# Any failure exits non-zero with one line saying what failed.
set -euo pipefail

PREFIX=${1:-target/embree4}
SUITE=${EMBREE4_SUITE:-trixie}
WHEEL_VERSION=${EMBREE4_WHEEL_VERSION:-4.4.0.post1}
# sha256 of embreex-4.4.0.post1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl
# (`sha256sum` of the file `pip download` saved); empty skips the check.
WHEEL_SHA256=${EMBREE4_WHEEL_SHA256-2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f}
WHEEL_PLATFORM=manylinux_2_28_x86_64
WHEEL_PYTHON=3.11

fail() {
    echo "embree4-fetch: FAILED: $*" >&2
    exit 1
}

stamp="$SUITE $WHEEL_VERSION $WHEEL_SHA256"
if [[ -f $PREFIX/.complete && $(cat "$PREFIX/.complete") == "$stamp" ]]; then
    echo "embree4-fetch: using $PREFIX ($stamp)"
    exit 0
fi

command -v apt-get >/dev/null || fail "apt-get not found (the headers come from a Debian package)"
command -v dpkg-deb >/dev/null || fail "dpkg-deb not found"
python=$(command -v python3 || true)
[[ -n $python ]] || fail "python3 not found (pip downloads the library wheel)"
"$python" -m pip --version >/dev/null 2>&1 || fail "python3 -m pip does not work (pip downloads the library wheel)"

rm -rf "$PREFIX"
mkdir -p "$PREFIX"
PREFIX=$(cd "$PREFIX" && pwd)
work=$PREFIX/fetch
mkdir -p "$work/apt/lists/partial" "$work/apt/cache/archives/partial" "$work/debs" "$work/wheel"

# The Debian archive this machine's apt already uses, read from its own
# sources, so the private configuration reaches the same mirror.
uri=${EMBREE4_APT_URI:-}
if [[ -z $uri ]]; then
    uri=$(grep -hs '^URIs:' /etc/apt/sources.list.d/*.sources | awk '{print $2}' | grep -v -- '-security' | head -n 1 || true)
fi
if [[ -z $uri ]]; then
    uri=$(grep -hs '^deb ' /etc/apt/sources.list /etc/apt/sources.list.d/*.list | awk '{print $2}' | grep -v -- '-security' | head -n 1 || true)
fi
[[ -n $uri ]] || fail "no Debian archive URI in /etc/apt/sources.list{,.d/} (set EMBREE4_APT_URI)"
keyring=/usr/share/keyrings/debian-archive-keyring.gpg
[[ -f $keyring ]] || fail "$keyring missing (install debian-archive-keyring)"
cat >"$work/apt/sources.sources" <<EOF
Types: deb
URIs: $uri
Suites: $SUITE
Components: main
Signed-By: $keyring
EOF

apt_opts=(
    -o "Dir::Etc::sourcelist=$work/apt/sources.sources"
    -o "Dir::Etc::sourceparts=/dev/null"
    -o "Dir::State::Lists=$work/apt/lists"
    -o "Dir::Cache=$work/apt/cache"
    -o "Acquire::IndexTargets::deb::DEP-11::DefaultEnabled=false"
    -o "Acquire::IndexTargets::deb::Contents-deb::DefaultEnabled=false"
    -o "APT::Sandbox::User=root"
)
echo "embree4-fetch: apt index of suite '$SUITE'"
# apt-get update exits 0 on an unknown suite; its "E:"/"W:" lines tell.
if ! apt-get "${apt_opts[@]}" update >"$work/apt-update.log" 2>&1 ||
    grep -qE '^(E:|W: (Failed|The repository|GPG))' "$work/apt-update.log"; then
    cat "$work/apt-update.log" >&2
    fail "apt-get update of Debian suite '$SUITE' from $uri (see the lines above)"
fi
(cd "$work/debs" && apt-get "${apt_opts[@]}" download libembree-dev) >"$work/apt-download.log" 2>&1 || {
    cat "$work/apt-download.log" >&2
    fail "apt-get download libembree-dev from suite '$SUITE'"
}
deb=$(ls "$work"/debs/libembree-dev_*.deb 2>/dev/null | head -n 1)
[[ -n $deb ]] || fail "apt-get download left no libembree-dev .deb"
dpkg-deb -x "$deb" "$work/deb-root" || fail "dpkg-deb -x $deb"
[[ -f $work/deb-root/usr/include/embree4/rtcore.h ]] ||
    fail "$(basename "$deb") has no include/embree4/rtcore.h (suite '$SUITE' ships Embree $(dpkg-deb -f "$deb" Version), not 4)"
mkdir -p "$PREFIX/include"
# -a keeps the package's mtimes: a fresh fetch of the same headers does
# not make cargo rebuild (build.rs watches rtcore.h).
cp -a "$work/deb-root/usr/include/embree4" "$PREFIX/include/"

echo "embree4-fetch: wheel embreex==$WHEEL_VERSION"
"$python" -m pip download --quiet --no-deps --only-binary=:all: \
    --platform "$WHEEL_PLATFORM" --python-version "$WHEEL_PYTHON" \
    -d "$work/wheel" "embreex==$WHEEL_VERSION" >"$work/pip.log" 2>&1 || {
    cat "$work/pip.log" >&2
    fail "pip download embreex==$WHEEL_VERSION"
}
whl=$(ls "$work"/wheel/embreex-*.whl 2>/dev/null | head -n 1)
[[ -n $whl ]] || fail "pip download left no embreex wheel"
if [[ -n $WHEEL_SHA256 ]]; then
    got=$(sha256sum "$whl" | awk '{print $1}')
    [[ $got == "$WHEEL_SHA256" ]] || fail "$(basename "$whl") has sha256 $got, expected $WHEEL_SHA256"
fi
"$python" -m zipfile -e "$whl" "$work/wheel/x" || fail "unzip $(basename "$whl")"
mkdir -p "$PREFIX/lib"
cp "$work"/wheel/x/embreex.libs/*.so* "$PREFIX/lib/" 2>/dev/null ||
    fail "$(basename "$whl") has no embreex.libs/*.so*"
lib=$(cd "$PREFIX/lib" && ls libembree4*.so.4 2>/dev/null | head -n 1)
[[ -n $lib ]] || fail "$(basename "$whl") ships no libembree4*.so.4"
# The wheel's library has a hashed soname; the link step looks for libembree4.so.
ln -sfn "$lib" "$PREFIX/lib/libembree4.so"

# The library must load here: every dependency found, no symbol version missing.
if ldd_out=$(ldd "$PREFIX/lib/$lib" 2>&1) && ! grep -qE 'not found|version .* not found' <<<"$ldd_out"; then
    :
else
    echo "$ldd_out" >&2
    fail "$lib does not load on this system (see ldd above)"
fi

macro() { awk -v m="$1" '$1 == "#define" && $2 == m {print $3}' "$PREFIX/include/embree4/rtcore_config.h"; }
h_major=$(macro RTC_VERSION_MAJOR)
h_version=$(macro RTC_VERSION)
[[ $h_major == 4 ]] || fail "headers are Embree major '$h_major', not 4"
# The library's version is its only string that is a bare 4.x.y.
l_version=$(strings -n 5 "$PREFIX/lib/$lib" | grep -m1 -xE '4\.[0-9]+\.[0-9]+' || true)
[[ -n $l_version ]] || fail "cannot read the Embree version out of $lib"
IFS=. read -r lmaj lmin lpat <<<"$l_version"
l_num=$((lmaj * 10000 + lmin * 100 + lpat))
((h_version <= l_num)) ||
    fail "headers $h_version are newer than library $l_version: the binary could call what the library lacks"

{
    echo "headers: $(basename "$deb") (Debian $SUITE), RTC_VERSION $h_version"
    echo "library: $lib (Embree $l_version) from $(basename "$whl")"
} >"$PREFIX/SOURCES"
rm -rf "$work"
echo "$stamp" >"$PREFIX/.complete"
cat "$PREFIX/SOURCES"
echo "embree4-fetch: ready in $PREFIX"
