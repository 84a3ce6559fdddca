#!/usr/bin/env bash
# Installs the Debian 12 packages ActiveQS builds and runs with. Idempotent: packages
# already present are left alone, and nothing is downloaded when all are installed.
# Run as root (or with sudo available).
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libceres-dev libeigen3-dev libsuitesparse-dev
  libgoogle-glog-dev libgflags-dev libgtest-dev googletest
  libopenblas0-pthread libopenblas-pthread-dev
  python3 python3-matplotlib python3-numpy
  libopenmpi-dev openmpi-bin
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} packages already installed"
else
  echo "install_deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Make sure the threaded OpenBLAS is the BLAS/LAPACK that CHOLMOD links at run time (also
# when every package was there: another BLAS may have been selected since); changed only
# where another is selected, and said.
arch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || echo x86_64-linux-gnu)
for lib in libblas.so.3 liblapack.so.3; do
  alt="/usr/lib/${arch}/openblas-pthread/${lib}"
  [ -e "$alt" ] || continue
  current=$(update-alternatives --query "${lib}-${arch}" 2>/dev/null | sed -n 's/^Value: //p')
  if [ "$current" != "$alt" ]; then
    if $SUDO update-alternatives --set "${lib}-${arch}" "$alt" >/dev/null 2>&1; then
      echo "install_deps: ${lib} now points at ${alt} (was ${current:-unset})"
    else
      echo "install_deps: warning: could not point ${lib} at ${alt} (it is ${current:-unset});" \
           "CHOLMOD may then use another BLAS, whose threads --threads does not govern"
    fi
  fi
done
echo "install_deps: done"
