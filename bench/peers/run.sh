#!/usr/bin/env bash
# make bench-peers: our engine against Siconos (per step) and Yade (to rest), same scene.
# Installs the peers with apt if missing, builds the LD_PRELOAD shim, runs every comparison
# and writes bench/results/peers-YYYYMMDD-HHMM.json (bench/peers/README.md explains it).
#
# Knobs (environment):
#   PEERS_QUICK=1            smoke run: a few steps and short caps (file *-quick.json)
#   PEERS_STEPS=700          steps of the deposit, ours and Siconos with asserts off
#   PEERS_SHIPPED_STEPS=300  steps of the deposit in Siconos as shipped
#   PEERS_DENSE_CONTACTS=2000, PEERS_DENSE_STEPS=20   the dense start and its steps
#   PEERS_SICONOS_CAP_S=600  wall cap of each Siconos run (it stops and says so)
#   PEERS_YADE_CAP_S=600, PEERS_OURS_REST_CAP_S=600   caps of the runs to rest
#   PEERS_REST_DT_LARGE=5e-4 our second run to rest, at this larger time step (NSCD's
#                            regime; the first uses the common 5e-5 s); empty: skipped
#   PEERS_REST_TOL_LOOSE=1e-3 our third run to rest, at h = 5e-5 s with this NLGS
#                            tolerance (docs/tradeoff.md: enough for a pile at rest; the
#                            other runs use the common 1e-4); empty: skipped
#   PEERS_REST_RELAX=1.4     our fourth run to rest, at h = 5e-5 s and tol 1e-4 with this
#                            NLGS over-relaxation (docs/speed.md); empty: skipped
#   PEERS_REST_COMPLIANCE=0.01  our fifth run to rest, at h = 5e-5 s and tol 1e-4 with
#                            compliant contacts (Options.contact_compliance); empty: skipped
#   PEERS_REST_ANDERSON=0, PEERS_REST_HOT=2   NLGS of our runs to rest: Anderson depth and
#                            re-sweeps of the hot contacts (docs/speed.md: the fastest
#                            measured for this deposit; 4 and 0 were the default until
#                            2026-11-24 evening)
#   PEERS_SKIP="yade shipped"   parts to leave out (siconos, shipped, dense, yade)
#   PEERS_NOTE="..."         a note written into the JSON (e.g. "machine shared")
#   PEERS_KEEP=1             keep the work directory (logs, HDF5, per-run JSON)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"
HERE=bench/peers
VPY="$ROOT/.venv/bin/python"
SYSPY=/usr/bin/python3

if [[ "${PEERS_QUICK:-0}" == 1 ]]; then
  STEPS=${PEERS_STEPS:-40}; SHIPPED=${PEERS_SHIPPED_STEPS:-20}
  DENSE_C=${PEERS_DENSE_CONTACTS:-300}; DENSE_N=${PEERS_DENSE_STEPS:-3}
  SIC_CAP=${PEERS_SICONOS_CAP_S:-60}; YADE_CAP=${PEERS_YADE_CAP_S:-15}
  REST_CAP=${PEERS_OURS_REST_CAP_S:-15}; QUICK=true
else
  STEPS=${PEERS_STEPS:-700}; SHIPPED=${PEERS_SHIPPED_STEPS:-300}
  DENSE_C=${PEERS_DENSE_CONTACTS:-2000}; DENSE_N=${PEERS_DENSE_STEPS:-20}
  SIC_CAP=${PEERS_SICONOS_CAP_S:-600}; YADE_CAP=${PEERS_YADE_CAP_S:-600}
  REST_CAP=${PEERS_OURS_REST_CAP_S:-600}; QUICK=false
fi
SKIP=" ${PEERS_SKIP:-} "
skip() { [[ "$SKIP" == *" $1 "* ]]; }

# ---- the peers, installed with apt if missing --------------------------------------------
need=()
for p in python3-siconos python3-scipy python3-h5py yade g++; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if ((${#need[@]})); then
  echo "installing with apt: ${need[*]}"
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi
[[ -x "$VPY" ]] || { echo "no project venv at $VPY: run 'make install'" >&2; exit 1; }

WORK="$(mktemp -d /tmp/nscd-peers.XXXXXX)"
cleanup() { if [[ "${PEERS_KEEP:-0}" == 1 ]]; then echo "work directory kept: $WORK"; else rm -rf "$WORK"; fi; }
trap cleanup EXIT
cat /proc/loadavg > "$WORK/loadavg_start"
# one thread everywhere: our numba (set in ours.py), BLAS/OpenMP of the peers, Yade -j1
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

"$VPY" - "$WORK/config.json" <<PY
import json, sys, datetime
sys.path.insert(0, "$HERE")
import common
json.dump(dict(started=datetime.datetime.now().isoformat(timespec="seconds"), quick=$( [[ $QUICK == true ]] && echo True || echo False ),
               note="""${PEERS_NOTE:-}""", params=common.PARAMS, steps=$STEPS, shipped_steps=$SHIPPED,
               dense_contacts=$DENSE_C, dense_steps=$DENSE_N, siconos_cap_s=$SIC_CAP,
               yade_cap_s=$YADE_CAP, ours_rest_cap_s=$REST_CAP, skip="${PEERS_SKIP:-}",
               threads=1), open(sys.argv[1], "w"))
PY

# run NAME CMD...: whole-process wall time and exit code into process_times.tsv; output
# to NAME.log (its last line echoed).  A failed run is reported, not fatal.
run() {
  local name=$1; shift
  local t0 t1 rc=0
  t0=$(date +%s%N)
  "$@" >"$WORK/$name.log" 2>&1 || rc=$?
  t1=$(date +%s%N)
  printf '%s\t%s\t%s\n' "$name" "$(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f", (b-a)/1e9}')" "$rc" \
    >> "$WORK/process_times.tsv"
  if [[ $rc -ne 0 ]]; then
    echo "  $name FAILED (exit $rc); last lines of its log:"; tail -5 "$WORK/$name.log" | sed 's/^/    /'
  else
    echo "  $name: $(grep -v '^No module named siconos.fclib' "$WORK/$name.log" | tail -1)"
  fi
}

echo "peers: work directory $WORK; deposit $STEPS steps (Siconos shipped $SHIPPED), dense start at >= $DENSE_C contacts, $DENSE_N steps"

# ---- the LD_PRELOAD shim (Siconos's debug graph checks off), built here, never committed --
SHIM="$WORK/graph_assert_off.so"
KLIB=$(ls /usr/lib/x86_64-linux-gnu/libsiconos_kernel.so.* 2>/dev/null | head -1 || true)
g++ -O2 -shared -fPIC -o "$SHIM" "$HERE/graph_assert_off.cpp"
nm -D --defined-only "$SHIM" | awk '/SiconosGraph/{print $3}' | sort > "$WORK/shim.syms"
nm -D --defined-only "$KLIB" | awk '/state_assert|adjacent_vertices_ok/{print $3}' | sort > "$WORK/lib.syms"
if cmp -s "$WORK/shim.syms" "$WORK/lib.syms"; then MATCH=True; else MATCH=False; fi
"$VPY" - "$WORK" "$MATCH" "$KLIB" <<'PY'
import json, sys
w, match, lib = sys.argv[1], sys.argv[2] == "True", sys.argv[3]
syms = open(f"{w}/shim.syms").read().split()
json.dump(dict(source="bench/peers/graph_assert_off.cpp", compiled_with="g++ -O2 -shared -fPIC",
               library=lib, symbols=syms, symbols_match_library=match), open(f"{w}/shim.json", "w"))
PY
[[ $MATCH == True ]] || echo "  WARNING: the shim's symbols differ from $KLIB's: the asserts-off figures are not what they say"

# ---- our deposit (also makes the common start states) ------------------------------------
run ours_init "$VPY" $HERE/ours.py init --out "$WORK/init_state.json"
run ours_deposit "$VPY" $HERE/ours.py steps --state "$WORK/init_state.json" --steps "$STEPS" \
    --checkpoints "$SHIPPED,$STEPS" --dense-contacts "$DENSE_C" --dense-out "$WORK/dense_state.json" \
    --out "$WORK/ours_deposit.json"

# ---- Siconos ------------------------------------------------------------------------------
if ! skip siconos; then
  run siconos_off_deposit env LD_PRELOAD="$SHIM" $SYSPY $HERE/siconos_deposit.py \
      --state "$WORK/init_state.json" --steps "$STEPS" --checkpoints "$SHIPPED,$STEPS" \
      --cap-s "$SIC_CAP" --out "$WORK/siconos_off_deposit.json"
  if ! skip shipped; then
    run siconos_shipped_deposit $SYSPY $HERE/siconos_deposit.py \
        --state "$WORK/init_state.json" --steps "$SHIPPED" --checkpoints "$SHIPPED" \
        --cap-s "$SIC_CAP" --out "$WORK/siconos_shipped_deposit.json"
  fi
  if ! skip dense && [[ -f "$WORK/dense_state.json" ]]; then
    run ours_dense "$VPY" $HERE/ours.py steps --state "$WORK/dense_state.json" --steps "$DENSE_N" \
        --out "$WORK/ours_dense.json"
    run siconos_off_dense env LD_PRELOAD="$SHIM" $SYSPY $HERE/siconos_deposit.py \
        --state "$WORK/dense_state.json" --steps "$DENSE_N" --cap-s "$SIC_CAP" \
        --out "$WORK/siconos_off_dense.json"
    if ! skip shipped; then
      run siconos_shipped_dense $SYSPY $HERE/siconos_deposit.py \
          --state "$WORK/dense_state.json" --steps "$DENSE_N" --cap-s "$SIC_CAP" \
          --out "$WORK/siconos_shipped_dense.json"
    fi
  fi
fi

# ---- Yade: the same deposit to rest ---------------------------------------------------------
if ! skip yade; then
  AND=${PEERS_REST_ANDERSON:-0}; HOT=${PEERS_REST_HOT:-2}
  run ours_rest "$VPY" $HERE/ours.py rest --state "$WORK/init_state.json" --cap-s "$REST_CAP" \
      --anderson "$AND" --hot-sweeps "$HOT" --out "$WORK/ours_rest.json"
  DT_LARGE=${PEERS_REST_DT_LARGE-5e-4}
  if [[ -n "$DT_LARGE" ]]; then
    run ours_rest_dt_large "$VPY" $HERE/ours.py rest --state "$WORK/init_state.json" \
        --cap-s "$REST_CAP" --dt "$DT_LARGE" --anderson "$AND" --hot-sweeps "$HOT" \
        --out "$WORK/ours_rest_dt_large.json"
  fi
  TOL_LOOSE=${PEERS_REST_TOL_LOOSE-1e-3}
  if [[ -n "$TOL_LOOSE" ]]; then
    run ours_rest_loose_tol "$VPY" $HERE/ours.py rest --state "$WORK/init_state.json" \
        --cap-s "$REST_CAP" --tol "$TOL_LOOSE" --anderson "$AND" --hot-sweeps "$HOT" \
        --out "$WORK/ours_rest_loose_tol.json"
  fi
  RELAX=${PEERS_REST_RELAX-1.4}
  if [[ -n "$RELAX" ]]; then
    run ours_rest_sor "$VPY" $HERE/ours.py rest --state "$WORK/init_state.json" \
        --cap-s "$REST_CAP" --relax "$RELAX" --anderson "$AND" --hot-sweeps "$HOT" \
        --out "$WORK/ours_rest_sor.json"
  fi
  SOFT=${PEERS_REST_COMPLIANCE-0.01}
  if [[ -n "$SOFT" ]]; then
    run ours_rest_compliant "$VPY" $HERE/ours.py rest --state "$WORK/init_state.json" \
        --cap-s "$REST_CAP" --contact-compliance "$SOFT" --anderson "$AND" --hot-sweeps "$HOT" \
        --out "$WORK/ours_rest_compliant.json"
  fi
  run yade_rest env PEERS_STATE="$WORK/init_state.json" PEERS_OUT="$WORK/yade_rest.json" \
      PEERS_CAP_S="$YADE_CAP" yade -n -j1 -x $HERE/yade_deposit.py
fi

"$VPY" $HERE/report.py "$WORK"
