#!/usr/bin/env bash
# Make sure this machine has an OpenCL device that builds kernels.
#
# The pocl extra brings PoCL as a wheel, whose LLVM 14 does not know CPUs
# newer than it (AMD Zen 5, for one): there every build fails with
# "unknown target CPU 'generic'".  On Debian and Ubuntu, the distribution's
# PoCL (pocl-opencl-icd, LLVM 15 or newer) picks the CPU by its features and
# works; mcocl's default device is the first one that builds (mcocl devices).
set -euo pipefail
python=${PYTHON:-python}
probe() { "$python" -c "import mcocl.runtime as r; r.select_device()" 2>/dev/null; }
if probe; then
    exit 0
fi
echo "ensure-device: no OpenCL device here builds kernels; installing Debian's pocl-opencl-icd" >&2
if ! command -v apt-get >/dev/null; then
    echo "ensure-device: no apt-get: install an OpenCL CPU driver (PoCL >= 3.1) by hand" >&2
    exit 1
fi
sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq pocl-opencl-icd >/dev/null
probe || { "$python" -m mcocl devices >&2; exit 1; }
