#!/usr/bin/env bash
# Build manigraph service images from docker/Dockerfile.
#
# Usage: docker/build.sh [--tag TAG] [--prefix PREFIX] [TARGET...]
#   TARGET  router recorder tools perception skills planner sim (default: all)
#   --tag   image tag (default: dev)      -> PREFIX/TARGET:TAG
#   --prefix image name prefix (default: manigraph)
#   --no-host-ca  do not add this host's /usr/local/share/ca-certificates/*.crt
#                 to the build context (see docker/extra-ca/README.md)
# Extra `docker build` flags can be passed in $DOCKER_BUILD_FLAGS
# (e.g. DOCKER_BUILD_FLAGS="--no-cache").
#
# The build context is a temporary copy holding only what the images need
# (pyproject.toml, uv.lock, shared/, tools/, services/, families/, docker/; not training/,
# which no image installs), so a large .venv or
# .git in the work tree is never sent to the engine, with or without a
# .dockerignore; the work tree is not written to. If the base image (python:3.11-slim-bookworm by default) is
# not present and cannot be pulled, it is built from Debian packages with
# docker/base/build-base-image.sh (needs root).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/.." && pwd)"
TAG=dev
PREFIX=manigraph
HOST_CA=1
TARGETS=()
while [ $# -gt 0 ]; do
    case "$1" in
        --tag) TAG="$2"; shift ;;
        --prefix) PREFIX="$2"; shift ;;
        --no-host-ca) HOST_CA=0 ;;
        -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
        -*) echo "unknown option: $1" >&2; exit 2 ;;
        *) TARGETS+=("$1") ;;
    esac
    shift
done
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(router recorder tools perception skills planner sim)

BASE_IMAGE="${BASE_IMAGE:-python:3.11-slim-bookworm}"
if ! docker image inspect "$BASE_IMAGE" >/dev/null 2>&1; then
    if ! docker pull "$BASE_IMAGE" >/dev/null 2>&1; then
        echo "[build.sh] $BASE_IMAGE not available; building it from Debian packages"
        "$HERE/base/build-base-image.sh" --tag "$BASE_IMAGE"
    fi
fi

CTX="$(mktemp -d "${TMPDIR:-/tmp}/manigraph-docker-ctx.XXXXXX")"
trap 'rm -rf "$CTX"' EXIT
tar -C "$REPO" -c \
    --exclude='__pycache__' --exclude='*.py[cod]' --exclude='*.egg-info' \
    --exclude='.venv' --exclude='.pytest_cache' --exclude='.mypy_cache' \
    --exclude='.ruff_cache' \
    --exclude='docker/extra-ca/*.crt' \
    pyproject.toml uv.lock shared tools services families docker | tar -C "$CTX" -x
if [ "$HOST_CA" -eq 1 ] && ls /usr/local/share/ca-certificates/*.crt >/dev/null 2>&1; then
    cp -p /usr/local/share/ca-certificates/*.crt "$CTX/docker/extra-ca/"
    echo "[build.sh] adding this host's extra CA certificates to the build context"
fi
cp -p "$REPO"/docker/extra-ca/*.crt "$CTX/docker/extra-ca/" 2>/dev/null || true

# A service image is the Dockerfile's `service` stage grown from the stage its package needs
# (the same pairs as compose.yaml's x-build-* entries).
service_deps() {
    case "$1" in
        perception|skills) echo shared-deps ;;
        planner) echo torch ;;
        sim) echo sim-deps ;;
        *) echo "" ;;
    esac
}

for target in "${TARGETS[@]}"; do
    image="$PREFIX/$target:$TAG"
    deps="$(service_deps "$target")"
    stage_args=(--target "$target")
    if [ -n "$deps" ]; then
        stage_args=(--target service --build-arg SERVICE="$target" --build-arg SERVICE_DEPS="$deps")
    fi
    echo "[build.sh] building $target (${stage_args[*]}) -> $image"
    start=$(date +%s)
    # shellcheck disable=SC2086
    docker build ${DOCKER_BUILD_FLAGS:-} \
        --build-arg BASE_IMAGE="$BASE_IMAGE" "${stage_args[@]}" \
        -f "$CTX/docker/Dockerfile" -t "$image" "$CTX"
    size=$(docker image inspect -f '{{.Size}}' "$image" | awk '{printf "%.2f GB", $1/1e9}')
    echo "[build.sh] $image built in $(( $(date +%s) - start ))s, size $size"
done
