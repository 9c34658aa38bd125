# Sourced by scripts/debian13.sh and scripts/dolfinx011.sh: what both do to run the
# checkout inside the cached Debian 13 root ($ROOT).

# PASS: the host's certificates, proxy and package-index settings, for pip in the root
root_pass_settings() {
  PASS=()
  if [ -f /etc/ssl/certs/ca-certificates.crt ]; then
    cp /etc/ssl/certs/ca-certificates.crt "$ROOT/etc/ssl/certs/host-ca-certificates.crt"
    PASS+=(PIP_CERT=/etc/ssl/certs/host-ca-certificates.crt)
  fi
  for var in http_proxy https_proxy no_proxy HTTP_PROXY HTTPS_PROXY NO_PROXY PIP_INDEX_URL \
             PIP_EXTRA_INDEX_URL PIP_DEFAULT_TIMEOUT; do
    [ -n "${!var:-}" ] && PASS+=("$var=${!var}")
  done
  cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
}

# The checkout's tracked and untracked-but-not-ignored files copied to $ROOT$1 (its .venv
# and .cache kept), with the mesh files made here: Debian 13's gmsh 4.13 splits some cells
# of the same geometry differently from Debian 12's 4.8 (20 of the tiny beam's 240
# tetrahedra), so only on the same meshes do both platforms give the same numbers
# (measured: the tiny arc run's first objective to 4e-14, its 30th to 6e-7, Newton's
# tolerance)
root_copy_checkout() {
  local dest="$ROOT$1"
  mkdir -p "$dest"
  find "$dest" -mindepth 1 -maxdepth 1 ! -name .venv ! -name .cache -exec rm -rf {} +
  git ls-files -co --exclude-standard -z | tar --null -cf - -T - | tar -xf - -C "$dest"
  find meshes -maxdepth 1 \( -name '*.msh' -o -name '*.json' \) -exec cp {} "$dest/meshes/" \;
  # Two pytest workers that meet one form: the second waits for the first's compile, by
  # default 10 s, which a loaded root once exceeded (a TimeoutError on a fresh JIT cache).
  # The root's own home gets a longer wait; dolfinx 0.9 and 0.11 read this file.
  mkdir -p "$ROOT/root/.config/dolfinx"
  echo '{"timeout": 300}' > "$ROOT/root/.config/dolfinx/dolfinx_jit_options.json"
  # A compile killed midway (an MPI rank that died) leaves its C file without the
  # `.c.cached` mark, and every later process waits for it until the timeout: no run is
  # active here, so such leftovers go
  local c
  for c in "$ROOT"/root/.cache/fenics/*.c; do
    [ -e "$c" ] && [ ! -e "$c.cached" ] && rm -f "$c"
  done
  return 0
}

# proc and sys for MPI (hwloc reads the CPU topology; the wheel's MPICH fails in
# MPI_Init without them), a tmpfs for its shared memory; unmounted however the run ends
root_mount() {
  MOUNTED=()
  trap root_unmount EXIT
  mount -t proc proc "$ROOT/proc" && MOUNTED+=("$ROOT/proc")
  mount --bind /sys "$ROOT/sys" && MOUNTED+=("$ROOT/sys")
  mkdir -p "$ROOT/dev/shm"
  mount -t tmpfs tmpfs "$ROOT/dev/shm" && MOUNTED+=("$ROOT/dev/shm")
}
root_unmount() {
  for ((i = ${#MOUNTED[@]} - 1; i >= 0; i--)); do umount -l "${MOUNTED[i]}" || true; done
}
