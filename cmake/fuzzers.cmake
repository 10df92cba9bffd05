# libFuzzer targets (clang; scripts/fuzz.sh configures a separate build with the sanitizer flags).
foreach(target fuzz_old_map_file fuzz_image_message fuzz_pose_graph fuzz_pose_graph_session
               fuzz_loop_detector)
  add_executable(${target} fuzz/${target}.cpp)
  target_link_options(${target} PRIVATE -fsanitize=fuzzer)
endforeach()
target_link_libraries(fuzz_old_map_file ${PROJECT_NAME}_core)
target_include_directories(fuzz_old_map_file PRIVATE src)
target_include_directories(fuzz_image_message SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(fuzz_image_message ${PROJECT_NAME}_messages ${catkin_LIBRARIES})
add_dependencies(fuzz_image_message ${PROJECT_NAME}_generate_messages_cpp)
target_link_libraries(fuzz_pose_graph ${PROJECT_NAME}_backend)
target_link_libraries(fuzz_pose_graph_session ${PROJECT_NAME}_backend)
target_link_libraries(fuzz_loop_detector ${PROJECT_NAME}_core)
