#!/usr/bin/env bash
# LiDAR-IMU extrinsic online (issue "what real vehicles bring", part 2): each scene's recording is
# run with its true extrinsic (T_imu_lidar in the simulator's scenario.yaml) made wrong by a
# rotation of ROT_DEG about (1, -1, 1)/sqrt(3) (applied on the LiDAR side: R_given = R_true·Exp(e))
# and a translation of TRANS_CM along the same axis, with estimate_extrinsic on. One markdown row
# per scene: the share of scans held (the motion did not excite the extrinsic), the error of the
# estimate against the truth (rotation angle of R_true⁻¹·R_est / translation) after 10, 30 and 60 s
# of scans and at the end, when it settled within 0.5 deg and 2 cm for good, and the ATE. The
# prior sigma is the size of the error given (initial_covariance.extrinsic_rotation_std and
# extrinsic_translation_std; a --set after -- overrides it).
#
#   bench/extrinsic.sh [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-r ROT_DEG] [-m TRANS_CM]
#                      SCENARIO... [-- --set k=v ...]
#   defaults: config/mid360.yaml, lidar mid360, out/bench, seed 1, 3 deg, 5 cm
#
# Simulations are shared with bench/run_scenarios.sh (OUTDIR/sim-<scenario>-<lidar>-<seed>).
# FUSE_BIN: binaries (default build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=config/mid360.yaml; LIDAR=mid360; OUT=out/bench; SEED=1; ROT=3; TRANS=5; SCENARIOS=(); EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    -c) CONFIG=$2; shift 2 ;;
    -l) LIDAR=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -s) SEED=$2; shift 2 ;;
    -r) ROT=$2; shift 2 ;;
    -m) TRANS=$2; shift 2 ;;
    --) shift; EXTRA=("$@"); break ;;
    *) SCENARIOS+=("$1"); shift ;;
  esac
done
[ ${#SCENARIOS[@]} -gt 0 ] || { echo "usage: $0 [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-r ROT_DEG] [-m TRANS_CM] SCENARIO... [-- --set k=v ...]" >&2; exit 2; }
BIN=${FUSE_BIN:-build/bin}
mkdir -p "$OUT"
get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
# The value of `key: [a, b, c]` under T_imu_lidar in a scenario.yaml, as "a b c".
truth() { awk -v k="$2" '/^T_imu_lidar:/{on=1; next} on && /^[^ ]/{on=0} on && $1 == k":" {gsub(/[][,]/, " "); $1=""; print}' "$1"; }
echo "| scenario | lidar | seed | given error | held | 10 s | 30 s | 60 s | end | within 0.5° and 2 cm from | ATE m | status |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for sc in "${SCENARIOS[@]}"; do
  sim="$OUT/sim-$sc-$LIDAR-$SEED"
  if [ ! -f "$sim/recording.mcap" ]; then
    $BIN/fuse-sim --scenario "$sc" --seed "$SEED" --lidar "$LIDAR" --out "$sim" > "$sim.log" 2>&1
  fi
  read -r tx ty tz <<< "$(truth "$sim/scenario.yaml" translation)"
  read -r qx qy qz qw <<< "$(truth "$sim/scenario.yaml" rotation_xyzw)"
  # R_given = R_true·Exp(e), e = ROT_DEG about (1, -1, 1)/sqrt(3); t_given = t_true + TRANS_CM along the axis.
  given=$(awk -v x="$qx" -v y="$qy" -v z="$qz" -v w="$qw" -v r="$ROT" -v m="$TRANS" -v tx="$tx" -v ty="$ty" -v tz="$tz" 'BEGIN{
    h = r * atan2(0, -1) / 360; s = sin(h) / sqrt(3); c = cos(h); ex = s; ey = -s; ez = s
    gw = w*c - x*ex - y*ey - z*ez; gx = w*ex + x*c + y*ez - z*ey; gy = w*ey - x*ez + y*c + z*ex; gz = w*ez + x*ey - y*ex + z*c
    d = m / 100 / sqrt(3)
    printf "%.9f %.9f %.9f %.9f %.6f %.6f %.6f", gx, gy, gz, gw, tx + d, ty - d, tz + d }')
  read -r gx gy gz gw gtx gty gtz <<< "$given"
  run="$OUT/run-$sc-$LIDAR-$SEED-ext$ROT-$TRANS-$(basename "$CONFIG" .yaml)"
  st=ok
  $BIN/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off --extrinsic-from config \
    --set estimator.estimate_extrinsic=true --set "estimator.extrinsic.translation=[$gtx,$gty,$gtz]" \
    --set "estimator.extrinsic.rotation_xyzw=[$gx,$gy,$gz,$gw]" \
    --set "estimator.initial_covariance.extrinsic_rotation_std=$(awk -v r="$ROT" 'BEGIN{printf "%.6f", r * atan2(0, -1) / 180}')" \
    --set "estimator.initial_covariance.extrinsic_translation_std=$(awk -v m="$TRANS" 'BEGIN{printf "%.4f", m / 100}')" "${EXTRA[@]}" > "$run.txt" 2>&1 || st="exit $?"
  ate=nan
  if $BIN/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" > "$run.eval" 2>&1; then ate=$(get ate_rmse_m "$run.eval"); fi
  # diagnostics.csv: ext_rx_deg..ext_rz_deg (the rotation vector, degrees), ext_x..ext_z, ext_held
  # (0 estimated, 1 held, 2 held but for the tilt).
  row=$(awk -F, -v x="$qx" -v y="$qy" -v z="$qz" -v w="$qw" -v tx="$tx" -v ty="$ty" -v tz="$tz" '
    NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
    {
      t = $col["t"]; if (n == 0) t0 = t
      vx = $col["ext_rx_deg"]; vy = $col["ext_ry_deg"]; vz = $col["ext_rz_deg"]
      th = sqrt(vx*vx + vy*vy + vz*vz) * atan2(0, -1) / 180; s = th > 0 ? sin(th / 2) / (th * 180 / atan2(0, -1)) : 0
      ex = vx * s; ey = vy * s; ez = vz * s; ew = cos(th / 2)
      dw = w*ew + x*ex + y*ey + z*ez  # the scalar part of conj(q_true)·q_est
      if (dw < 0) dw = -dw; if (dw > 1) dw = 1
      rot = 2 * atan2(sqrt(1 - dw*dw), dw) * 180 / atan2(0, -1)
      trans = sqrt(($col["ext_x"] - tx)^2 + ($col["ext_y"] - ty)^2 + ($col["ext_z"] - tz)^2) * 100
      cell = sprintf("%.2f° / %.1f cm", rot, trans)
      for (k = 1; k <= 3; ++k) if (t - t0 <= mark[k] + 1e-6) at[k] = cell
      if (rot > 0.5 || trans > 2) settled = "never"; else if (settled == "never" || settled == "") settled = sprintf("%.0f s", t - t0)
      held += $col["ext_held"] != 0; tilt += $col["ext_held"] == 2; ++n; last = cell  # 1 all held, 2 held but the tilt
    }
    BEGIN { mark[1] = 10; mark[2] = 30; mark[3] = 60 }
    END { for (k = 1; k <= 3; ++k) if (t - t0 < mark[k]) at[k] = "–"
          printf "%.0f %%%s | %s | %s | %s | %s | %s", 100 * held / n, (tilt > 0 ? sprintf(" (tilt estimated on %.0f %%)", 100 * tilt / n) : ""),
                 at[1], at[2], at[3], last, settled }' "$run/diagnostics.csv")
  printf "| %s | %s | %s | %s° / %s cm | %s | %s | %s |\n" "$sc" "$LIDAR" "$SEED" "$ROT" "$TRANS" "$row" "$ate" "$st"
done
