#!/usr/bin/env bash
# SPDX-License-Identifier: LGPL-2.1-or-later
# make test-freecad1: the whole suite on FreeCAD 1.0 (Debian 13 "trixie") in a root kept in
# .cache/debian13/ of this checkout, made once with debootstrap from the mirror apt already uses.
#
#   FREECAD1_TREE=worktree   test the working tree as it is (default: a fresh clone of HEAD)
#   FREECAD1_ROOT=DIR        keep the root elsewhere
#   FREECAD1_PYTEST="ARGS"   pytest arguments instead of the whole suite (make test)
#
# Where the machine cannot make the root (not root, no debootstrap to be had, mounting refused)
# it says so in one line with the word "skipped" and exits 0; a failing test fails the target.
set -uo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
root=${FREECAD1_ROOT:-$top/.cache/debian13}
packages="freecad python3-numpy python3-scipy python3-matplotlib python3-serial python3-pytest python3-pytest-xdist python3-hypothesis python3-dask python3-distributed xvfb xauth make git"

say() { echo "test-freecad1: $*" >&2; }
skip() { echo "test-freecad1: skipped: $*"; exit 0; }

[ "$(id -u)" -eq 0 ] || skip "not root: making and mounting a Debian 13 root needs root"

if ! command -v debootstrap >/dev/null 2>&1; then
  say "installing debootstrap"
  { apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y debootstrap; } >&2 \
    || skip "debootstrap is not installed and apt-get could not install it"
fi

# The mirror this machine's apt already uses (deb822 .sources first, then one-line lists).
mirror=$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null \
  | awk '/^URIs:/ {for (i = 2; i <= NF; i++) if ($i ~ /debian\/?$/ && $i !~ /security/) {print $i; exit}}')
if [ -z "$mirror" ]; then
  mirror=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null \
    | awk '$1 == "deb" {for (i = 2; i <= NF; i++) if ($i ~ /^(https?|file):/ && $i ~ /debian\/?$/ && $i !~ /security/) {print $i; exit}}')
fi
[ -n "$mirror" ] || { say "no Debian mirror found in /etc/apt/sources*: cannot make the root"; exit 1; }

mounted=()
cleanup() {
  local i
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount -l "${mounted[i]}" 2>/dev/null; done
}
trap cleanup EXIT
bind() {  # bind SRC: mount SRC at the same place inside the root
  mkdir -p "$root$1"
  mount --bind "$1" "$root$1" 2>/dev/null || return 1
  mounted+=("$root$1")
}

# Never delete a root that still has something mounted inside (a bind of the host's /dev...).
mounts_inside() { awk -v r="$root/" 'index($2 "/", r) == 1 {print $2}' /proc/mounts; }

# The ready mark holds the package list it was made with: a changed list installs again.
if [ "$(cat "$root/.bladerecon-ready" 2>/dev/null)" != "$packages" ]; then
  if [ ! -e "$root/.bladerecon-bootstrapped" ]; then
    [ -z "$(mounts_inside)" ] || { say "still mounted inside $root: $(mounts_inside | tr '\n' ' ')(umount them first)"; exit 1; }
    rm -rf "$root"
    mkdir -p "$root"
    say "debootstrap --variant=minbase trixie $root (about a minute)"
    ok=0
    for attempt in 1 2; do
      if debootstrap --variant=minbase trixie "$root" "$mirror" >"$root.debootstrap.log" 2>&1; then ok=1; break; fi
      say "debootstrap attempt $attempt failed (log: $root.debootstrap.log)"
      rm -rf "$root"; mkdir -p "$root"
    done
    [ $ok -eq 1 ] || { tail -5 "$root.debootstrap.log" >&2; exit 1; }
    touch "$root/.bladerecon-bootstrapped"
  fi
  printf '#!/bin/sh\nexit 101\n' >"$root/usr/sbin/policy-rc.d"; chmod +x "$root/usr/sbin/policy-rc.d"
  cp -L /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
  bind /proc || skip "mounting refused (mount --bind /proc into the root)"
  say "installing FreeCAD 1.0 and the test dependencies in the root (about four minutes)"
  if ! chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root DEBIAN_FRONTEND=noninteractive \
       sh -c "apt-get update && apt-get install -y --no-install-recommends $packages" >"$root.install.log" 2>&1; then
    tail -20 "$root.install.log" >&2; say "apt-get install in the root failed (log: $root.install.log)"; exit 1
  fi
  printf '%s' "$packages" >"$root/.bladerecon-ready"
  cleanup; mounted=()
fi

for d in /proc /sys /dev /dev/pts; do bind "$d" || skip "mounting refused (mount --bind $d into the root)"; done
mkdir -p "$root/dev/shm"; mountpoint -q "$root/dev/shm" || true

# One folder per run, so that two runs (two developers' checks) never share a tree.
work="$root/work/run.$$"
rm -rf "$work"; mkdir -p "$work"
trap 'cleanup; rm -rf "$work"' EXIT
if [ "${FREECAD1_TREE:-}" = worktree ]; then
  tar -C "$top" --exclude=./.cache --exclude=./.git --exclude='*/__pycache__' --exclude=./demo_out -cf - . \
    | tar -C "$work" --one-top-level=main -xf -
else
  git clone -q "$top" "$work/main" || { say "git clone of $top failed"; exit 1; }
fi
[ -d "$top/../shared" ] && cp -a "$top/../shared" "$work/shared"

inner="make test"
[ -n "${FREECAD1_PYTEST:-}" ] && inner="/usr/bin/python3 -m pytest ${FREECAD1_PYTEST}"
versions='/usr/bin/python3 -c "import sys; sys.path.append(\"/usr/lib/freecad/lib\"); import FreeCAD, numpy; print(\"test-freecad1: FreeCAD\", \".\".join(FreeCAD.Version()[:3]), \"Python\", sys.version.split()[0], \"numpy\", numpy.__version__)"'
chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 CI="${CI:-}" \
  sh -c "$versions >&2; cd /work/run.$$/main && PYTHONPATH=/work/run.$$/main $inner"
rc=$?
[ $rc -eq 0 ] && say "passed on FreeCAD 1.0" || say "FAILED on FreeCAD 1.0 (exit $rc)"
exit $rc
