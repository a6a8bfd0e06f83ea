#!/usr/bin/env bash
# The GPU test suite (the `tiledlight-tests` package) on a real GPU: the device machine
# (an NVIDIA H200 lent through the `device` tool), where lavapipe's serial execution no
# longer hides races and driver differences. Run it whenever GPU code changes, and record
# the result (adapter, driver, commit, pass count) in docs/GPU-TESTS.md.
#
#   scripts/device-gpu-tests.sh stage   # here: build the test binaries, strip and pack them
#                                       # into .device/gpu-tests (git-ignored), and stage
#                                       # the Vulkan loader into .gl (../shared/tools/device-prep.sh)
#   scripts/device-gpu-tests.sh run [FILTER...]
#                                       # there (`carry: [".gl", ".device"]`): unpack, run every
#                                       # binary on the adapter named by WGPU_ADAPTER_NAME
#                                       # (default H200), a summary and the logs (logs.tar.gz) under $OUT
#
# The binaries are built with the dev profile (optimised dependencies; what CI runs), so
# staging reuses the local build instead of a second, release one; stripped and packed with
# xz they fit the device tool's 64 MiB limit on what travels. Tests read files relative to
# the directory they were built in (tests/reference, target/test-output), so `run` links
# that directory to the copy it runs in.
set -uo pipefail
cmd=${1:-}
shift || true
root=$(git rev-parse --show-toplevel 2>/dev/null || pwd)
cd "$root"
stage=.device/gpu-tests

case $cmd in
stage)
  set -e
  mkdir -p .git/info
  for p in /.gl/ /.device/; do grep -qxF "$p" .git/info/exclude 2>/dev/null || echo "$p" >>.git/info/exclude; done
  bash ../shared/tools/device-prep.sh --no-build >/dev/null
  rm -rf "$stage" && mkdir -p "$stage/bin"
  # Every test binary of the GPU package: one per file of tests/tests. Built with the
  # whole workspace selected, as `cargo xtask test` builds it (a `-p` build resolves other
  # dependency features and rebuilds them).
  cargo test --workspace --no-run --message-format=json 2>/dev/null |
    python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if (m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["kind"] == ["test"]
            and "#tiledlight-tests@" in m["package_id"]):
        print(m["target"]["name"], m["executable"])
' | while read -r name exe; do
    strip -o "$stage/bin/$name" "$exe"
  done
  echo "$root" >"$stage/built-in"
  git rev-parse --short=12 HEAD >"$stage/commit"
  git status --porcelain --untracked-files=no | grep -q . && echo "+uncommitted" >>"$stage/commit"
  tar -C "$stage" -cf - bin | xz -9 -T0 >"$stage/bin.tar.xz"
  rm -rf "$stage/bin"
  ls -la "$stage"
  du -sh .gl "$stage"
  ;;
run)
  out=${OUT:-gpu-tests-out}
  logs=/tmp/gpu-tests/logs
  mkdir -p "$out"
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
  if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  fi
  export WGPU_ADAPTER_NAME=${WGPU_ADAPTER_NAME:-H200} WGPU_BACKEND=${WGPU_BACKEND:-vulkan}
  # The seed the tests fall back to themselves (crates/cull/tests/common/seed.rs).
  export PROPTEST_RNG_SEED=${PROPTEST_RNG_SEED:-20261122}
  built_in=$(cat "$stage/built-in")
  if [ "$built_in" != "$root" ] && [ ! -e "$built_in" ]; then
    mkdir -p "$(dirname "$built_in")" && ln -s "$root" "$built_in"
  fi
  mkdir -p /tmp/gpu-tests/logs && xz -dc "$stage/bin.tar.xz" | tar -C /tmp/gpu-tests -xf -
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
  echo "commit $(cat "$stage/commit" | tr '\n' ' ')" | tee -a "$out/gpu.txt"
  passed=0 failed=0 failing=()
  for exe in /tmp/gpu-tests/bin/*; do
    name=$(basename "$exe")
    # Each file's tests run as threads of one process, sharing one device, as `cargo test`
    # runs them: concurrency lavapipe never shows.
    # --show-output: what passing tests measured (FLIP, errors, counts) goes in the log too.
    timeout 500 "$exe" --show-output "$@" >"$logs/$name.log" 2>&1
    rc=$?
    p=$(grep -oE '[0-9]+ passed' "$logs/$name.log" | tail -1 | cut -d' ' -f1)
    f=$(grep -oE '[0-9]+ failed' "$logs/$name.log" | tail -1 | cut -d' ' -f1)
    passed=$((passed + ${p:-0}))
    failed=$((failed + ${f:-0}))
    if [ $rc -ne 0 ]; then
      failing+=("$name(rc $rc)")
      [ -z "$f" ] && failed=$((failed + 1))
    fi
    echo "$name: rc $rc, ${p:-0} passed, ${f:-0} failed" | tee -a "$out/summary.txt"
  done
  grep -h "^adapter:" "$logs"/*.log | sort -u | head -1 | tee -a "$out/gpu.txt"
  echo "gpu-tests: $passed passed, $failed failed ${failing[*]}" | tee -a "$out/summary.txt"
  # The device tool returns at most 8 files: the logs travel as one archive, with the
  # failure artefacts (-actual/-difference PNGs) the tests wrote.
  if [ -d "$root/target/test-output" ]; then cp -r "$root/target/test-output" "$logs/"; fi
  tar -C "$logs" -czf "$out/logs.tar.gz" .
  [ "$failed" -eq 0 ]
  ;;
*)
  echo "usage: $0 stage | run [TEST FILTER...]" >&2
  exit 2
  ;;
esac
