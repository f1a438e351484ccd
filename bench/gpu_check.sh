#!/usr/bin/env bash
# The GPU backend's check on a machine with an NVIDIA GPU and no package registry: the environment,
# bench render and a short bench quality on the GPU, then the CUDA kernel tests for real. Every log
# and figure goes under $OUT (default ./gpu-check); each step runs even where one before it failed,
# and the last line sums them up. Wheels that the machine lacks (lookalike's own dependencies, and
# numba-cuda where the machine's is missing or older than the [cuda] extra's) are installed from the
# folder WHEELS (default ./.whl) with pip --no-index, source archives in WHEELS/src (meshoptimizer,
# which has no wheel for every Python) built there. ASSETS: the folder holding the quality
# benchmark's assets (default ../shared/assets), ASSET: the assets run, by name, space-separated (default spot), BUDGET: its wall
# time (default 90s), QUALITY_OUT: where its runs go (default $OUT/quality); SKIP_QUALITY=1 leaves
# that run out. Then a profiled run (spot, STEPS steps, default 300) writes its phases to
# profile.log, slowest first.
#   OUT=/tmp/out bash bench/gpu_check.sh
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-gpu-check}
WHEELS=${WHEELS:-.whl}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1 NUMBA_CUDA_LOW_OCCUPANCY_WARNINGS=0
status=()

step() {  # step NAME SECONDS COMMAND...: run COMMAND within SECONDS, its output in $OUT/NAME.log
    local name=$1 seconds=$2; shift 2
    timeout "$seconds" "$@" >"$OUT/$name.log" 2>&1
    local rc=$?
    status+=("$name=$rc")
    echo "$name: exit $rc (log $OUT/$name.log)"
}

if [ -d "$WHEELS" ]; then
    wheels=("$WHEELS"/*.whl)
    if python3 -c 'import sys, numba_cuda; sys.exit(tuple(map(int, numba_cuda.__version__.split(".")[:2])) < (0, 30))' 2>/dev/null; then
        wheels=("${wheels[@]/*numba_cuda*/}")
    fi
    step install 180 python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/site ${wheels[@]}
    export PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH}
    for archive in "$WHEELS"/src/*.tar.gz; do
        [ -e "$archive" ] && step "build_$(basename "$archive" .tar.gz)" 300 python3 -m pip install -q --no-index \
            --no-deps --no-build-isolation --target /tmp/site "$archive"
    done
fi
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH}
step environment 120 bash -c 'nvidia-smi; python3 -c "
import torch, numba
from numba import cuda
print(\"torch\", torch.__version__, \"cuda\", torch.version.cuda, \"sees\", torch.cuda.is_available())
import numba_cuda, sys; print(\"python\", sys.version.split()[0], \"numba\", numba.__version__, \"numba-cuda\", numba_cuda.__version__, numba_cuda.__file__)
cuda.detect()
from lookalike.devices import cuda_problem, device_label, resolve_device
print(\"lookalike: auto is\", device_label(resolve_device(\"auto\")), \"; problem:\", cuda_problem())
"'
step bench_render 240 python3 -m lookalike.cli bench render --device cuda --json
chosen=(); for asset in ${ASSET:-spot}; do chosen+=(--asset "$asset"); done
[ -n "${SKIP_QUALITY:-}" ] || step bench_quality 420 python3 -m lookalike.cli bench quality --device cuda "${chosen[@]}" \
    --time-budget "${BUDGET:-90s}" --assets-dir "${ASSETS:-../shared/assets}" --json --out "${QUALITY_OUT:-$OUT/quality}"
step profile 300 python3 -m lookalike.cli simplify "${ASSETS:-../shared/assets}/spot/spot.obj" -o /tmp/gpu-profile \
    --triangles 1000 --iterations "${STEPS:-300}" --device cuda --quiet --force --profile
python3 - "$OUT/profile.log" <<'PY'  # the run's phases, slowest first, in place of its log
import json, sys
phases = json.load(open("/tmp/gpu-profile/metrics.json"))["profile"]
with open(sys.argv[1], "w") as log:
    for name, p in sorted(phases.items(), key=lambda kv: -kv[1]["wall_s"]):
        print(f"{p['wall_s']:9.2f} s wall {p['cpu_s']:9.2f} s CPU {p['calls']:7d} calls  {name}", file=log)
PY
step kernel_tests 300 python3 -m pytest -q -p no:cacheprovider tests/test_cuda_kernels.py
echo "gpu check: ${status[*]}" | tee "$OUT/summary.txt"
