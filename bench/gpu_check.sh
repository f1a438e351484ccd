#!/usr/bin/env bash
# The GPU backend's check on a machine with an NVIDIA GPU and no package registry: the environment,
# the CUDA kernel tests for real, then bench render and a short bench quality on the GPU. Every log
# and figure goes under $OUT (default ./gpu-check); each step runs even where one before it failed,
# and the last line sums them up. Wheels that the machine lacks (numba-cuda and lookalike's own
# dependencies) are installed from the folder WHEELS (default ./.whl) with pip --no-index.
#   OUT=/tmp/out bash bench/gpu_check.sh
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-gpu-check}
WHEELS=${WHEELS:-.whl}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
status=()

step() {  # step NAME SECONDS COMMAND...: run COMMAND within SECONDS, its output in $OUT/NAME.log
    local name=$1 seconds=$2; shift 2
    timeout "$seconds" "$@" >"$OUT/$name.log" 2>&1
    local rc=$?
    status+=("$name=$rc")
    echo "$name: exit $rc (log $OUT/$name.log)"
}

if [ -d "$WHEELS" ]; then
    step install 180 python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/site "$WHEELS"/*.whl
    export PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH}
fi
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH}
step environment 120 bash -c 'nvidia-smi; python3 -c "
import torch, numba
from numba import cuda
print(\"torch\", torch.__version__, \"cuda\", torch.version.cuda, \"sees\", torch.cuda.is_available())
print(\"numba\", numba.__version__)
cuda.detect()
from lookalike.devices import cuda_problem, device_label, resolve_device
print(\"lookalike: auto is\", device_label(resolve_device(\"auto\")), \"; problem:\", cuda_problem())
"'
step kernel_tests 300 python3 -m pytest -q -p no:cacheprovider tests/test_cuda_kernels.py
step bench_render 240 python3 -m lookalike.cli bench render --device cuda --json
cp "$OUT/bench_render.log" "$OUT/bench_render.json" 2>/dev/null
step bench_quality 240 python3 -m lookalike.cli bench quality --device cuda --asset "${ASSET:-spot}" --json --out "$OUT/quality"
echo "gpu check: ${status[*]}" | tee "$OUT/summary.txt"
