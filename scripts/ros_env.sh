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
