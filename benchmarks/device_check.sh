#!/bin/sh
# The GPU checks of docs/performance.md ("GPU") as one prepared run on a lent GPU machine.
#
#   here:    make device-wheels                      # what the device image lacks, as wheels in .whl/
#   device:  sh benchmarks/device_check.sh quick     # carry .whl; results in $OUT
#            sh benchmarks/device_check.sh ppo       # the 10^8-decision PPO run
#
# The device image has python3 with a CUDA build of torch, numba and numba-cuda, and no network: the
# pure-Python packages planetnav adds (gymnasium, filterpy, jplephem, skyfield-data) travel as wheels and
# install into /tmp/site; the repository itself is put on PYTHONPATH (no install, no build).
#   quick: bench_gpu.py: GPU rows against the host mode on three ids (200 decisions), env-only rates at
#          N = 2^10, 2^14, 2^18, the kernels' registers and occupancy, the step capped at 168 registers
#          at 2^18, the host's bank-drawing rate, the device PPO's end-to-end rate ($OUT/bench_gpu.json;
#          each stage's result in $OUT/bench_gpu.log as it finishes).
#   ppo:   baselines/ppo_device.py on planetnav/Cruise-Target-v2, 10^8 decisions from 65,536 rows, then the
#          suite's evaluation on the CPU ($OUT/ppo.log).
# A stage that has not finished when the call's limit comes leaves what it wrote so far in $OUT.
set -eu
OUT=${OUT:-/tmp/planetnav_device_out}
mkdir -p "$OUT"
if ls .whl/*.whl >/dev/null 2>&1; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl
    PYTHONPATH=/tmp/site:$PWD
else
    PYTHONPATH=$PWD
fi
export PYTHONPATH PYTHONUNBUFFERED=1
python3 - <<'PY' | tee "$OUT/versions.txt"
import gymnasium, numba, numpy, torch

try:
    import numba_cuda
    nbc = numba_cuda.__version__
except ImportError:
    nbc = "absent"
gpu = torch.cuda.get_device_name(0) if torch.cuda.is_available() else "no CUDA device"
print(f"gpu {gpu}; torch {torch.__version__}; numba {numba.__version__}; numba-cuda {nbc}; "
      f"numpy {numpy.__version__}; gymnasium {gymnasium.__version__}")
PY
case "${1:-quick}" in
quick)
    python3 benchmarks/bench_gpu.py --sizes 10 14 18 --max-registers 168 --ppo-updates 5 \
        >"$OUT/bench_gpu.json" 2>"$OUT/bench_gpu.log"
    cat "$OUT/bench_gpu.json"
    ;;
ppo)
    python3 baselines/ppo_device.py --device cuda --env-id planetnav/Cruise-Target-v2 --num-envs 65536 \
        --num-steps 16 --num-minibatches 8 --update-epochs 4 --total-timesteps 100000000 \
        --bank-workers "$(nproc)" --eval-episodes 100 2>&1 | tee "$OUT/ppo.log"
    ;;
*)
    echo "usage: sh benchmarks/device_check.sh [quick|ppo]" >&2
    exit 2
    ;;
esac
