# Sourced by scripts that run the built node: a local ROS master and the build's environment.
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
set +u
source _build/devel/setup.bash
set -u

# Waits until NODE lists TOPIC among its subscriptions (30 s at most); else names LOG and exits.
wait_for_subscriber() {  # TOPIC NODE LOG
  for _ in $(seq 1 60); do
    if rostopic info "$1" 2> /dev/null | sed -n '/^Subscribers:/,$p' | grep -q " $2 "; then
      return 0
    fi
    sleep 0.5
  done
  echo "$(basename "$0" .sh): $2 did not subscribe to $1 within 30 s; see $3" >&2
  exit 1
}

# Plays BAG (rosbag play --clock at RATE, in the background: PLAYER_PID) once the player is
# connected to every NODE named for its TOPIC. A subscriber the master lists is not yet connected,
# and ROS 1 drops what a publisher sends before the connection is up: an unpaused bag lost its
# first messages, a keyframe with them. On failure names LOG and exits.
play_bag_when_connected() {  # BAG RATE LOG TOPIC:NODE...
  local bag=$1 rate=$2 log=$3
  shift 3
  rosbag play --clock --quiet --pause --rate="$rate" "$bag" __name:=bag_player \
    < /dev/null > /dev/null &
  PLAYER_PID=$!
  local connected="" missing=""
  for _ in $(seq 1 60); do
    # Bus info: "* topic: T", then "* to: N" for each connection.
    connected=$(rosnode info /bag_player 2> /dev/null | awk '
      /^ \* topic: / { topic = $3 }
      /^    \* to: / { print topic ":" $3 }')
    missing=""
    for pair in "$@"; do
      grep -qx -- "$pair" <<< "$connected" || missing="$missing $pair"
    done
    [ -z "$missing" ] && break
    sleep 0.5
  done
  local problem=""
  if [ -n "$missing" ]; then
    problem="the bag player did not connect to$missing within 30 s"
  elif ! rosservice call /bag_player/pause_playback "data: false" > /dev/null; then
    problem="the bag player did not resume (rosservice call /bag_player/pause_playback)"
  fi
  if [ -n "$problem" ]; then
    kill -INT "$PLAYER_PID" 2> /dev/null || true
    echo "$(basename "$0" .sh): $problem; see $log" >&2
    exit 1
  fi
}
