# Sourced by scripts that run the built node: a local ROS master and the build's environment
# (LCD_ROS_SETUP: another setup.bash, such as an install space's).
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
set +u
source "${LCD_ROS_SETUP:-_build/devel/setup.bash}"
set -u

# Waits for SERVICE of the launch PID just started (60 s at most), or shows the end of its LOG and
# exits if the launch died or the service never came.
wait_for_service() {  # SERVICE PID LOG
  local service=$1 pid=$2 log=$3
  for _ in $(seq 1 120); do
    if rosservice list 2> /dev/null | grep -qx "$service"; then return 0; fi
    if ! kill -0 "$pid" 2> /dev/null; then
      tail -n 20 "$log" >&2
      echo "$(basename "$0" .sh): the detector did not start; its log is $log" >&2
      exit 1
    fi
    sleep 0.5
  done
  echo "$(basename "$0" .sh): $service did not appear within 60 s; see $log" >&2
  exit 1
}

# Waits until node PUBLISHER is connected to each SUBSCRIBER named for its TOPIC (30 s at most);
# else names LOG and exits. The master lists a subscriber before the connection is up, and ROS 1
# drops what a publisher sends before then: a bag played at once lost its first messages (and a
# keyframe with them), a keyframe sent too early was missing from the pose graph.
wait_for_connections() {  # PUBLISHER LOG TOPIC:SUBSCRIBER...
  local publisher=$1 log=$2
  shift 2
  local connected="" missing=""
  for _ in $(seq 1 60); do
    # Bus info: "* topic: T", then "* to: N" for each connection.
    connected=$(rosnode info "$publisher" 2> /dev/null | awk '
      /^ \* topic: / { topic = $3 }
      /^    \* to: / { print topic ":" $3 }')
    missing=""
    for pair in "$@"; do
      grep -qx -- "$pair" <<< "$connected" || missing="$missing $pair"
    done
    [ -z "$missing" ] && return 0
    sleep 0.5
  done
  echo "$(basename "$0" .sh): $publisher did not connect to$missing within 30 s; see $log" >&2
  exit 1
}

# Plays BAG (rosbag play --clock at RATE) in the background (PLAYER_PID; the caller stops it on
# exit) once the player is connected to every SUBSCRIBER named for its TOPIC: paused until then.
play_bag_when_connected() {  # BAG RATE LOG TOPIC:SUBSCRIBER...
  local bag=$1 rate=$2 log=$3
  shift 3
  rosbag play --clock --quiet --pause --rate="$rate" "$bag" __name:=bag_player \
    < /dev/null > /dev/null &
  PLAYER_PID=$!
  wait_for_connections /bag_player "$log" "$@"
  if ! rosservice call /bag_player/pause_playback "data: false" > /dev/null; then
    echo "$(basename "$0" .sh): the bag player did not resume; see $log" >&2
    exit 1
  fi
}
