# autonomsim_test(NAME SOURCES src... LIBS lib...)
# One GoogleTest executable; its tests are registered with ctest one by one. Tests run with the
# repository root as working directory so that they can name scenario files as users do.
function(autonomsim_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} autonomsim_flags GTest::gtest_main GTest::gmock)
  gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                       PROPERTIES ENVIRONMENT "AUTONOMSIM_BIN_DIR=${CMAKE_BINARY_DIR}/bin"
                       DISCOVERY_TIMEOUT 60)
endfunction()
