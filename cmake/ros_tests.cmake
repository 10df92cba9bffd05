# Tests of the ROS wrapper: message conversions, the running node, every shipped launch file.
find_package(rostest REQUIRED)
find_package(roslaunch REQUIRED)

catkin_add_gtest(test_ros_conversions test/ros/test_ros_conversions.cpp)
target_include_directories(test_ros_conversions SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_ros_conversions ${PROJECT_NAME}_nodelet ${catkin_LIBRARIES}
  GTest::gtest_main)
target_compile_definitions(test_ros_conversions PRIVATE
  PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")

# What robots exchange: rows and evidence through their messages.
catkin_add_gtest(test_fleet_messages test/ros/test_fleet_messages.cpp)
target_include_directories(test_fleet_messages SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_fleet_messages ${PROJECT_NAME}_messages ${catkin_LIBRARIES}
  GTest::gtest_main)

# LoopClosure.msg's contract between robots, read by a backend that knows only its documentation.
catkin_add_gtest(test_loop_contract test/ros/test_loop_contract.cpp)
target_include_directories(test_loop_contract SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_loop_contract ${PROJECT_NAME}_messages ${PROJECT_NAME}_backend
  ${catkin_LIBRARIES} GTest::gtest_main)

catkin_add_gtest(test_pose_graph_messages test/ros/test_pose_graph_messages.cpp)
target_include_directories(test_pose_graph_messages SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_pose_graph_messages ${PROJECT_NAME}_messages ${catkin_LIBRARIES}
  GTest::gtest_main)

catkin_add_gtest(test_bag_source test/ros/test_bag_source.cpp)
target_link_libraries(test_bag_source ${PROJECT_NAME}_bag ${catkin_LIBRARIES})

foreach(name node_revisit node_bad_input node_restart node_time_jump node_tf_timeout node_odometry
    node_depth_silent node_map_switch node_two_robots node_camera_gap node_rogue_peer)
  add_rostest_gtest(test_${name} test/ros/${name}.test test/ros/test_${name}.cpp)
  target_include_directories(test_${name} SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  target_link_libraries(test_${name} ${PROJECT_NAME}_sim ${PROJECT_NAME}_eval ${catkin_LIBRARIES})
  add_dependencies(test_${name} ${PROJECT_NAME}_generate_messages_cpp loop_closure_node
    ${PROJECT_NAME}_nodelet)
endforeach()
target_compile_definitions(test_node_restart PRIVATE
  PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")

# The detector and the pose-graph backend together on the demo's bag, with wrong loops injected.
add_rostest_gtest(test_node_pose_graph test/ros/node_pose_graph.test
  test/ros/test_node_pose_graph.cpp)
target_include_directories(test_node_pose_graph SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_node_pose_graph ${PROJECT_NAME}_sim ${PROJECT_NAME}_eval
  ${catkin_LIBRARIES})
add_dependencies(test_node_pose_graph ${PROJECT_NAME}_generate_messages_cpp loop_closure_node
  ${PROJECT_NAME}_nodelet pose_graph_node ${PROJECT_NAME}_pose_graph_nodelet loop_injector
  make_demo_bag)
target_compile_definitions(test_node_pose_graph PRIVATE
  MAKE_DEMO_BAG="$<TARGET_FILE:make_demo_bag>")

# The pose graph alone on keyframes and loops the test makes: the camera mount from tf, new maps.
add_rostest_gtest(test_node_pose_graph_synthetic test/ros/node_pose_graph_synthetic.test
  test/ros/test_node_pose_graph_synthetic.cpp)
target_include_directories(test_node_pose_graph_synthetic SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_node_pose_graph_synthetic ${PROJECT_NAME}_core ${catkin_LIBRARIES})
add_dependencies(test_node_pose_graph_synthetic ${PROJECT_NAME}_generate_messages_cpp pose_graph_node
  ${PROJECT_NAME}_pose_graph_nodelet)

roslaunch_add_file_check(launch IGNORE_UNSET_ARGS)
roslaunch_add_file_check(test/ros)
# The same revisit, with the pose looked up in tf instead of synced odometry.
add_rostest(test/ros/node_revisit_tf.test DEPENDENCIES test_node_revisit)
# Again with depth images, the camera mount from tf and metric poses in the base frame.
add_rostest(test/ros/node_revisit_depth.test DEPENDENCIES test_node_revisit)
# Again through a distorted lens named in camera_info.
add_rostest(test/ros/node_revisit_distorted.test DEPENDENCIES test_node_revisit)
# Again with the broad autoencoder, trained first by lcd_train on a generated bag (the script runs
# rostest on node_revisit_broad.test with the model it trained).
add_test(NAME tool_broad_trained_then_run
  COMMAND ${CATKIN_ENV} ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/broad_trained_then_run.sh
    $<TARGET_FILE:make_demo_bag> $<TARGET_FILE:lcd_train> ${CMAKE_CURRENT_SOURCE_DIR})
# The running node publishes exactly the loops lcd_evaluate --detector reports for the same bag.
add_rostest_gtest(test_node_matches_evaluate test/ros/node_matches_evaluate.test
  test/ros/test_node_matches_evaluate.cpp)
target_include_directories(test_node_matches_evaluate SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(test_node_matches_evaluate ${PROJECT_NAME}_sim ${catkin_LIBRARIES})
target_compile_definitions(test_node_matches_evaluate PRIVATE
  MAKE_DEMO_BAG="$<TARGET_FILE:make_demo_bag>" LCD_EVALUATE="$<TARGET_FILE:lcd_evaluate>"
  DEMO_CONFIG="${CMAKE_CURRENT_SOURCE_DIR}/config/demo.yaml")
add_dependencies(test_node_matches_evaluate ${PROJECT_NAME}_generate_messages_cpp
  loop_closure_node ${PROJECT_NAME}_nodelet make_demo_bag lcd_evaluate)
