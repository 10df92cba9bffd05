# Core tests link the ROS-free libraries only.
set(CORE_TESTS
  test_input_error
  test_keyframe_selector
  test_hog_descriptor
  test_descriptor_registry
  test_keyframe_database
  test_row_projection
  test_package_files
  test_old_map_file
  test_temporal_consistency
  test_condition_standardiser
  test_place_distinctiveness
  test_false_alarms
  test_calibrated_decision
  test_session_counter
  test_keyframe_describer
  test_thread_annotations
  test_score_normalisation
  test_appearance_check
  test_loop_detector
  test_loop_detector_map
  test_map_session
  test_loop_detector_ids
  test_map_file_safety
  test_sequence_matching
  test_bounded_queue
  test_detector_runtime
  test_input_monitor
  test_odometry_history
  test_camera_gap
  test_keyframe_store
  test_map_formats
  test_saved_search_rows
  test_match_image
  test_landmarks
  test_convnet_descriptor
  test_pca_whitening
  test_vlad
  test_cnn_global_descriptor
  test_backbone_descriptor
  test_broad_autoencoder
  test_geometric_verification
  test_lens_distortion
  test_metric_pose
  test_covariance_conventions
  test_shipped_config
  test_fleet_matcher
  test_foreign_map
  test_request_rate
  test_sim)
foreach(name ${CORE_TESTS})
  catkin_add_gtest(${name} test/core/${name}.cpp)
  target_link_libraries(${name} ${PROJECT_NAME}_core ${PROJECT_NAME}_config ${PROJECT_NAME}_sim
    GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
endforeach()
# The store test edits a map as a newer version would have written it, and reads its record
# layout; both map tests write the old map file through the private payload writer; the rows
# test checks the rows file's own checksum.
target_link_libraries(test_keyframe_store SQLite::SQLite3)
target_link_libraries(test_map_formats SQLite::SQLite3)
target_link_libraries(test_saved_search_rows SQLite::SQLite3)
target_link_libraries(test_map_file_safety SQLite::SQLite3)
target_include_directories(test_keyframe_store PRIVATE src)
target_include_directories(test_map_formats PRIVATE src)
target_include_directories(test_saved_search_rows PRIVATE src)
target_include_directories(test_old_map_file PRIVATE src)

# Evaluation: ground truth readers, metrics, the evaluator, and the regression guard on real data.
foreach(name test_ground_truth test_evaluation test_match_verification test_baselines_regression
    test_loop_detector_sim)
  catkin_add_gtest(${name} test/core/${name}.cpp)
  target_link_libraries(${name} ${PROJECT_NAME}_eval ${PROJECT_NAME}_sim GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
endforeach()
# The reader's test writes v5 files byte by byte (zlib) and v7.3 files through libmatio.
find_package(ZLIB REQUIRED)
target_link_libraries(test_ground_truth ZLIB::ZLIB PkgConfig::MATIO)

# The pose-graph backend links Ceres; its test links the backend and the core only.
catkin_add_gtest(test_pose_graph test/core/test_pose_graph.cpp)
target_link_libraries(test_pose_graph ${PROJECT_NAME}_backend ${PROJECT_NAME}_config ${PROJECT_NAME}_sim
  ${PROJECT_NAME}_eval GTest::gtest_main)
target_compile_definitions(test_pose_graph PRIVATE PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
catkin_add_gtest(test_pose_graph_chains test/core/test_pose_graph_chains.cpp)
target_link_libraries(test_pose_graph_chains ${PROJECT_NAME}_backend ${PROJECT_NAME}_sim
  GTest::gtest_main)
# Two robots on the corridor: their detectors, the loops between them and the pose graph.
catkin_add_gtest(test_fleet_corridor test/core/test_fleet_corridor.cpp)
target_link_libraries(test_fleet_corridor ${PROJECT_NAME}_backend ${PROJECT_NAME}_sim
  ${PROJECT_NAME}_eval GTest::gtest_main)
catkin_add_gtest(test_pose_graph_file test/core/test_pose_graph_file.cpp)
target_link_libraries(test_pose_graph_file ${PROJECT_NAME}_backend GTest::gtest_main)
catkin_add_gtest(test_pose_graph_session test/core/test_pose_graph_session.cpp)
target_link_libraries(test_pose_graph_session ${PROJECT_NAME}_backend GTest::gtest_main)
target_compile_definitions(test_pose_graph_session PRIVATE
  PACKAGE_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
catkin_add_gtest(test_pose_graph_runtime test/core/test_pose_graph_runtime.cpp)
target_link_libraries(test_pose_graph_runtime ${PROJECT_NAME}_backend GTest::gtest_main)

# A full disk (SQLite's file system wrapped so that writes fail) and the sessions of runs on one
# map, down to the pose graph's chains.
catkin_add_gtest(test_map_full_disk test/core/test_map_full_disk.cpp)
target_link_libraries(test_map_full_disk ${PROJECT_NAME}_backend ${PROJECT_NAME}_config
  ${PROJECT_NAME}_sim SQLite::SQLite3 GTest::gtest_main)

# Files written so that a failed write says so and leaves the earlier file (the pose graph's, a
# model).
catkin_add_gtest(test_durable_file test/core/test_durable_file.cpp)
target_link_libraries(test_durable_file ${PROJECT_NAME}_backend GTest::gtest_main)

include(cmake/ros_tests.cmake OPTIONAL)

# The verification benchmark on a sequence in KITTI's layout (the corridor exported that way).
add_test(NAME tool_bench_verification_kitti_layout
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/bench_verification_kitti.sh
    $<TARGET_FILE:lcd_bench_verification>)

# The pose-graph benchmark on KITTI 06's real route, a fifth of the loops wrong.
add_test(NAME tool_bench_pose_graph_kitti
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/bench_pose_graph_kitti.sh
    $<TARGET_FILE:lcd_bench_pose_graph>)

# lcd_train and lcd_evaluate with the learned descriptors (cnn_pca, broad) on a generated bag.
add_test(NAME tool_train_learned_descriptors
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/train_learned_descriptors.sh
    $<TARGET_FILE:make_demo_bag> $<TARGET_FILE:lcd_train> $<TARGET_FILE:lcd_evaluate>)

# Every tool's command line (CLI11): --help, one uniform error for a bad option or value; and
# lcd_evaluate --gt-mat on a MATLAB v7.3 (HDF5) file written through libmatio.
add_executable(write_mat73_fixture test/tools/write_mat73_fixture.cpp)
target_link_libraries(write_mat73_fixture ${OpenCV_LIBS} PkgConfig::MATIO)
add_test(NAME tool_command_lines
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/command_lines.sh $<TARGET_FILE_DIR:lcd_config>
    $<TARGET_FILE:write_mat73_fixture>)

# lcd_evaluate refuses another camera's --camera-info before evaluating (Gardens Point, when here).
add_test(NAME tool_evaluate_camera_info
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/evaluate_camera_info.sh ${CMAKE_CURRENT_SOURCE_DIR}
    $<TARGET_FILE:lcd_evaluate>)

# The converted pretrained backbone reproduces the original network (TensorFlow.js from npm).
add_executable(backbone_reference_check test/tools/backbone_reference_check.cpp)
target_link_libraries(backbone_reference_check ${OpenCV_LIBS})
add_test(NAME tool_backbone_reference
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/backbone_reference.sh ${CMAKE_CURRENT_SOURCE_DIR}
    ${CMAKE_CURRENT_BINARY_DIR}/backbone_reference $<TARGET_FILE:backbone_reference_check>)

# Each folder of the ROS-free library includes only the folders below it (README "Layout").
add_test(NAME include_layers
  COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${CMAKE_CURRENT_SOURCE_DIR}
    -P ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/check_include_layers.cmake)

# Every dependency package.xml names has its Debian packages, which scripts/install_deps.sh installs.
add_test(NAME package_dependencies
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/scripts/debian_packages.sh --check)

# No class with behaviour past 25 data members, LoopDetector past 12 (issue 82; docs/design.md).
add_test(NAME class_sizes COMMAND python3 ${CMAKE_CURRENT_SOURCE_DIR}/scripts/class_sizes.py)

# The catkin workspace's install space (scripts/build.sh) with the source tree out of reach: the
# downstream package builds against its exports, the tools run, the demo's loops from its node.
add_test(NAME tool_workspace_install
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/workspace_install.sh ${CMAKE_CURRENT_SOURCE_DIR})
set_tests_properties(tool_workspace_install PROPERTIES TIMEOUT 600)

# The README's demo command (scripts/demo.sh) runs as written: one line per loop, summary last.
add_test(NAME tool_demo_script
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/demo_script.sh ${CMAKE_CURRENT_SOURCE_DIR})
set_tests_properties(tool_demo_script PROPERTIES TIMEOUT 900)
# The two-robot demo (scripts/demo.sh --two-robots): loops between robots, none false.
add_test(NAME tool_demo_two_robots
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/demo_script.sh ${CMAKE_CURRENT_SOURCE_DIR}
    --two-robots)
set_tests_properties(tool_demo_two_robots PROPERTIES TIMEOUT 900)

# Mapping nodes killed at random moments, maps saved over and loaded: every published keyframe is
# in one map file (scripts/kill_soak.sh; 3 kills here, 20 by hand).
add_test(NAME tool_kill_soak
  COMMAND ${CMAKE_COMMAND} -E env ROS_MASTER_URI=http://localhost:11471 PATH=/usr/bin:$ENV{PATH}
    ${CMAKE_CURRENT_SOURCE_DIR}/scripts/kill_soak.sh --kills 3 --seed 1 --no-setup)
set_tests_properties(tool_kill_soak PROPERTIES TIMEOUT 600)

# The demo in the real rviz under Xvfb: no display in error from start to end, loops green, an
# accepted loop in the match view. Its last screenshot is the README's picture (docs/rviz_demo.png).
find_package(X11)
if(X11_FOUND)
  add_executable(rviz_screenshot test/tools/rviz_screenshot.cpp)
  target_include_directories(rviz_screenshot SYSTEM PRIVATE ${X11_INCLUDE_DIR})
  target_link_libraries(rviz_screenshot ${X11_LIBRARIES} ${OpenCV_LIBS})
  add_test(NAME tool_rviz_screenshot
    COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/rviz_screenshot.sh ${CMAKE_CURRENT_SOURCE_DIR}
      $<TARGET_FILE:rviz_screenshot> ${CMAKE_CURRENT_BINARY_DIR}/rviz_demo.png)
  set_tests_properties(tool_rviz_screenshot PROPERTIES TIMEOUT 600)
else()
  message(FATAL_ERROR "libx11-dev is missing: scripts/install_deps.sh installs it")
endif()

# The README's tool commands run as written (evaluations as dry runs; README "Evaluate").
add_test(NAME tool_readme_commands
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/tools/readme_commands.sh ${CMAKE_CURRENT_SOURCE_DIR})

include(cmake/test_tiers.cmake)
