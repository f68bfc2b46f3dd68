#!/usr/bin/env bash
# Builds the hocurved image without a Docker engine or image registry:
#   1. a Debian 12 base image from Debian packages (debootstrap, then `podman import`), unless it
#      exists already (--rebuild-base forces it, --skip-base never builds it),
#   2. the service image with `podman build --isolation chroot --format docker` (docker/Dockerfile;
#      the docker format keeps the HEALTHCHECK, which the OCI format drops). The build context is the
#      repository root, filtered by its .dockerignore.
# Usage: docker/build.sh [--mirror URL] [--security-mirror URL] [--tag NAME] [--jobs N]
#                        [--skip-base | --rebuild-base]
# Needs root (or rootless podman with a user namespace), debootstrap and podman
# (apt-get install podman debootstrap uidmap fuse-overlayfs slirp4netns crun).
set -euo pipefail
cd "$(dirname "$0")/.."
MIRROR="http://deb.debian.org/debian"
SECURITY_MIRROR="http://deb.debian.org/debian-security"
TAG="localhost/hocurve:latest"
BASE_TAG="localhost/hocurve-base:bookworm"
JOBS=2
BASE_MODE=auto
usage() {
  echo "usage: $0 [--mirror URL] [--security-mirror URL] [--tag NAME] [--jobs N] [--skip-base | --rebuild-base]" >&2
  exit 2
}
while [ $# -gt 0 ]; do
  case "$1" in
    --mirror) MIRROR="$2"; shift 2 ;;
    --security-mirror) SECURITY_MIRROR="$2"; shift 2 ;;
    --tag) TAG="$2"; shift 2 ;;
    --jobs) JOBS="$2"; shift 2 ;;
    --skip-base) BASE_MODE=skip; shift ;;
    --rebuild-base) BASE_MODE=rebuild; shift ;;
    *) usage ;;
  esac
done
for tool in podman debootstrap; do
  command -v "$tool" >/dev/null || { echo "build.sh: '$tool' is not installed (apt-get install $tool)" >&2; exit 1; }
done
# The compile shares the machine: lower priority for everything below.
NICE=(nice -n 10)
start=$(date +%s)
with_base=""

if [ "$BASE_MODE" = rebuild ] || { [ "$BASE_MODE" = auto ] && ! podman image exists "$BASE_TAG"; }; then
  rootfs=$(mktemp -d /tmp/hocurve-rootfs.XXXXXX)
  trap 'rm -rf "$rootfs"' EXIT
  echo "build.sh: debootstrap bookworm from $MIRROR into $rootfs"
  "${NICE[@]}" debootstrap --variant=minbase --include=ca-certificates bookworm "$rootfs" "$MIRROR"
  # Keep images small: no apt caches or lists, no docs (but the copyright files), man pages or
  # translations.
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/lib/apt/lists/* \
         "$rootfs"/usr/share/man/* "$rootfs"/usr/share/locale/* "$rootfs"/var/log/*.log "$rootfs"/var/log/apt/*
  find "$rootfs/usr/share/doc" -mindepth 1 ! -type d ! -name copyright -delete
  find "$rootfs/usr/share/doc" -mindepth 1 -type d -empty -delete
  cat > "$rootfs/etc/apt/sources.list" <<EOF
deb $MIRROR bookworm main
deb $MIRROR bookworm-updates main
deb $SECURITY_MIRROR bookworm-security main
EOF
  # The same trims for every later apt-get in the image (as Debian's official images do).
  cat > "$rootfs/etc/dpkg/dpkg.cfg.d/01-hocurve-nodoc" <<'EOF'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/locale/*
path-exclude /usr/share/info/*
EOF
  echo 'APT::Install-Recommends "false"; APT::Install-Suggests "false";' > "$rootfs/etc/apt/apt.conf.d/01-hocurve-norecommends"
  tar --numeric-owner -C "$rootfs" -c . | podman import --change 'CMD ["/bin/bash"]' - "$BASE_TAG"
  rm -rf "$rootfs"
  trap - EXIT
  echo "build.sh: base image $BASE_TAG built in $(( $(date +%s) - start )) s"
  with_base=yes
elif ! podman image exists "$BASE_TAG"; then
  echo "build.sh: --skip-base but $BASE_TAG does not exist" >&2
  exit 1
fi

image_start=$(date +%s)
"${NICE[@]}" podman build --isolation chroot --format docker --layers \
  --build-arg "BASE=$BASE_TAG" --build-arg "JOBS=$JOBS" \
  -f docker/Dockerfile -t "$TAG" .
size=$(podman image inspect --format '{{.Size}}' "$TAG")
[ -z "$with_base" ] || with_base=" ($(( $(date +%s) - start )) s with the base image)"
echo "build.sh: built $TAG ($(( size / 1000000 )) MB) in $(( $(date +%s) - image_start )) s$with_base"
echo "build.sh: smoke test: docker/smoke_test.sh $TAG   (RUN_OPTS=... for podman run options, see there)"
