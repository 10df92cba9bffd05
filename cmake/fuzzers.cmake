# libFuzzer targets (clang; scripts/fuzz.sh configures a separate build with the sanitizer flags).
foreach(target fuzz_database_file fuzz_image_message)
  add_executable(${target} fuzz/${target}.cpp)
  target_link_options(${target} PRIVATE -fsanitize=fuzzer)
endforeach()
target_link_libraries(fuzz_database_file ${PROJECT_NAME}_core)
target_include_directories(fuzz_image_message SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(fuzz_image_message ${PROJECT_NAME}_messages ${catkin_LIBRARIES})
add_dependencies(fuzz_image_message ${PROJECT_NAME}_generate_messages_cpp)
