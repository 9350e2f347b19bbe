#!/usr/bin/env bash
# Installs, idempotently, everything vkmech needs on Debian 12 (bookworm),
# from Debian packages only. Mesa comes from bookworm-backports: its lavapipe
# exposes VK_KHR_ray_query / VK_KHR_acceleration_structure (bookworm's Mesa 22
# does not).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

PKGS=(
  build-essential cmake ninja-build pkg-config git
  libvulkan-dev libvulkan1 vulkan-tools vulkan-validationlayers
  glslang-tools
  libglm-dev
  libtinygltf-dev
  libopenexr-dev
  doctest-dev
  libpugixml-dev
  libstb-dev
  libcli11-dev
  zlib1g-dev
  python3-matplotlib
  python3-numpy python3-pytest python3-pybind11 python3-dev
  parallel
  clang libclang-rt-14-dev clang-format
)

# Enable bookworm-backports once.
if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo "install-deps: enabling bookworm-backports"
  echo 'deb http://deb.debian.org/debian bookworm-backports main' |
    $SUDO tee /etc/apt/sources.list.d/bookworm-backports.list >/dev/null
  NEED_UPDATE=1
fi

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
# lavapipe must come from backports (Mesa >= 23 for ray queries).
mesa_ok=0
if dpkg-query -W -f='${Status} ${Version}' mesa-vulkan-drivers 2>/dev/null | grep -q 'install ok installed'; then
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)
  if dpkg --compare-versions "$v" ge 23; then mesa_ok=1; fi
fi

if [ ${#missing[@]} -eq 0 ] && [ $mesa_ok -eq 1 ]; then
  echo "install-deps: everything is installed"
  exit 0
fi

$SUDO apt-get update -qq
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if [ $mesa_ok -eq 0 ]; then
  echo "install-deps: installing mesa-vulkan-drivers from bookworm-backports"
  $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers
fi
echo "install-deps: done"
