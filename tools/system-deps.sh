#!/usr/bin/env bash
# Debian packages the test suite needs, installed with apt-get only if missing:
#   chromium, chromium-driver  the report test opens the HTML report in a real headless browser
#   gcc                        the C reference loops and the generated C code (host build)
#   gcc-arm-none-eabi, libnewlib-arm-none-eabi   the generated C for a Cortex-M4F (size, stack)
#   gcc-arm-linux-gnueabihf, libc6-dev-armhf-cross, qemu-user
#                              the generated C built for ARM Linux and run under qemu-arm
# Run as root, or as a user with password-less sudo. Safe to run again.
set -uo pipefail
need=()
[ -x /usr/bin/chromedriver ] || need+=(chromium chromium-driver)
command -v gcc >/dev/null 2>&1 || need+=(gcc)
command -v arm-none-eabi-gcc >/dev/null 2>&1 || need+=(gcc-arm-none-eabi)
[ -f /usr/lib/arm-none-eabi/include/math.h ] || need+=(libnewlib-arm-none-eabi)
command -v arm-linux-gnueabihf-gcc >/dev/null 2>&1 || need+=(gcc-arm-linux-gnueabihf libc6-dev-armhf-cross)
command -v qemu-arm >/dev/null 2>&1 || need+=(qemu-user)
[ "${#need[@]}" -eq 0 ] && exit 0
echo "system-deps: installing ${need[*]} with apt-get"
if ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: apt-get not found (not Debian/Ubuntu?): install ${need[*]} yourself" >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo -n"; else
        echo "system-deps: not root and no sudo: cannot apt-get install ${need[*]}" >&2; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q || { echo "system-deps: apt-get update failed" >&2; exit 1; }
$SUDO apt-get install -y -q --no-install-recommends "${need[@]}" \
    || { echo "system-deps: apt-get install ${need[*]} failed" >&2; exit 1; }
