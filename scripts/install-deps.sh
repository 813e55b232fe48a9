#!/usr/bin/env bash
# Installs the Debian packages Talus needs. Idempotent: does nothing (quickly) when
# everything is present. Run as root or with sudo available.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libcgal-dev libeigen3-dev libgmp-dev libmpfr-dev libboost-dev
  libassimp-dev libcairo2-dev libpng-dev libhdf5-dev hdf5-tools libyaml-cpp-dev libgdal-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopenmpi-dev openmpi-bin
  python3-matplotlib python3-h5py python3-numpy fonts-dejavu-core
  time
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
