#!/bin/bash
# Issue #23 on a lent GPU machine (prepared by bench/device/prepare.sh; carry .gl .whl .xshared):
# GL on the GPU, mcpt (fragment, compute and wavefront dispatch) beside Mitsuba cuda_ad_rgb at 1024x1024,
# throughput, then the suite in parallel and its failures again in one process (16 processes
# sharing one H200 lost draws during long draws: bench/RESULTS.md). Files land in $OUT.
# PEER_S, SUITE_S, TP_S: seconds each step may take (the device tool allows 600 a call).
export PYTHONUNBUFFERED=1
T0=$(date +%s); el() { echo "== $(( $(date +%s) - T0 )) s: $*"; }
# Only on the lent machine (its driver lives in /usr/local/nvidia): unpacking GL loaders into / of
# any other machine would replace its own.
[ -d /usr/local/nvidia ] || { echo "run.sh: not a lent GPU machine (no /usr/local/nvidia)"; exit 2; }
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
f=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json; [ -f $f ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$f
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site
mkdir -p /tmp/mts && tar -xJf .whl/mitsuba-drjit-site.tar.xz -C /tmp/mts || exit 1
python3 -m pip install -q --no-index --no-deps --no-build-isolation -e . 2>&1 | tail -3
printf '#!/bin/sh\nPYTHONPATH=/tmp/mts:/tmp/site exec python3 "$@"\n' > /tmp/peerpy; chmod +x /tmp/peerpy
export MCPT_SHARED=$PWD/.xshared MCPT_PEER_PYTHON=/tmp/peerpy OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
python3 -c "import moderngl; c = moderngl.create_standalone_context(backend='egl', require=430); print(c.info['GL_RENDERER'])"
el set-up done
timeout "${PEER_S:-260}" python3 -m mcpt.bench.gpu_peer -o /tmp/gp 2>&1 | tee "$OUT/peer.log" | grep -v "^round"
cp /tmp/gp/peer.json /tmp/gp/PEER.md "$OUT/" 2>/dev/null
el peer done
timeout "${TP_S:-90}" python3 -m mcpt.bench.run --only throughput -o /tmp/tp > "$OUT/throughput.log" 2>&1
grep -E "Mpaths/s" "$OUT/throughput.log"
el throughput done
timeout "${SUITE_S:-200}" python3 -m pytest -q -n 8 --dist loadfile -p no:benchmark > "$OUT/suite.log" 2>&1
tail -1 "$OUT/suite.log"
timeout 120 python3 -m pytest -q --lf -p no:xdist -p no:benchmark > "$OUT/suite-failed-alone.log" 2>&1
tail -1 "$OUT/suite-failed-alone.log"
el all done
