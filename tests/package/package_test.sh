#!/usr/bin/env bash
# package.deb: builds this build's Debian packages (cmake/package.cmake), checks their contents
# and metadata against independent sources (the executables' NEEDED libraries resolved with
# dpkg -S, the DEP-5 format), and, as root, installs them with apt-get on this machine, runs
# the installed programs from /usr/bin in an empty folder (scaratwin fk, a short demo), checks
# the messages for a moved data folder and a missing runtime package, and removes them.
#
#   package_test.sh BUILD_DIR WORK_DIR
#
# Not root: the install part is skipped with a message (exit 77, ctest's SKIP_RETURN_CODE),
# unless SCARATWIN_PACKAGE_TEST=required (scripts/test.sh, CI) makes that a failure.
set -euo pipefail
build=$1
work=$2
fail() {
  echo "FAIL: $*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work/debs" "$work/empty" "$work/home"
cd "$work"

# 1. build the packages. The release packages are xz-compressed (cmake/package.cmake, checked
# here); this test writes them with gzip, which dpkg reads the same way: xz takes a minute
# for the sanitizer build's binaries, gzip a few seconds, and compression is all that differs
grep -qx 'set(CPACK_DEBIAN_COMPRESSION_TYPE "xz")' "$build/CPackConfig.cmake" ||
  fail "the packages are not configured for xz compression ($build/CPackConfig.cmake)"
cpack --config "$build/CPackConfig.cmake" -B "$work/debs" -D CPACK_DEBIAN_COMPRESSION_TYPE=gzip \
  >"$work/cpack.log" 2>&1 || { cat "$work/cpack.log"; fail "cpack failed"; }
arch=$(dpkg --print-architecture)
version=$(sed -n 's/^set(CPACK_PACKAGE_VERSION "\(.*\)")$/\1/p' "$build/CPackConfig.cmake")-1
main_deb=$work/debs/scaratwin_${version}_${arch}.deb
emu_deb=$work/debs/scaratwin-emulator_${version}_${arch}.deb
for deb in "$main_deb" "$emu_deb"; do
  [[ -f $deb ]] || fail "no $(basename "$deb") in $work/debs: $(ls "$work/debs")"
done
echo "built $(basename "$main_deb") ($(du -h "$main_deb" | cut -f1)) and" \
  "$(basename "$emu_deb") ($(du -h "$emu_deb" | cut -f1))"

# 2. contents: each file in the package it belongs to, and only there
dpkg-deb -c "$main_deb" | awk '{print $6}' | sed 's|^\./|/|' >main.files
dpkg-deb -c "$emu_deb" | awk '{print $6}' | sed 's|^\./|/|' >emu.files
for f in /usr/bin/scaratwin /usr/bin/scaratwin-sim \
  /usr/share/scaratwin/config/scara.toml \
  /usr/share/scaratwin/firmware/uno/scaratwin-fw-uno.hex \
  /usr/share/scaratwin/firmware/uno/scaratwin-fw-uno.elf \
  /usr/share/scaratwin/firmware/mega/scaratwin-fw-mega.hex \
  /usr/share/scaratwin/firmware/bootloader/optiboot-uno.hex \
  /usr/share/scaratwin/web/index.html /usr/share/scaratwin/web/vendor/three/three.module.js \
  /usr/lib/libscaratwin_kinematics.a /usr/include/scaratwin/kinematics/kinematics.hpp \
  /usr/lib/cmake/scaratwin/scaratwinConfig.cmake \
  /usr/share/bash-completion/completions/scaratwin \
  /usr/share/man/man1/scaratwin.1.gz /usr/share/man/man1/scaratwin-sim.1.gz \
  /usr/share/doc/scaratwin/copyright /usr/share/doc/scaratwin/changelog.Debian.gz; do
  grep -qx "$f" main.files || fail "scaratwin has no $f"
done
for f in /usr/bin/scaratwin-robot /usr/share/man/man1/scaratwin-robot.1.gz \
  /usr/share/bash-completion/completions/scaratwin-robot \
  /usr/share/doc/scaratwin-emulator/copyright \
  /usr/share/doc/scaratwin-emulator/changelog.Debian.gz; do
  grep -qx "$f" emu.files || fail "scaratwin-emulator has no $f"
done
grep -qx /usr/bin/scaratwin-robot main.files && fail "the GPL emulator is in scaratwin"
[[ $(grep -c '^/usr/bin/.' emu.files) == 1 ]] || fail "scaratwin-emulator holds more than" \
  "scaratwin-robot: $(grep '^/usr/bin/.' emu.files)"
overlap=$(comm -12 <(grep -v '/$' main.files | sort) <(grep -v '/$' emu.files | sort))
[[ -z $overlap ]] || fail "files in both packages: $overlap"

# 3. metadata: licences and Depends
dpkg-deb -x "$main_deb" main.root
dpkg-deb -x "$emu_deb" emu.root
for pkg in scaratwin scaratwin-emulator; do
  root=main.root
  [[ $pkg == scaratwin-emulator ]] && root=emu.root
  c=$root/usr/share/doc/$pkg/copyright
  head -1 "$c" | grep -qx 'Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' ||
    fail "$c: not a DEP-5 copyright file"
done
grep -q '^License: Apache-2.0$' main.root/usr/share/doc/scaratwin/copyright ||
  fail "scaratwin's copyright names no Apache-2.0"
grep -q '^License: GPL-3.0-or-later$' emu.root/usr/share/doc/scaratwin-emulator/copyright ||
  fail "scaratwin-emulator's copyright names no GPL-3.0-or-later"
zcat main.root/usr/share/man/man1/scaratwin.1.gz | grep -q '^\.TH SCARATWIN "1"' ||
  fail "scaratwin.1 is no man page"
zcat main.root/usr/share/man/man1/scaratwin.1.gz | grep -q 'calibrate' ||
  fail "scaratwin.1 does not list the subcommands"

# every shared library an executable links must come from a package its Depends names:
# readelf's NEEDED entries, resolved to files with ldconfig and to packages with dpkg -S
# (independent of dpkg-shlibdeps, which made the Depends)
ldconfig -p >ldconfig.txt
check_depends() { # deb root executables...
  local deb=$1 root=$2 depends lib path owner
  shift 2
  depends=$(dpkg-deb -f "$deb" Depends)
  echo "$(basename "$deb") Depends: $depends"
  for exe in "$@"; do
    for lib in $(readelf -d "$root$exe" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
      path=$(awk -v l="$lib" '$1 == l && /x86-64/ {print $NF}' ldconfig.txt | head -1)
      [[ -n $path ]] || path=$(awk -v l="$lib" '$1 == l {print $NF}' ldconfig.txt | head -1)
      [[ -n $path ]] || fail "$exe needs $lib, which this machine does not have"
      owner=$({ dpkg -S "$(readlink -f "$path")" || dpkg -S "$path"; } 2>/dev/null | head -1 |
        cut -d: -f1)
      [[ -n $owner ]] || fail "no package owns $path ($lib, needed by $exe)"
      tr ',|' '\n\n' <<<"$depends" | awk '{print $1}' | grep -qxF "$owner" ||
        fail "$exe needs $lib from $owner, which Depends does not name: $depends"
      echo "  $exe: $lib from $owner"
    done
  done
}
check_depends "$main_deb" main.root /usr/bin/scaratwin /usr/bin/scaratwin-sim
check_depends "$emu_deb" emu.root /usr/bin/scaratwin-robot
for pkg in libegl-mesa0 libgl1-mesa-dri; do # loaded by libglvnd at run time, not linked
  dpkg-deb -f "$main_deb" Depends | grep -q "$pkg" || fail "scaratwin does not depend on $pkg"
done
dpkg-deb -f "$main_deb" Depends | grep -q libmosquitto1 ||
  fail "scaratwin does not depend on libmosquitto1 (the hub's --mqtt)"
dpkg-deb -f "$main_deb" Depends | grep -q libzstd1 ||
  fail "scaratwin does not depend on libzstd1 (scaratwin export --mcap)"
dpkg-deb -f "$emu_deb" Depends | grep -q "scaratwin (= $version)" ||
  fail "scaratwin-emulator does not depend on its scaratwin"

# 4. install, run, remove (root only)
if [[ $(id -u) -ne 0 ]]; then
  if [[ ${SCARATWIN_PACKAGE_TEST:-} == required ]]; then
    fail "not root: cannot install the packages (SCARATWIN_PACKAGE_TEST=required)"
  fi
  echo "SKIPPED: installing the packages needs root (the packages were built and checked)"
  exit 77
fi
for pkg in scaratwin scaratwin-emulator; do
  if dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed'; then
    fail "$pkg is installed on this machine already; this test installs and removes it," \
      "so remove it first (apt-get remove $pkg)"
  fi
done
moved=
cleanup() {
  [[ -n $moved ]] && mv "$moved" /usr/share/scaratwin
  DEBIAN_FRONTEND=noninteractive apt-get remove -y -qq scaratwin-emulator scaratwin \
    >"$work/remove.log" 2>&1 || true
}
trap cleanup EXIT
cd "$work/debs"
DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
  "./$(basename "$main_deb")" "./$(basename "$emu_deb")" >"$work/install.log" 2>&1 ||
  { cat "$work/install.log"; fail "apt-get install failed"; }
echo "installed: $(dpkg-query -W -f='${Package} ${Version}; ' scaratwin scaratwin-emulator)"

# from an empty folder, with /usr/bin on the PATH, no build or source tree anywhere in reach
cd "$work/empty"
run() {
  env -i HOME="$work/home" PATH=/usr/bin:/bin LANG=C.UTF-8 \
    ASAN_OPTIONS="${ASAN_OPTIONS:-}" UBSAN_OPTIONS="${UBSAN_OPTIONS:-}" "$@"
}
[[ $(command -v scaratwin) == /usr/bin/scaratwin || $(run sh -c 'command -v scaratwin') == /usr/bin/scaratwin ]] ||
  fail "scaratwin is not /usr/bin/scaratwin"
fk=$(run scaratwin fk 0.12 0 0 0) || fail "scaratwin fk failed: $fk"
echo "$ scaratwin fk 0.12 0 0 0"
echo "$fk"
# the oracle: with every angle 0 the DH chain is straight, so x = the sum of the a_m and
# z = d1 + the sum of the d_m of the description installed in /usr/share/scaratwin
want=$(awk -F'=' '/^a_m/ {x += $2} /^d_m/ {z += $2} END {printf "x = %.6f m  y = 0.000000 m  z = %.6f m", x, 0.12 + z}' \
  /usr/share/scaratwin/config/scara.toml)
grep -qF "$want" <<<"$fk" || fail "scaratwin fk: expected '$want' (the installed description's DH), got: $fk"

# a moved data folder: the message names the folder it looked for
moved=/usr/share/scaratwin.moved-by-package-test
mv /usr/share/scaratwin "$moved"
set +e
msg=$(run scaratwin fk 0.12 0 0 0 2>&1)
rc=$?
set -e
mv "$moved" /usr/share/scaratwin
moved=
[[ $rc == 2 ]] || fail "moved data folder: exit status $rc, expected 2: $msg"
grep -q "data folder '/usr/share/scaratwin' does not exist" <<<"$msg" ||
  fail "moved data folder: the message does not name /usr/share/scaratwin: $msg"
echo "moved data folder: $msg"

# a missing runtime package: libegl-mesa0 puts Mesa's EGL vendor file where libglvnd looks;
# pointing libglvnd at no vendor is the machine without it. The message names the packages.
set +e
msg=$(run __EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent/50_mesa.json scaratwin-sim --port 0 \
  --http-port 0 2>&1)
rc=$?
set -e
[[ $rc == 1 ]] || fail "no EGL vendor: scaratwin-sim exit status $rc, expected 1: $msg"
grep -q "install libegl-mesa0 and libgl1-mesa-dri" <<<"$msg" ||
  fail "no EGL vendor: the message does not name the packages: $msg"
echo "no EGL vendor: $msg"

# the short demo (one cube, the emulated robot at twice real time) from the empty folder; a
# bad count is refused before anything starts
set +e
msg=$(run scaratwin demo --cubes 4 2>&1)
rc=$?
set -e
[[ $rc == 2 && $msg == *"--cubes: Value 4 not in range 1 to 3"* && ! -e scaratwin-out ]] ||
  fail "scaratwin demo --cubes 4: exit status $rc, expected 2 and nothing written: $msg"
echo "$ scaratwin demo $SCARATWIN_PACKAGE_DEMO_ARGS"
# shellcheck disable=SC2086
run scaratwin demo $SCARATWIN_PACKAGE_DEMO_ARGS >"$work/demo.log" 2>&1 ||
  { tail -40 "$work/demo.log"; fail "the installed scaratwin demo failed"; }
tail -1 "$work/demo.log"
grep -q "^demo passed in .* s: 1 of 1 cubes in their trays" "$work/demo.log" ||
  fail "the demo did not sort its one cube: $(tail -1 "$work/demo.log")"
[[ -f scaratwin-out/twin.db && -f scaratwin-out/report.html ]] ||
  fail "the demo left no scaratwin-out/twin.db and report.html in the empty folder"
echo "package test passed"
