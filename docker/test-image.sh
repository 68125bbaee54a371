#!/usr/bin/env bash
# docker/test-image.sh -- build the stickslip image and run it for real.
#
#   docker/test-image.sh            (CI: .ci/run calls it after the tests)
#
# 1. engine: `docker` if a daemon answers, else podman (root: installed from Debian with runc
#    when missing; runc, overlay storage of its own in $STICKSLIP_CACHE/containers, ulimits
#    within the host's hard limits).
# 2. base:   `debian:trixie`, pulled, or (no registry reachable) made offline with
#    `debootstrap --variant=minbase trixie` and cached as a tarball outside the repository in
#    $STICKSLIP_CACHE/images (default /var/cache/stickslip/images), like ./dev's rootfs.
# 3. build:  the runtime image (Dockerfile's last stage; no PyPI request), tagged
#    stickslip:test.  The engine's layer cache keeps the Debian stack layer between runs (its
#    key is the Dockerfile lines above it and docker/apt-packages.txt), so a warm build only
#    re-installs the project.
# 4. inside the image: `stickslip --help`, `stickslip info`, every package of the source tree
#    importable from the install;
#    `mpirun -n 2 stickslip run scenes/smoke.toml --plot` and
#    `mpirun -n 2 stickslip sweep sweeps/smoke4.toml` (4 scenes) into a bind-mounted host
#    directory; the README's cluster recipe (`--user 1234:1234 -e HOME=/tmp`,
#    `mpirun -n 4 stickslip sweep ...`, oversubscribed on a 2-core machine); a scene error
#    (`--set mesh.n_inner=-1`) must give one line on stderr and exit 2.
# 5. on the host: every output is readable by a user other than the container's (modes, and
#    reading them as `nobody`), and the summaries equal those of `./dev` runs of the same
#    scenes to round-off (docker/compare_summaries.py).
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

ulimit_flags() {
    # podman's default ulimits (1048576 open files) exceed some hosts' hard limits, and runc
    # then fails with "error setting rlimit" (it cannot raise them without CAP_SYS_RESOURCE):
    # 20000 files and processes, lowered to the host's hard limits where those are smaller.
    local n u
    n=$(ulimit -Hn); u=$(ulimit -Hu)
    if [ "$n" = unlimited ] || [ "$n" -gt 20000 ]; then n=20000; fi
    if [ "$u" = unlimited ] || [ "$u" -gt 20000 ]; then u=20000; fi
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
        exec 8>"$IMAGES/.lock"
        flock 8  # one debootstrap at a time; a concurrent one may have made the tarball meanwhile
        if [ ! -f "$tarball" ]; then
            BASE_TMP="$IMAGES/.build.$$"   # removed by cleanup() if we are interrupted
            rm -rf --one-file-system "$BASE_TMP"
            debootstrap --variant=minbase trixie "$BASE_TMP" "$(mirror)" >"$IMAGES/debootstrap.log" 2>&1 ||
                die "debootstrap failed; see $IMAGES/debootstrap.log"
            # What the official image leaves out too: package caches and lists.
            rm -rf "$BASE_TMP"/var/cache/apt/archives/*.deb "$BASE_TMP"/var/lib/apt/lists/*
            tar --numeric-owner -C "$BASE_TMP" -cf "$tarball.tmp" . && mv "$tarball.tmp" "$tarball"
            rm -rf --one-file-system "$BASE_TMP"
            BASE_TMP=""
        fi
        exec 8>&-
    fi
    # (no -q: `docker import` has none; the progress goes to a log)
    "${ENGINE[@]}" import "$tarball" "$BASE" >"$IMAGES/import.log" 2>&1 ||
        die "could not import $tarball as $BASE; see $IMAGES/import.log"
    say "base: $BASE imported from $tarball"
}

# ---------------------------------------------------------------------------------------------
# 3. build
build_image() {
    local log="$OUT/build.log"
    if ! "${ENGINE[@]}" build "${BUILD_FLAGS[@]}" -t "$TAG" "$REPO" >"$log" 2>&1; then
        tail -n 30 "$log" >&2
        die "the image build failed (log above, whole log: $log)"
    fi
    local cached
    cached=$(grep -c -- '--> Using cache' "$log" || true)
    # Old project layers of earlier builds: untagged, no longer needed (the Debian stack layer
    # stays: the tagged image holds it).
    "${ENGINE[@]}" image prune -f >/dev/null 2>&1 || true
    local bytes
    bytes=$("${ENGINE[@]}" image inspect --format '{{.Size}}' "$TAG")
    say "image $TAG: $((bytes / 1000000)) MB ($cached build steps from the layer cache)"
}

# ---------------------------------------------------------------------------------------------
# 4. runs inside the image
N_RUN=0
crun() {  # crun [engine run options...] -- CMD...: one container, removed afterwards
    local -a opts=()
    while [ "$1" != "--" ]; do opts+=("$1"); shift; done
    shift
    N_RUN=$((N_RUN + 1))
    "${ENGINE[@]}" run --rm --name "stickslip-test-$$-$N_RUN" "${RUN_FLAGS[@]}" "${opts[@]}" \
        "$TAG" "$@"
}

BASE_TMP=""
cleanup() {
    local ids
    [ -z "$BASE_TMP" ] || rm -rf --one-file-system "$BASE_TMP" "$IMAGES/debian-trixie-minbase.tar.tmp"
    if [ "${#ENGINE[@]}" -gt 0 ]; then
        ids=$("${ENGINE[@]}" ps -aq --filter "name=stickslip-test-$$-" 2>/dev/null || true)
        [ -z "$ids" ] || "${ENGINE[@]}" rm -f $ids >/dev/null 2>&1 || true
    fi
    if [ -n "${OUT:-}" ] && [ -d "$OUT" ]; then
        if [ -n "$KEEP" ] || [ "$FAILED" != 0 ]; then say "outputs kept in $OUT"
        else rm -rf --one-file-system "$OUT"; fi
    fi
}

run_help() {
    local out
    out=$(crun -- stickslip --help 2>&1) || { echo "$out" >&2; fail "stickslip --help failed"; return; }
    grep -q '^usage: stickslip' <<<"$out" || { echo "$out" >&2; fail "stickslip --help: no usage line"; }
    out=$(crun -- stickslip info 2>&1 | tr -d '\0') || { echo "$out" >&2; fail "stickslip info failed"; return; }
    grep -q '^dolfinx 0\.9' <<<"$out" || { echo "$out" >&2; fail "stickslip info: no dolfinx 0.9"; }
    say "stickslip info: $(grep -E '^(dolfinx|PETSc|MPI [^s])' <<<"$out" | tr '\n' ';')"
}

run_installed_packages() {  # the install holds every package of the source tree
    # From / (not the source tree in the working directory), as the `stickslip` script does.
    local out
    out=$(crun -w / -- python3 -c '
import importlib, importlib.util, pathlib, sys
src = pathlib.Path("/opt/stickslip")
# the folders are installed as stickslip.<folder> (pyproject.toml: package-dir)
names = sorted(".".join(p.parent.relative_to(src).parts) for p in src.rglob("__init__.py")
               if p.parent.relative_to(src).parts[0] not in ("tests", "benchmarks"))
names = ["stickslip", *(f"stickslip.{n}" for n in names)]
bad = [f"{top}: installed as a top-level name" for top in ("solver", "cli", "studies")
       if importlib.util.find_spec(top) is not None]
for name in names:
    try:
        mod = importlib.import_module(name)
        if not mod.__file__.startswith("/usr/local/lib/"):
            bad.append(f"{name}: imported from {mod.__file__}")
    except ImportError as err:
        bad.append(f"{name}: {err}")
print("\n".join(bad) if bad else f"{len(names)} packages installed: {chr(32).join(names)}")
sys.exit(1 if bad else 0)' 2>&1) || { echo "$out" >&2; fail "the installed project lacks packages of the source tree, or installs more than stickslip (pyproject.toml [tool.setuptools] packages)"; return; }
    say "$out"
    # From the working directory (/opt/stickslip, first on sys.path for `python3 -c`): the
    # installed package, never a part of the source tree.
    out=$(crun -- python3 -c '
import stickslip, stickslip.node, stickslip.solver.scene as scene
print(stickslip.__file__, stickslip.node.__file__, scene.__file__)' 2>&1) &&
        [ -z "$(tr ' ' '\n' <<<"$out" | grep -v '^/usr/local/lib/')" ] ||
        { echo "$out" >&2; fail "python3 -c 'import stickslip...' in /opt/stickslip: not the installed package"; return; }
}

run_scenes() {  # the smoke scene and the 4-scene sweep, outputs in the mounted $OUT/image
    local mount="$OUT/image:/work/runs"
    # Default output root (STICKSLIP_OUTPUT=/work/runs): /work/runs/smoke, /work/runs/sweeps/smoke4.
    # --plot: matplotlib and pyvista's off-screen rendering (Xvfb, Mesa) work in the image too.
    crun -v "$mount" -- mpirun -n 2 stickslip run scenes/smoke.toml --plot >"$OUT/image-smoke.log" 2>&1 ||
        { tail -n 20 "$OUT/image-smoke.log" >&2; fail "mpirun -n 2 stickslip run scenes/smoke.toml --plot"; }
    local png
    for png in spacetime profile phase energy isomap; do
        [ "$(stat -c %s "$OUT/image/smoke/$png.png" 2>/dev/null || echo 0)" -gt 10000 ] ||
            fail "--plot in the image: $png.png missing or nearly empty"
    done
    crun -v "$mount" -- mpirun -n 2 stickslip sweep sweeps/smoke4.toml >"$OUT/image-sweep.log" 2>&1 ||
        { tail -n 20 "$OUT/image-sweep.log" >&2; fail "mpirun -n 2 stickslip sweep sweeps/smoke4.toml"; }
    # The same command again resumes: nothing left to run.
    crun -v "$mount" -- mpirun -n 2 stickslip sweep sweeps/smoke4.toml >"$OUT/image-resume.log" 2>&1 &&
        grep -q '4 already done, 0 to run' "$OUT/image-resume.log" ||
        { tail -n 20 "$OUT/image-resume.log" >&2; fail "re-running the sweep should resume (4 already done)"; }
}

run_sweep_cluster() {
    # The README's cluster-node recipe: a host user other than the image's (uid 1234 here) runs
    # `mpirun -n 4 stickslip sweep` (oversubscribed on a 2-core machine) as itself, with the
    # results on a mounted directory it owns.
    crun -v "$OUT/cluster:/data" --user 1234:1234 -e HOME=/tmp --shm-size=1g -- \
        mpirun -n 4 stickslip sweep sweeps/smoke4.toml -o /data/smoke4 >"$OUT/image-sweep-np4.log" 2>&1 ||
        { tail -n 20 "$OUT/image-sweep-np4.log" >&2; fail "mpirun -n 4 stickslip sweep sweeps/smoke4.toml"; }
}

run_scene_error() {  # a bad scene value: one line on stderr, exit status 2
    # (`smoke`: a shipped scene by its bare name, found by the installed code via STICKSLIP_SCENES)
    local rc=0 err
    crun -- stickslip run smoke --set mesh.n_inner=-1 >"$OUT/error.out" 2>"$OUT/error.err" || rc=$?
    err=$(grep -v '^[[:space:]]*$' "$OUT/error.err" || true)
    if [ "$rc" != 2 ] || [ "$(wc -l <<<"$err")" != 1 ] || ! grep -q 'n_inner' <<<"$err"; then
        cat "$OUT/error.err" >&2
        fail "a scene error should exit 2 with one line naming mesh.n_inner (got exit $rc, above)"
    else
        say "scene error: exit $rc: $err"
    fi
}

# ---------------------------------------------------------------------------------------------
# 5. checks on the host
check_readable() {  # every output readable by a user other than the container's (1000, 1234)
    local bad
    bad=$(find "$OUT/image" "$OUT/cluster" \( -type f ! -perm -o=r \) -o \( -type d ! -perm -o=rx \))
    if [ -n "$bad" ]; then
        ls -ln $bad >&2
        fail "$(wc -l <<<"$bad") outputs are not readable by other users (mode o+r, listed above)"
    fi
    if [ "$(id -u)" = 0 ] && command -v setpriv >/dev/null; then  # read them as nobody
        bad=$(setpriv --reuid=65534 --regid=65534 --clear-groups \
              find "$OUT/image" "$OUT/cluster" ! -readable 2>&1 || true)
        [ -z "$bad" ] || fail "user nobody cannot read $(wc -l <<<"$bad") outputs (modes above)"
        [ -n "$bad" ] || setpriv --reuid=65534 --regid=65534 --clear-groups \
            find "$OUT/image" "$OUT/cluster" -type f -exec cat {} + >/dev/null 2>&1 ||
            fail "user nobody cannot read every output file"
    fi
    say "$(find "$OUT/image" "$OUT/cluster" -type f | wc -l) output files, owner uid(s)" \
        "$(find "$OUT/image" "$OUT/cluster" -type f -printf '%U\n' | sort -u | tr '\n' ' ')"
}

dev_reference() {  # the same scenes through ./dev, into $OUT/dev
    "$REPO/dev" mpirun -n 2 stickslip run scenes/smoke.toml -o "$OUT/dev/smoke" --force \
        >"$OUT/dev-smoke.log" 2>&1 || { tail -n 20 "$OUT/dev-smoke.log" >&2; fail "./dev smoke run"; }
    "$REPO/dev" mpirun -n 2 stickslip sweep sweeps/smoke4.toml -o "$OUT/dev/sweeps/smoke4" \
        >"$OUT/dev-sweep.log" 2>&1 || { tail -n 20 "$OUT/dev-sweep.log" >&2; fail "./dev sweep"; }
}

compare_versions() {  # informative: the image's Debian stack versus ./dev's rootfs
    local pkgs
    pkgs=$(sed -e 's/#.*//' -e 's/[[:space:]]//g' "$REPO/docker/apt-packages.txt" | grep -v '^$' | tr '\n' ' ')
    # shellcheck disable=SC2086
    if diff <(crun -- dpkg-query -W $pkgs) <("$REPO/dev" dpkg-query -W $pkgs) >"$OUT/versions.diff"; then
        say "the image and ./dev's rootfs have the same versions of the apt list's packages"
    else
        say "warning: package versions differ between the image and ./dev's rootfs:"
        cat "$OUT/versions.diff" >&2
    fi
}

compare_summaries() {
    local pair ref other res
    for pair in "dev/smoke image/smoke" "dev/sweeps/smoke4 image/sweeps/smoke4" \
                "dev/sweeps/smoke4 cluster/smoke4"; do
        read -r ref other <<<"$pair"
        if res=$("$REPO/dev" python3 "$REPO/docker/compare_summaries.py" "$OUT/$ref" "$OUT/$other" 2>&1); then
            say "summaries $other vs $ref: $res"
        else
            echo "$res" >&2
            fail "summaries $other differ from ./dev's $ref"
        fi
    done
}

# ---------------------------------------------------------------------------------------------
main() {
    trap cleanup EXIT
    stage "engine"
    pick_engine
    stage "base image"
    base_image
    OUT=$(mktemp -d /tmp/stickslip-image-test.XXXXXX)  # /tmp: ./dev sees it too
    chmod 755 "$OUT"
    mkdir -p "$OUT/image" "$OUT/dev"
    mkdir -p "$OUT/cluster"
    # The mounts belong to the container's users: the image's (1000) and the --user one (1234).
    chown 1000:1000 "$OUT/image" 2>/dev/null || chmod 777 "$OUT/image"
    chown 1234:1234 "$OUT/cluster" 2>/dev/null || chmod 777 "$OUT/cluster"
    stage "build"
    build_image
    stage "--help, info, packages"
    run_help
    run_installed_packages
    stage "run + sweep (mpirun -n 2)"
    run_scenes
    stage "sweep (--user, mpirun -n 4)"
    run_sweep_cluster
    stage "scene error"
    run_scene_error
    stage "readable outputs"
    check_readable
    stage "./dev reference runs"
    dev_reference
    compare_versions
    stage "compare summaries"
    compare_summaries
    stage "clean up"
    local left
    left=$("${ENGINE[@]}" ps -aq --filter "name=stickslip-test-$$-" 2>/dev/null || true)
    [ -z "$left" ] || fail "containers left behind: $left"
    print_timings
    [ "$FAILED" = 0 ] || { say "some checks FAILED (see above)"; exit 1; }
    say "all checks passed"
}

main "$@"; exit $?
