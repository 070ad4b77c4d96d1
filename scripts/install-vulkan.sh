#!/usr/bin/env bash
# A Vulkan device for CPU-only Debian 12 (bookworm) machines: Mesa's lavapipe from
# bookworm-backports (Mesa 25). SAPIEN/ManiSkill rendering (manigraph up --sim physics --video)
# needs it; Debian 12's own Mesa 22 lavapipe does not work with SAPIEN. Physics without video
# needs no Vulkan at all. Run as root (or with sudo). Idempotent.
set -euo pipefail

if ! grep -q "bookworm" /etc/os-release; then
    echo "install-vulkan: this script is for Debian 12 (bookworm)" >&2
    exit 1
fi
echo 'deb http://deb.debian.org/debian bookworm-backports main' \
    > /etc/apt/sources.list.d/backports.list
apt-get update
DEBIAN_FRONTEND=noninteractive apt-get install -y -t bookworm-backports \
    mesa-vulkan-drivers libvulkan1
# lavapipe's ICD must be present: SAPIEN picks it up through the Vulkan loader.
test -f /usr/share/vulkan/icd.d/lvp_icd.json
echo "install-vulkan: lavapipe $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers) installed"
