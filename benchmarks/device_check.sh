#!/bin/sh
# The GPU checks of docs/performance.md ("GPU") as one prepared run on a lent GPU machine.
#
#   here:    make device-wheels                      # what the device image lacks, as wheels in .whl/
#   device:  sh benchmarks/device_check.sh quick     # carry .whl; results in $OUT; one 10-minute command
#            sh benchmarks/device_check.sh ppo       # the 10^8-decision PPO run, a command of its own
#
# The device image has python3 with a CUDA build of torch, numba and numba-cuda, and no network: the
# pure-Python packages planetnav adds (gymnasium, filterpy, jplephem, skyfield-data) travel as wheels and
# install into /tmp/site; the repository itself is put on PYTHONPATH (no install, no build).
#   quick: first the preflight (python -m planetnav_env.device.preflight, hard limit PREFLIGHT_S = 120 s):
#          card, driver, MIG; numba-cuda's NVVM and libdevice (a fallback CUDA_HOME if needed); a kernel and torch
#          on one stream; a >4 KB-parameter launch; libdevice's sin/atan2 to 1 ulp; the real kernels at
#          256 rows; 32-row parity. A failing check stops the run with one line naming it. Then
#          bench_gpu.py: env-only rates at N = 2^10, 2^14, 2^18, held and slewing, the CPU reference, GPU
#          rows against the host mode on three ids (200 decisions), the device PPO's end-to-end rate
#          (5 updates), the other ids' rates, the kernels' registers and occupancy, the step capped at 168
#          registers at 2^18, the host's bank-drawing rate ($OUT/bench_gpu.json, rewritten after every
#          stage; each stage's result in $OUT/bench_gpu.log as it finishes). The whole run stays inside
#          QUICK_S = 560 s (a hard timeout; the benchmark starts no stage past its deadline) and its last
#          line is a summary.
#   ppo:   baselines/ppo_device.py on planetnav/Cruise-Target-v2, 10^8 decisions from 16,384 rows in 382
#          updates of 64 minibatches (the configuration that reached the suite's score when trained on the
#          CPU: research/probes/ppo_device_1e8_cpu.py), then the suite's evaluation on the CPU ($OUT/ppo.log).
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
# numba's cache is empty on a fresh machine: compiling the CPU side (the host mode's row loops, which the
# parity stage runs, and the native vector env, the CPU reference and the evaluation) takes about 100 s.
# A second process compiles it into the cache while the benchmark compiles the bank's drawing and the CUDA
# kernels, so the later stages find it done. Its output goes to a file, not to this script's pipes.
python3 - >"$OUT/warm_cpu_cache.log" 2>&1 <<'PY' &
import time
import warnings

start = time.perf_counter()

import gymnasium as gym
import numpy as np
import torch

import planetnav_env  # noqa: F401
from planetnav_env.device.vector_env import DeviceVectorEnv

warnings.filterwarnings("ignore")
env = DeviceVectorEnv("planetnav/Cruise-Target-v1", 4, device="cpu", bank_size=4, refill="off")
env.reset(seed=0)
env.step(torch.zeros(4, dtype=torch.int64))
env.close()
vec = gym.make_vec("planetnav/Cruise-Target-v1", num_envs=2)
vec.reset(seed=0)
vec.step(np.zeros(2, np.int64))
print(f"CPU side compiled into numba's cache in {time.perf_counter() - start:.0f} s")
PY
warm=$!
start=$(date +%s)
elapsed() { echo $(( $(date +%s) - start )); }
case "${1:-quick}" in
quick)
    QUICK_S=${QUICK_S:-560}
    PREFLIGHT_S=${PREFLIGHT_S:-120}
    rc=0
    timeout -k 5 "$PREFLIGHT_S" python3 -m planetnav_env.device.preflight --env-file "$OUT/preflight.env" \
        >"$OUT/preflight.jsonl" 2>"$OUT/preflight.err" || rc=$?
    # Killed after its summary (at the interpreter's exit): the checks all finished.
    if [ "$rc" -ne 0 ] && tail -1 "$OUT/preflight.jsonl" | grep -q '^PREFLIGHT OK'; then rc=0; fi
    if [ "$rc" -ne 0 ]; then
        if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
            running=$(grep '"status": "running"' "$OUT/preflight.jsonl" | tail -1 | sed 's/.*"check": "\([^"]*\)".*/\1/')
            echo "SUMMARY device_check quick: PREFLIGHT FAILED at ${running:-start}: over its ${PREFLIGHT_S} s limit"
        else
            tail -1 "$OUT/preflight.jsonl"
            echo "SUMMARY device_check quick: $(tail -1 "$OUT/preflight.jsonl" | cut -c1-300) (exit $rc; $OUT/preflight.err)"
        fi
        kill "$warm" 2>/dev/null || true
        exit 1
    fi
    [ -s "$OUT/preflight.env" ] && . "$OUT/preflight.env"
    left=$(( QUICK_S - $(elapsed) ))
    if [ "$left" -lt 120 ]; then  # (timeout 0 would mean no limit at all)
        echo "SUMMARY device_check quick: $(tail -1 "$OUT/preflight.jsonl"); no time left for the benchmark ($left s)"
        kill "$warm" 2>/dev/null || true
        exit 1
    fi
    brc=0
    timeout -k 10 "$left" python3 benchmarks/bench_gpu.py --sizes 10 14 18 --max-registers 168 --ppo-updates 5 \
        --deadline-s $(( left - 90 )) --out "$OUT/bench_gpu.json" >"$OUT/bench_gpu.stdout" 2>"$OUT/bench_gpu.log" \
        || brc=$?
    kill "$warm" 2>/dev/null || true
    echo "SUMMARY device_check quick ($(elapsed) s): $(tail -1 "$OUT/preflight.jsonl"); bench exit $brc;" \
        "$(python3 benchmarks/bench_gpu.py --summarize "$OUT/bench_gpu.json" 2>&1 | tail -1)"
    exit 0
    ;;
ppo)
    python3 baselines/ppo_device.py --device cuda --env-id planetnav/Cruise-Target-v2 --num-envs 16384 \
        --num-steps 16 --num-minibatches 64 --update-epochs 4 --total-timesteps 100000000 \
        --bank-workers "$(nproc)" --eval-episodes 100 2>&1 | tee "$OUT/ppo.log"
    ;;
*)
    echo "usage: sh benchmarks/device_check.sh [quick|ppo]" >&2
    kill "$warm" 2>/dev/null || true
    exit 2
    ;;
esac
wait "$warm" || true
