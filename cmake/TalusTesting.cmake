# talus_add_test(NAME SOURCES... [LIBS ...]): one GoogleTest executable registered with CTest.
include(GoogleTest)
function(talus_add_test name)
  cmake_parse_arguments(arg "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${arg_SOURCES})
  talus_configure_target(${name})
  target_link_libraries(${name} PRIVATE ${arg_LIBS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    TALUS_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    TALUS_BINARY_DIR="${PROJECT_BINARY_DIR}")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
    PROPERTIES ENVIRONMENT "TALUS_BIN=${PROJECT_BINARY_DIR}/bin")
endfunction()
