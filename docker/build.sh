#!/usr/bin/env bash
# Builds the hocurved image without a Docker engine or registry:
#   1. a Debian 12 base image from Debian packages (debootstrap, then `podman import`),
#   2. the service image with `podman build --isolation chroot` (docker/Dockerfile).
# Usage: docker/build.sh [--mirror URL] [--tag hocurve:latest] [--skip-base]
# Needs root (or rootless podman with a user namespace), debootstrap and podman.
set -euo pipefail
cd "$(dirname "$0")/.."
MIRROR="http://deb.debian.org/debian"
TAG="localhost/hocurve:latest"
BASE_TAG="localhost/hocurve-base:bookworm"
SKIP_BASE=0
while [ $# -gt 0 ]; do
  case "$1" in
    --mirror) MIRROR="$2"; shift 2 ;;
    --tag) TAG="$2"; shift 2 ;;
    --skip-base) SKIP_BASE=1; shift ;;
    *) echo "usage: $0 [--mirror URL] [--tag NAME] [--skip-base]" >&2; exit 2 ;;
  esac
done
for tool in podman debootstrap; do
  command -v "$tool" >/dev/null || { echo "build.sh: '$tool' is not installed (apt-get install $tool)" >&2; exit 1; }
done

if [ "$SKIP_BASE" = 0 ]; then
  rootfs=$(mktemp -d /tmp/hocurve-rootfs.XXXXXX)
  trap 'rm -rf "$rootfs"' EXIT
  echo "build.sh: debootstrap bookworm from $MIRROR"
  debootstrap --variant=minbase --include=ca-certificates bookworm "$rootfs" "$MIRROR"
  # Keep images small: no apt caches, no docs.
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/* "$rootfs"/usr/share/doc/*
  echo "deb $MIRROR bookworm main" > "$rootfs/etc/apt/sources.list"
  tar -C "$rootfs" -c . | podman import --change 'CMD ["/bin/bash"]' - "$BASE_TAG"
fi

podman build --isolation chroot --ignorefile docker/dockerignore --build-arg "BASE=$BASE_TAG" \
  -f docker/Dockerfile -t "$TAG" .
echo "build.sh: built $TAG; smoke test: docker/smoke_test.sh $TAG"
