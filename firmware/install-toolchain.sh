#!/bin/sh
# Install the firmware's ARM toolchain: Debian's gcc-arm-none-eabi (GCC 12) with newlib, the
# compiler, binutils and C library `make -C firmware arm` uses for the LPC2148 build, and
# gdb-multiarch, the debugger for `hil run --gdb` on the emulated board. The host build needs
# only the machine's C compiler (gcc, as for the bench's clock shim).
#
#   sh firmware/install-toolchain.sh        (as root, or with sudo available)
#
# Idempotent: does nothing when arm-none-eabi-gcc, newlib's headers and gdb-multiarch are already there.
set -eu
if command -v arm-none-eabi-gcc >/dev/null 2>&1 && [ -f /usr/include/newlib/stdio.h ] \
        && command -v gdb-multiarch >/dev/null 2>&1; then
    echo "firmware toolchain: $(arm-none-eabi-gcc --version | head -n 1) with newlib and gdb-multiarch, already installed"
    exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends gcc-arm-none-eabi binutils-arm-none-eabi libnewlib-arm-none-eabi libnewlib-dev gdb-multiarch
echo "firmware toolchain: $(arm-none-eabi-gcc --version | head -n 1) and $(gdb-multiarch --version | head -n 1) installed"
