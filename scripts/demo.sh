#!/usr/bin/env bash
# make demo: the sim and msspr_policy_node serving the shipped checkpoint on
# pointmaze-medium, in lockstep over ROS, evaluated on the five tasks; prints the
# per-task table and writes build/demo/{results.json,trajectories.png,success.png}.
#   MSSPR_DEMO_OBSERVATION_MODE=pixels make demo   serve from 64x64 camera images instead of states
#   DEMO_EPISODES=50 make demo       episodes per task (default 20)
#   DEMO_TASKS_FILE=config/eval_tasks_medium_easy.yaml make demo   custom tasks
#   MSSPR_DEMO_ENV=cube-single make demo   the URDF arm's cube-single (states; writes
#                                          results.json and success.png); with
#                                          MSSPR_DEMO_OBSERVATION_MODE=pixels from the camera and a goal image
#   MSSPR_DEMO_CHECKPOINT=FILE make demo   cube-single and the envs below: serve FILE instead
#                                          of the shipped one
#   MSSPR_DEMO_ENV=antmaze-medium make demo  the ant on antmaze-medium (states; 1000 steps)
#   MSSPR_DEMO_ENV=scene make demo         the arm's scene (or cube-double, puzzle-3x3,
#                                          puzzle-4x4; states), from msspr_policy_node/checkpoints/ENV-state.pt
#   MSSPR_DEMO_ROBOT=pointmaze_base make demo   (or ur5e_cube with MSSPR_DEMO_ENV=cube-single;
#                                          a spec with a camera, pointmaze_camera or
#                                          ur5e_cube_camera, serves the pixels checkpoint)
#                                          over standard ROS messages through the robot
#                                          spec config/robots/NAME.yaml (docs/bring_your_own_robot.md)
set -euo pipefail
BUILD=${1:-build}
cd "$(dirname "$0")/.."
source scripts/ros_env.sh
OUT=$PWD/$BUILD/demo
mkdir -p "$OUT"
rm -f "$OUT/results.json"
LOG=$OUT/roslaunch.log
OBS_MODE=${MSSPR_DEMO_OBSERVATION_MODE:-}
if [ "${MSSPR_DEMO_PIXELS:-0}" = 1 ]; then
  echo "[demo] MSSPR_DEMO_PIXELS=1 is deprecated: use MSSPR_DEMO_OBSERVATION_MODE=pixels" >&2
  OBS_MODE=${OBS_MODE:-pixels}
fi
case "${OBS_MODE:-state}" in
  state) PIXELS=false ;;
  pixels) PIXELS=true ;;
  *)
    echo "[demo] MSSPR_DEMO_OBSERVATION_MODE must be state or pixels, not '$OBS_MODE'" >&2
    exit 2
    ;;
esac
# A robot spec with a camera (images:) serves a pixels policy.
if [ -n "${MSSPR_DEMO_ROBOT:-}" ] && grep -q '^images:' "config/robots/${MSSPR_DEMO_ROBOT}.yaml" 2>/dev/null; then
  PIXELS=true
fi
ENV=${MSSPR_DEMO_ENV:-pointmaze}
case "$ENV" in
  pointmaze)
    CKPT=msspr_policy_node/checkpoints/pointmaze-medium-$([ "$PIXELS" = true ] && echo pixels || echo state).pt
    if [ -f "$CKPT" ]; then
      echo "[demo] pointmaze-medium: msspr_policy_node serving $CKPT ($([ "$PIXELS" = true ] && echo images || echo states)), lockstep over ROS"
      LAUNCH=(demo.launch observation_mode:="$([ "$PIXELS" = true ] && echo pixels || echo state)")
      [ -n "${DEMO_TASKS_FILE:-}" ] && LAUNCH+=(tasks_file:="$(readlink -f "$DEMO_TASKS_FILE")")
    else
      echo "[demo] no $CKPT: evaluating the scripted expert instead"
      LAUNCH=(expert_demo.launch)
    fi
    ;;
  cube-single)
    if [ -n "${DEMO_TASKS_FILE:-}" ]; then
      echo "[demo] MSSPR_DEMO_ENV=cube-single runs the cube's five tasks: no DEMO_TASKS_FILE" >&2
      exit 2
    fi
    MODE=$([ "$PIXELS" = true ] && echo pixels || echo state)
    CKPT=${MSSPR_DEMO_CHECKPOINT:-msspr_policy_node/checkpoints/cube-single-$MODE.pt}
    if [ ! -f "$CKPT" ]; then
      echo "[demo] no $CKPT$([ "$PIXELS" = true ] && [ -z "${MSSPR_DEMO_CHECKPOINT:-}" ] && echo ": give a pixels checkpoint of the arm with MSSPR_DEMO_CHECKPOINT=FILE (one trained with config/cube_pixels_cpu.yaml)")" >&2
      exit 1
    fi
    echo "[demo] cube-single (URDF arm): msspr_policy_node serving $CKPT ($([ "$PIXELS" = true ] && echo "camera and goal images" || echo states)), lockstep over ROS"
    LAUNCH=(demo.launch env:=cube-single observation_mode:="$([ "$PIXELS" = true ] && echo pixels || echo state)")
    if [ "$PIXELS" = true ]; then
      LAUNCH+=(cube_pixel_checkpoint:="$(readlink -f "$CKPT")")
    else
      LAUNCH+=(cube_checkpoint:="$(readlink -f "$CKPT")")
    fi
    ;;
  antmaze-medium|antmaze-large|cube-double|scene|puzzle-3x3|puzzle-4x4)
    if [ "$PIXELS" = true ] || [ -n "${DEMO_TASKS_FILE:-}" ] || [ -n "${MSSPR_DEMO_ROBOT:-}" ]; then
      echo "[demo] MSSPR_DEMO_ENV=$ENV serves the state checkpoint on msspr's own topics: no MSSPR_DEMO_OBSERVATION_MODE=pixels, DEMO_TASKS_FILE or MSSPR_DEMO_ROBOT" >&2
      exit 2
    fi
    CKPT=${MSSPR_DEMO_CHECKPOINT:-msspr_policy_node/checkpoints/$ENV-state.pt}
    if [ ! -f "$CKPT" ]; then
      echo "[demo] no $CKPT: give a state checkpoint of $ENV with MSSPR_DEMO_CHECKPOINT=FILE (docs/training.md)" >&2
      exit 1
    fi
    echo "[demo] $ENV: msspr_policy_node serving $CKPT (states), lockstep over ROS"
    LAUNCH=(demo.launch env:="$ENV" task_checkpoint:="$(readlink -f "$CKPT")")
    ;;
  *)
    echo "[demo] MSSPR_DEMO_ENV must be pointmaze, cube-single, cube-double, scene, puzzle-3x3, puzzle-4x4, antmaze-medium or antmaze-large, not '$ENV'" >&2
    exit 2
    ;;
esac
if [ -n "${MSSPR_DEMO_ROBOT:-}" ]; then
  if [ ! -f "config/robots/$MSSPR_DEMO_ROBOT.yaml" ]; then
    echo "[demo] MSSPR_DEMO_ROBOT: no config/robots/$MSSPR_DEMO_ROBOT.yaml" >&2
    exit 2
  fi
  echo "[demo] over standard messages through config/robots/$MSSPR_DEMO_ROBOT.yaml"
  LAUNCH+=(robot:="$MSSPR_DEMO_ROBOT")
fi
echo "[demo] running sim + agent + evaluator, ${DEMO_EPISODES:-20} episodes per task (log: $LOG) ..."
roslaunch -p "$MSSPR_PORT" msspr "${LAUNCH[@]}" out_dir:="$OUT" episodes:="${DEMO_EPISODES:-20}" >"$LOG" 2>&1 || true
grep -E "msspr_eval: task" "$LOG" | sed -E 's/^.*(msspr_eval: task)/[demo] \1/; s/\x1b\[[0-9;]*m//g' || true
if [ ! -s "$OUT/results.json" ]; then
  echo "[demo] failed: no $OUT/results.json; the launch log follows" >&2
  tail -30 "$LOG" >&2
  exit 1
fi
python3 scripts/print_results.py "$OUT/results.json"
if [ "$ENV" = pointmaze ] || [ "${ENV#antmaze}" != "$ENV" ]; then
  echo "[demo] wrote $OUT/results.json, $OUT/trajectories.png and $OUT/success.png"
else
  echo "[demo] wrote $OUT/results.json and $OUT/success.png"
fi
