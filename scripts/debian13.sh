#!/usr/bin/env bash
# `make test-debian13`: the fast tier (`make test`: lint, types, serial, mpirun -n 2)
# inside a Debian 13 (trixie) root with Debian's FEniCSx (dolfinx 0.9.0, ufl 2024.2,
# basix 0.9, PETSc 3.22), beside the Debian 12 platform the checkout itself runs on.
#
# The root is built once with debootstrap and cached outside the checkout
# (SHAPEGROWTH_DEBIAN13_ROOT, default ~/.cache/shapegrowth/debian13: ~4.6 GB, ~3 min to
# build); the checkout's tracked and untracked-but-not-ignored files are copied into it
# (its .venv and JIT cache are kept between runs). A machine where it cannot run (not
# root, no debootstrap and no apt to install it) skips it with one line, exit status 0.
set -euo pipefail
cd "$(dirname "$0")/.."

ROOT=${SHAPEGROWTH_DEBIAN13_ROOT:-$HOME/.cache/shapegrowth/debian13}
# The archive comes from this machine's own apt sources (a mirror or proxy the machine is set
# up for), or from SHAPEGROWTH_DEBIAN13_MIRROR
host_mirror() {
  local codename uri
  codename=$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")
  [ -n "$codename" ] || return 0
  # one-line sources: deb [options] URI SUITE COMPONENTS...
  uri=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null \
        | sed -E 's/\[[^]]*\]//' \
        | awk -v s="$codename" '$1 == "deb" && $3 == s {print $2; exit}' || true)
  if [ -z "$uri" ]; then  # deb822 stanzas: URIs and Suites, separated by blank lines
    uri=$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null | awk -v s="$codename" '
      /^[[:space:]]*$/ {if (u != "" && hit) {print u; exit}; u = ""; hit = 0; next}
      /^URIs:/ {u = $2}
      /^Suites:/ {for (i = 2; i <= NF; i++) if ($i == s) hit = 1}
      END {if (u != "" && hit) print u}' | head -n 1 || true)
  fi
  echo "$uri"
}
MIRROR=${SHAPEGROWTH_DEBIAN13_MIRROR:-$(host_mirror)}
# The packages of scripts/setup.sh, plus make for the Makefile and Debian's numba (built
# against Debian's numpy, so pip finds numba there and fetches none)
PACKAGES="python3-dolfinx-real python3-gmsh python3-nlopt python3-h5py python3-venv
  python3-yaml python3-matplotlib python3-scipy python3-pytest python3-pytest-xdist python3-nbclient
  python3-nbformat python3-ipykernel python3-numba libopenblas0-pthread openmpi-bin
  python3-setuptools make ca-certificates"
# one line: the list goes into a `bash -c` string below, where a newline would end apt-get's
# command and run the next line's package names as commands
PACKAGES=$(echo $PACKAGES)

skip() { echo "test-debian13: skipped: $*"; exit 0; }

[ "$(id -u)" = 0 ] || skip "needs root (debootstrap, chroot and mount); run it as root"
command -v chroot >/dev/null || skip "no chroot on this machine"

if [ ! -f "$ROOT/.shapegrowth-ready" ]; then
  if ! command -v debootstrap >/dev/null; then
    command -v apt-get >/dev/null || skip "no debootstrap, and no apt-get to install it"
    echo "test-debian13: installing debootstrap"
    apt-get install -y -q --no-install-recommends debootstrap >/dev/null \
      || skip "debootstrap could not be installed (apt-get install debootstrap failed)"
  fi
  [ -n "$MIRROR" ] || skip "no Debian archive in this machine's apt sources; set SHAPEGROWTH_DEBIAN13_MIRROR"
  # apt's proxy, if the machine has one, for debootstrap's downloads and the root's apt
  eval "$(apt-config shell HTTP_PROXY_APT Acquire::http::Proxy 2>/dev/null || true)"
  if [ -n "${HTTP_PROXY_APT:-}" ]; then
    export http_proxy=${http_proxy:-$HTTP_PROXY_APT}
  fi
  echo "test-debian13: building the Debian 13 root in $ROOT from $MIRROR (about 3 minutes, once)"
  rm -rf "$ROOT.partial"
  mkdir -p "$(dirname "$ROOT")"
  debootstrap --variant=minbase trixie "$ROOT.partial" "$MIRROR" > "$ROOT.log" 2>&1 \
    || { tail -n 20 "$ROOT.log"; echo "test-debian13: debootstrap failed (log: $ROOT.log)"; exit 1; }
  cp /etc/resolv.conf "$ROOT.partial/etc/resolv.conf"
  # the machine's apt settings that name a proxy go into the root's apt as they are
  grep -lis proxy /etc/apt/apt.conf.d/* 2>/dev/null | while read -r f; do
    cp "$f" "$ROOT.partial/etc/apt/apt.conf.d/"
  done || true
  # shellcheck disable=SC2086
  chroot "$ROOT.partial" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin \
    DEBIAN_FRONTEND=noninteractive bash -c \
    "apt-get update -q && apt-get install -y -q --no-install-recommends $PACKAGES" \
    >> "$ROOT.log" 2>&1 \
    || { tail -n 20 "$ROOT.log"; echo "test-debian13: apt-get in the root failed (log: $ROOT.log)"; exit 1; }
  rm -rf "$ROOT"
  mv "$ROOT.partial" "$ROOT"
  touch "$ROOT/.shapegrowth-ready"
fi
# pip installs the test tools into .venv: the host's name server, proxy settings and
# trusted certificates (a proxy that re-signs TLS) go with it
# shellcheck source=scripts/root_common.sh
. scripts/root_common.sh  # (after the checks above, which need nothing beside this script)
root_pass_settings
# The copy of the checkout; its .venv and .cache stay between runs
SRC=/work/shapegrowth
root_copy_checkout "$SRC"
root_mount

start=$(date +%s)
chroot "$ROOT" /usr/bin/env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 \
  "${PASS[@]}" bash -c "cd $SRC && make ${SHAPEGROWTH_DEBIAN13_TARGET:-test}"
echo "test-debian13: passed on Debian 13 in $(( $(date +%s) - start )) s"
