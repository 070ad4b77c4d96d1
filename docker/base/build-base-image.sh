#!/usr/bin/env bash
# Build, from Debian packages only, a local stand-in for the public
# `python:3.11-slim-bookworm` image and tag it with exactly that name, so
# Dockerfiles that say `FROM python:3.11-slim-bookworm` build unchanged on a
# Docker engine that cannot pull from any image registry.
#
# What is inside: Debian bookworm (debootstrap --variant=minbase) + Debian's
# python3 (3.11), python3-venv, python3-pip, ca-certificates, netbase, tzdata
# and tini. `python` and `python3` resolve via /usr/local/bin symlinks.
# Debian's "externally managed" marker is removed so that `pip install` as
# root behaves as in the public image. Differences to the public image:
# python3 lives in /usr/bin (the public one has /usr/local/bin/python3, and
# both have /usr/local/bin first on PATH), and pip is Debian's.
#
# The Debian mirror is the one this machine's apt is configured with (read at
# run time from /etc/apt/sources.list and /etc/apt/sources.list.d/), unless
# --mirror URL or $DEBIAN_MIRROR says otherwise.
#
# Usage: docker/base/build-base-image.sh [--force] [--tag NAME] [--mirror URL]
#   --force   rebuild even if the tag already exists
#   --tag     image name to produce (default python:3.11-slim-bookworm)
#   --mirror  Debian mirror URL (default: from this machine's apt config)
# Needs root (debootstrap, chroot) and a running Docker engine.
set -euo pipefail

TAG="python:3.11-slim-bookworm"
FORCE=0
MIRROR="${DEBIAN_MIRROR:-}"
SECURITY_MIRROR="${DEBIAN_SECURITY_MIRROR:-}"
SUITE="bookworm"
PACKAGES="python3 python3-venv python3-pip ca-certificates netbase tzdata tini"

while [ $# -gt 0 ]; do
    case "$1" in
        --force) FORCE=1 ;;
        --tag) TAG="$2"; shift ;;
        --mirror) MIRROR="$2"; shift ;;
        -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
        *) echo "unknown argument: $1" >&2; exit 2 ;;
    esac
    shift
done

log() { printf '[build-base-image %s] %s\n' "$(date +%H:%M:%S)" "$*"; }

if [ "$FORCE" -eq 0 ] && docker image inspect "$TAG" >/dev/null 2>&1; then
    log "image $TAG already exists; nothing to do (use --force to rebuild)"
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    echo "build-base-image.sh must run as root (debootstrap/chroot)" >&2
    exit 1
fi

export DEBIAN_FRONTEND=noninteractive

# --- find the mirror(s) this machine's apt uses --------------------------------
# Prints "URI<TAB>SUITE" for every enabled deb entry (one-line and deb822 formats).
apt_entries() {
    local f
    for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
        [ -f "$f" ] || continue
        # deb [options] URI SUITE COMPONENTS...
        sed -e 's/#.*//' -e 's/\[[^]]*\]//' "$f" \
            | awk '$1 == "deb" { print $2 "\t" $3 }'
    done
    for f in /etc/apt/sources.list.d/*.sources; do
        [ -f "$f" ] || continue
        awk '
            function flush() {
                if (types ~ /(^| )deb( |$)/ && enabled != "no")
                    for (i = 1; i <= nu; i++) for (j = 1; j <= ns; j++) print u[i] "\t" s[j]
                types = ""; enabled = ""; nu = 0; ns = 0
            }
            /^[ \t]*#/ { next }
            /^[ \t]*$/ { flush(); next }
            {
                key = tolower($1); sub(/:$/, "", key)
                if (key == "types") { types = ""; for (i = 2; i <= NF; i++) types = types " " $i; sub(/^ /, "", types) }
                else if (key == "uris") { nu = 0; for (i = 2; i <= NF; i++) u[++nu] = $i }
                else if (key == "suites") { ns = 0; for (i = 2; i <= NF; i++) s[++ns] = $i }
                else if (key == "enabled") { enabled = tolower($2) }
            }
            END { flush() }
        ' "$f"
    done
}

if [ -z "$MIRROR" ]; then
    MIRROR="$(apt_entries | awk -F'\t' -v s="$SUITE" '$2 == s { print $1; exit }')"
fi
if [ -z "$SECURITY_MIRROR" ]; then
    SECURITY_MIRROR="$(apt_entries | awk -F'\t' -v s="$SUITE-security" '$2 == s { print $1; exit }')"
fi
if [ -z "$MIRROR" ]; then
    echo "could not find a '$SUITE' Debian mirror in this machine's apt config; pass --mirror URL" >&2
    exit 1
fi
MIRROR="${MIRROR%/}"
SECURITY_MIRROR="${SECURITY_MIRROR%/}"
log "target tag:      $TAG"
log "debian mirror:   $MIRROR ($SUITE, $SUITE-updates)"
log "security mirror: ${SECURITY_MIRROR:-<none found; skipping $SUITE-security>}"

START=$(date +%s)

if ! command -v debootstrap >/dev/null 2>&1; then
    log "installing debootstrap on the host"
    apt-get update -qq
    apt-get install -y -qq debootstrap >/dev/null
fi

WORK="$(mktemp -d /var/tmp/manigraph-base.XXXXXX)"
ROOT="$WORK/rootfs"
cleanup() {
    local m
    for m in dev/pts dev proc sys; do
        if mountpoint -q "$ROOT/$m" 2>/dev/null; then umount -l "$ROOT/$m" || true; fi
    done
    rm -rf --one-file-system "$WORK"
}
trap cleanup EXIT

# --- 1. minimal Debian ------------------------------------------------------------
log "debootstrap --variant=minbase $SUITE (this takes a few minutes)"
debootstrap --variant=minbase --components=main "$SUITE" "$ROOT" "$MIRROR" >"$WORK/debootstrap.log" 2>&1 || {
    tail -n 40 "$WORK/debootstrap.log" >&2
    echo "debootstrap failed" >&2
    exit 1
}
log "debootstrap done ($(( $(date +%s) - START ))s)"

# --- 2. image-style apt/dpkg settings (as in Debian's official container images) ---
cat >"$ROOT/etc/dpkg/dpkg.cfg.d/docker" <<'EOF'
# keep the image small: no docs, man pages or translations
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
path-include /usr/share/locale/locale.alias
path-exclude /usr/share/lintian/*
EOF
cat >"$ROOT/etc/apt/apt.conf.d/docker-clean" <<'EOF'
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
EOF
cat >"$ROOT/etc/apt/apt.conf.d/docker-no-languages" <<'EOF'
Acquire::Languages "none";
EOF
cat >"$ROOT/etc/apt/apt.conf.d/docker-gzip-indexes" <<'EOF'
Acquire::GzipIndexes "true";
Acquire::CompressionTypes::Order:: "gz";
EOF
# no daemons may start inside the chroot
printf '#!/bin/sh\nexit 101\n' >"$ROOT/usr/sbin/policy-rc.d"
chmod 0755 "$ROOT/usr/sbin/policy-rc.d"

rm -f "$ROOT/etc/apt/sources.list"
{
    printf 'Types: deb\nURIs: %s\nSuites: %s %s-updates\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
        "$MIRROR" "$SUITE" "$SUITE"
    if [ -n "$SECURITY_MIRROR" ]; then
        printf '\nTypes: deb\nURIs: %s\nSuites: %s-security\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
            "$SECURITY_MIRROR" "$SUITE"
    fi
} >"$ROOT/etc/apt/sources.list.d/debian.sources"

# --- 3. python and friends inside the chroot ---------------------------------------
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
mount -t proc proc "$ROOT/proc"
mount --bind /dev "$ROOT/dev"
mount --bind /dev/pts "$ROOT/dev/pts"
in_root() { chroot "$ROOT" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    DEBIAN_FRONTEND=noninteractive LANG=C.UTF-8 "$@"; }

log "apt-get update + upgrade (updates/security) in the rootfs"
in_root apt-get update -qq
in_root apt-get -y -qq -o Dpkg::Options::=--force-confold dist-upgrade >/dev/null
log "installing: $PACKAGES"
# shellcheck disable=SC2086
in_root apt-get install -y -qq --no-install-recommends $PACKAGES >"$WORK/install.log" 2>&1 || {
    tail -n 40 "$WORK/install.log" >&2
    exit 1
}
in_root apt-get clean

# python / python3 on /usr/local/bin (where the public image has them)
ln -sf /usr/bin/python3 "$ROOT/usr/local/bin/python3"
ln -sf /usr/bin/python3 "$ROOT/usr/local/bin/python"
ln -sf /usr/bin/pip3 "$ROOT/usr/local/bin/pip3"
ln -sf /usr/bin/pip3 "$ROOT/usr/local/bin/pip"
# pip as root installs into /usr/local like in the public image (PEP 668 marker off)
rm -f "$ROOT"/usr/lib/python3*/EXTERNALLY-MANAGED
PYVER="$(in_root python3 -c 'import platform; print(platform.python_version())')"
log "python in rootfs: $PYVER"

umount -l "$ROOT/dev/pts" "$ROOT/dev" "$ROOT/proc"

# --- 4. trim ---------------------------------------------------------------------------
log "trimming the rootfs"
rm -f "$ROOT/usr/sbin/policy-rc.d"
rm -rf "$ROOT"/var/lib/apt/lists/* "$ROOT"/var/cache/apt/* "$ROOT"/var/cache/debconf/*-old \
    "$ROOT"/var/log/* "$ROOT"/tmp/* "$ROOT"/var/tmp/* "$ROOT"/root/.cache
find "$ROOT/usr/share/doc" -mindepth 1 -not -name copyright -not -type d -delete 2>/dev/null || true
find "$ROOT/usr/share/doc" -mindepth 1 -type d -empty -delete 2>/dev/null || true
rm -rf "$ROOT"/usr/share/man/* "$ROOT"/usr/share/info/* "$ROOT"/usr/share/lintian/*
find "$ROOT/usr/share/locale" -mindepth 1 -maxdepth 1 -not -name locale.alias -exec rm -rf {} + 2>/dev/null || true
find "$ROOT/usr/lib" -name '__pycache__' -type d -prune -exec rm -rf {} + 2>/dev/null || true
: >"$ROOT/etc/resolv.conf"
: >"$ROOT/etc/hostname"
rm -rf "${ROOT:?}"/dev/* "${ROOT:?}"/proc/* "${ROOT:?}"/sys/*
rm -f "$ROOT/etc/machine-id" && : >"$ROOT/etc/machine-id"

# --- 5. import ---------------------------------------------------------------------
log "importing rootfs as $TAG"
tar --numeric-owner --xattrs -C "$ROOT" -c . | docker import \
    --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    --change 'ENV LANG=C.UTF-8' \
    --change "ENV PYTHON_VERSION=$PYVER" \
    --change 'CMD ["python3"]' \
    --message "local python:3.11-slim-bookworm equivalent built from Debian packages by build-base-image.sh" \
    - "$TAG" >/dev/null

log "checking the image"
docker run --rm "$TAG" python3 -c 'import sys, ssl, venv, ensurepip; print(sys.version)'
log "done in $(( $(date +%s) - START ))s; $(docker image inspect -f '{{.Size}}' "$TAG" | awk '{printf "%.0f MB", $1/1e6}')"
