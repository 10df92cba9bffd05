# ROS messages <-> core types, in one place: the node and the bag reader share it.
add_library(${PROJECT_NAME}_messages src/messages/ros_conversions.cpp)
target_include_directories(${PROJECT_NAME}_messages SYSTEM PUBLIC ${catkin_INCLUDE_DIRS})
target_include_directories(${PROJECT_NAME}_messages PUBLIC src)
target_link_libraries(${PROJECT_NAME}_messages ${PROJECT_NAME}_core ${PROJECT_NAME}_backend
  ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_messages ${PROJECT_NAME}_generate_messages_cpp)

# Bag reading for the offline tools: frames with their odometry and camera_info, as the node
# receives them.
add_library(${PROJECT_NAME}_bag src/bag/bag_source.cpp)
target_link_libraries(${PROJECT_NAME}_bag ${PROJECT_NAME}_messages ${PROJECT_NAME}_eval
  ${catkin_LIBRARIES})

# Parameters from the parameter server, for both nodelets.
add_library(${PROJECT_NAME}_ros_parameters src/ros/ros_parameter_source.cpp)
target_include_directories(${PROJECT_NAME}_ros_parameters SYSTEM PUBLIC ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_ros_parameters ${PROJECT_NAME}_core ${catkin_LIBRARIES})

# ROS wrapper: the nodelet, its standalone node, and the demo tools.
add_library(${PROJECT_NAME}_nodelet
  src/ros/loop_markers.cpp
  src/ros/loop_closure_node.cpp
  src/ros/camera_info_state.cpp
  src/ros/keyframe_preparation.cpp
  src/ros/node_inputs.cpp
  src/ros/node_outputs.cpp
  src/ros/map_services.cpp
  src/ros/node_diagnostics.cpp
  src/ros/fleet_link.cpp
  src/ros/evidence_channel.cpp
  src/ros/loop_closure_nodelet.cpp)
target_include_directories(${PROJECT_NAME}_nodelet SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_nodelet ${PROJECT_NAME}_messages ${PROJECT_NAME}_config
  ${PROJECT_NAME}_ros_parameters ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_nodelet ${PROJECT_NAME}_generate_messages_cpp)

# The markers' cost per keyframe as the map grows (bench/README.md).
add_executable(lcd_bench_markers src/tools/lcd_bench_markers.cpp)
target_include_directories(lcd_bench_markers SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(lcd_bench_markers ${PROJECT_NAME}_nodelet ${PROJECT_NAME}_eval
  ${catkin_LIBRARIES})

add_executable(loop_closure_node src/ros/nodelet_main.cpp)
target_include_directories(loop_closure_node SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(loop_closure_node ${catkin_LIBRARIES})
target_compile_definitions(loop_closure_node PRIVATE NODE_NAME="loop_closure"
  NODELET_TYPE="landmark_loop_closure/LoopClosureNodelet")

# The reference pose-graph backend: its nodelet and standalone node.
add_library(${PROJECT_NAME}_pose_graph_nodelet src/ros/pose_graph_node.cpp)
target_include_directories(${PROJECT_NAME}_pose_graph_nodelet SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_include_directories(${PROJECT_NAME}_pose_graph_nodelet PRIVATE src/ros)
target_link_libraries(${PROJECT_NAME}_pose_graph_nodelet ${PROJECT_NAME}_messages
  ${PROJECT_NAME}_backend ${PROJECT_NAME}_ros_parameters ${catkin_LIBRARIES})
add_dependencies(${PROJECT_NAME}_pose_graph_nodelet ${PROJECT_NAME}_generate_messages_cpp)
add_executable(pose_graph_node src/ros/nodelet_main.cpp)
target_include_directories(pose_graph_node SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(pose_graph_node ${catkin_LIBRARIES})
target_compile_definitions(pose_graph_node PRIVATE NODE_NAME="pose_graph"
  NODELET_TYPE="landmark_loop_closure/PoseGraphNodelet")

# Installed (catkin_make install, catkin build --install): libraries, every program, launch and
# config files, messages, and the models (found at run time through the package path).
install(TARGETS ${PROJECT_NAME}_core ${PROJECT_NAME}_config ${PROJECT_NAME}_nodelet
  ${PROJECT_NAME}_pose_graph_nodelet ${PROJECT_NAME}_ros_parameters
  ${PROJECT_NAME}_sim ${PROJECT_NAME}_eval ${PROJECT_NAME}_messages ${PROJECT_NAME}_bag
  ${PROJECT_NAME}_backend
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION})
install(TARGETS loop_closure_node pose_graph_node lcd_bench_markers
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(DIRECTORY include/${PROJECT_NAME}/ DESTINATION ${CATKIN_PACKAGE_INCLUDE_DESTINATION})
install(DIRECTORY launch config msg srv DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(FILES nodelet_plugins.xml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(DIRECTORY model/ DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/model
  FILES_MATCHING PATTERN "*.onnx" PATTERN "*.onnx.json" PATTERN "*.onnx.source" PATTERN "*.whitening")
install(PROGRAMS scripts/plot_results.py DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
# The backbone's fetch beside the models it writes: share/landmark_loop_closure/scripts/
# fetch_backbone.sh fills share/landmark_loop_closure/model/ (an install made offline).
install(PROGRAMS scripts/fetch_backbone.sh scripts/convert_backbone.py
  DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION}/scripts)

# Demo tools: the generated corridor bag and a report of loops against ground truth.
add_executable(make_demo_bag src/tools/make_demo_bag.cpp)
target_include_directories(make_demo_bag SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(make_demo_bag ${PROJECT_NAME}_sim ${catkin_LIBRARIES})

# Wrong loops on purpose, for the backend's robustness check (demo.sh --wrong-loops, rostest).
add_executable(loop_injector src/tools/loop_injector.cpp)
target_include_directories(loop_injector SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(loop_injector ${catkin_LIBRARIES})
add_dependencies(loop_injector ${PROJECT_NAME}_generate_messages_cpp)

add_executable(demo_report src/tools/demo_report.cpp)
target_include_directories(demo_report SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(demo_report ${PROJECT_NAME}_eval ${catkin_LIBRARIES})
add_dependencies(demo_report ${PROJECT_NAME}_generate_messages_cpp)
install(TARGETS make_demo_bag demo_report loop_injector RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

# Offline evaluation tool: image folders, the generated corridor, and bags (hence ROS).
add_executable(lcd_evaluate src/tools/lcd_evaluate.cpp src/tools/evaluate_support.cpp
  src/tools/evaluate_detector.cpp src/tools/loop_offsets.cpp)
target_include_directories(lcd_evaluate SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(lcd_evaluate ${PROJECT_NAME}_bag ${PROJECT_NAME}_config ${PROJECT_NAME}_sim
  ${catkin_LIBRARIES})

add_executable(lcd_train src/tools/lcd_train.cpp)
target_include_directories(lcd_train SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(lcd_train ${PROJECT_NAME}_bag ${PROJECT_NAME}_config ${catkin_LIBRARIES})
install(TARGETS lcd_evaluate lcd_train RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
