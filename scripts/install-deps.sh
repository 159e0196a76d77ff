#!/usr/bin/env bash
# Installs the Debian 12 packages scaratwin needs (build, tests, firmware, emulator, UI tests,
# the Python package, the companion dialects' Octave tests, the fleet over MQTT).
# Safe to run again: apt-get skips what is already installed. Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git help2man gcovr
  libeigen3-dev libboost-dev libsqlite3-dev libcli11-dev libspdlog-dev libfmt-dev
  nlohmann-json3-dev libtomlplusplus-dev libgtest-dev libgmock-dev libbenchmark-dev
  liborocos-kdl-dev
  libmujoco-dev libqhull-dev libegl-dev libgl-dev libopengl-dev libegl-mesa0 libgl1-mesa-dri
  libpng-dev libapriltag-dev libzstd-dev zlib1g-dev sqlite3
  gcc-avr avr-libc binutils-avr arduino-core-avr simavr libsimavr-dev libsimavrparts1 libelf-dev
  avrdude
  clang libclang-rt-14-dev
  chromium
  pybind11-dev python3-dev python3-numpy python3-pytest python3-pandas python3-matplotlib
  jupyter-nbconvert python3-ipykernel
  octave octave-instrument-control
  libmosquitto-dev mosquitto mosquitto-clients libssl-dev openssl
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# node and npm: Debian's nodejs ships npm separately; a NodeSource nodejs already has it.
command -v node >/dev/null || missing+=(nodejs)
command -v npm >/dev/null || missing+=(npm)

if ((${#missing[@]})); then
  echo "installing: ${missing[*]}"
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "all Debian packages present"
fi
