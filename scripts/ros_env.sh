# Sourced by scripts that run the built node: a local ROS master and the build's environment.
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
set +u
source _build/devel/setup.bash
set -u
