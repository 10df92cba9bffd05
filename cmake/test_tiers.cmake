# Test tiers: every ctest entry carries one label (ctest -L TIER; README "Tests").
#   unit  gtests of the libraries and of the message conversions; no ROS master; seconds each
#   node  rostests: a running nodelet on its own ROS master (rostest takes a free port, so two
#         run at once)
#   tool  the programs and scripts end to end: install, demo, rviz, README commands, launch checks
#   data  checks on the real datasets in ../shared/data: "Not Run" (skipped) without them
#   slow  ThreadSanitizer: the threaded core tests rebuilt and run (scripts/tsan.sh); Clang's
#         thread-safety analysis of the libraries and nodes (scripts/thread_safety.sh)
# scripts/test.sh runs all of them (slow last); scripts/test.sh --quick the unit tier on an
# existing build.
# A new entry without a tier stops the configure.

# Another ctest entry for the cases of gtest `target` that match `filter` (gtest's --gtest_filter),
# named TARGET_SUFFIX, in tier `label`.
function(llc_gtest_entry target suffix filter label)
  get_target_property(folder ${target} RUNTIME_OUTPUT_DIRECTORY)
  set(name ${target}_${suffix})
  catkin_run_tests_target("gtest" ${name} "gtest-${name}.xml"
    COMMAND "${folder}/${target} --gtest_filter=${filter} --gtest_output=xml:${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/gtest-${name}.xml"
    DEPENDENCIES ${target})
  set_tests_properties(_ctest_${PROJECT_NAME}_gtest_${name} PROPERTIES LABELS ${label})
endfunction()

# The cases of a gtest that read ../shared/data (`data_filter`, positive patterns only), as an
# entry of their own in the data tier ("Not Run" when they skip); the entry catkin_add_gtest made
# runs every other case, so a case added later runs in the unit tier at least.
function(llc_data_cases target data_filter)
  set_property(TEST _ctest_${PROJECT_NAME}_gtest_${target} APPEND PROPERTY
    ENVIRONMENT "GTEST_FILTER=-${data_filter}")
  llc_gtest_entry(${target} shared_data "${data_filter}" data)
  set_tests_properties(_ctest_${PROJECT_NAME}_gtest_${target}_shared_data PROPERTIES
    SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")
endfunction()

# A long gtest split into entries that run side by side: one per named case (gtest filters), and
# the entry catkin_add_gtest made runs every other case, so a case added later still runs.
function(llc_split_gtest target)
  set(index 1)
  set(others "")
  foreach(filter ${ARGN})
    llc_gtest_entry(${target} part${index} "${filter}" unit)
    set(others "${others}:${filter}")
    math(EXPR index "${index} + 1")
  endforeach()
  string(SUBSTRING "${others}" 1 -1 others)
  set_property(TEST _ctest_${PROJECT_NAME}_gtest_${target} APPEND PROPERTY
    ENVIRONMENT "GTEST_FILTER=-${others}")
endfunction()

llc_data_cases(test_ground_truth "Shared*")
llc_data_cases(test_baselines_regression
  "BaselineRegression.Nordland*:BaselineRegression.GardensPoint*")
# Each of these cases drives two laps of the corridor (35-50 s; the rest together about 30 s).
llc_split_gtest(test_loop_detector_sim
  LoopDetectorOnCorridor.RevisitGivesOnlyTrueLoops
  LoopDetectorOnCorridor.SequenceMatchingGivesOnlyTrueLoopsAndNoneOnAOneWayRoute
  LoopDetectorOnCorridor.AfterTheOdometryIsReinitialisedLoopsJoinTheEarlierSession
  LoopDetectorOnCorridor.LearnedDescriptorsAtTheirThresholdsGiveOnlyTrueLoops)

# Scripts that need ../shared/data exit 77 without it.
set(llc_data_scripts tool_bench_pose_graph_kitti tool_evaluate_camera_info)
set_tests_properties(${llc_data_scripts} PROPERTIES LABELS data SKIP_RETURN_CODE 77)
# Scripts that exit 77 when something the install fetches (the backbone) is missing.
set_tests_properties(tool_train_learned_descriptors PROPERTIES SKIP_RETURN_CODE 77)

# ThreadSanitizer's build and run. scripts/test.sh runs it after the other tiers: its build takes
# both cores.
add_test(NAME tsan_threaded_tests COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/scripts/tsan.sh)
set_tests_properties(tsan_threaded_tests PROPERTIES LABELS slow TIMEOUT 1800)
# Clang's thread-safety analysis: the libraries and nodes built with it (slow: a build of its own,
# started early by scripts/test.sh like ThreadSanitizer's), and the check that it refuses code that
# breaks an annotation (unit: one small file).
add_test(NAME thread_safety_build COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/scripts/thread_safety.sh)
set_tests_properties(thread_safety_build PROPERTIES LABELS slow TIMEOUT 1800)
add_test(NAME thread_safety_refuses_violations
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/test/thread_safety/refuses_violations.sh
          ${CMAKE_CURRENT_SOURCE_DIR}/include)
set_tests_properties(thread_safety_refuses_violations PROPERTIES LABELS unit)

get_property(llc_tests DIRECTORY PROPERTY TESTS)
foreach(test ${llc_tests})
  get_test_property(${test} LABELS labels)
  if(labels)
    continue()
  endif()
  if(test MATCHES "^_ctest_${PROJECT_NAME}_gtest_")
    set(tier unit)
  elseif(test MATCHES "^_ctest_${PROJECT_NAME}_rostest_")
    set(tier node)
  elseif(test STREQUAL "include_layers" OR test STREQUAL "class_sizes" OR
         test STREQUAL "package_dependencies")
    set(tier unit)
  elseif(test MATCHES "^(tool_|_ctest_${PROJECT_NAME}_roslaunch-check_)")
    set(tier tool)
  else()
    message(FATAL_ERROR "ctest entry ${test} has no tier: give it a label in cmake/test_tiers.cmake")
  endif()
  set_tests_properties(${test} PROPERTIES LABELS ${tier})
endforeach()

# `unit_tests` builds the programs of the unit tier (scripts/test.sh --quick).
add_custom_target(unit_tests)
foreach(test ${llc_tests})
  get_test_property(${test} LABELS labels)
  if(labels STREQUAL "unit" AND test MATCHES "^_ctest_${PROJECT_NAME}_gtest_(.+)$")
    string(REGEX REPLACE "_(part[0-9]+|shared_data)$" "" program "${CMAKE_MATCH_1}")
    add_dependencies(unit_tests ${program})
  endif()
endforeach()

# The demo, rviz, the README's commands and the kill soak share _demo/ (its bag, made by whichever
# comes first) and (but the soak) the demo's ROS master port: one at a time. The demo and rviz play a bag in real time and
# check every loop: each has both cores (ctest -j2), as a user's laptop gives them; beside another
# test the detector drops keyframes (measured: 385 of 473) and a loop lands 3.6 m off.
set_tests_properties(tool_demo_script tool_demo_two_robots tool_rviz_screenshot
  tool_readme_commands tool_kill_soak tool_workspace_install PROPERTIES RESOURCE_LOCK demo_folder)
set_tests_properties(tool_demo_script tool_demo_two_robots tool_rviz_screenshot
  tool_workspace_install PROPERTIES PROCESSORS 2)

# Without the timings of an earlier run (a clean clone), ctest starts entries by COST: the longest
# first (seconds measured on 2 cores), so that short ones fill the cores at the end.
set_tests_properties(
  _ctest_${PROJECT_NAME}_rostest_test_ros_node_matches_evaluate.test PROPERTIES COST 220)
set_tests_properties(tool_train_learned_descriptors PROPERTIES COST 175)
set_tests_properties(_ctest_${PROJECT_NAME}_rostest_test_ros_node_restart.test PROPERTIES COST 95)
foreach(part part1 part2 part3 part4)
  set_tests_properties(_ctest_${PROJECT_NAME}_gtest_test_loop_detector_sim_${part} PROPERTIES
    COST 60)
endforeach()
set_tests_properties(_ctest_${PROJECT_NAME}_gtest_test_baselines_regression_shared_data
  PROPERTIES COST 50)

# OpenMP's threads (oneDNN's, OpenCV's) spin after each parallel region by default: beside another
# entry that spinning takes the other core (measured, the corridor's revisit case alone: 21.9 s of
# CPU for 15.2 s, 16.4 s with passive waiting, the same wall time).
set_property(TEST ${llc_tests} APPEND PROPERTY ENVIRONMENT OMP_WAIT_POLICY=PASSIVE)
set_tests_properties(_ctest_${PROJECT_NAME}_rostest_test_ros_node_two_robots.test PROPERTIES
  COST 45)
set_tests_properties(_ctest_${PROJECT_NAME}_rostest_test_ros_node_rogue_peer.test PROPERTIES
  COST 125)
set_tests_properties(_ctest_${PROJECT_NAME}_gtest_test_fleet_corridor PROPERTIES COST 30)
