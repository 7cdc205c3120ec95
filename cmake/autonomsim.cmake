# autonomsim_test(NAME SOURCES src... LIBS lib... [PROPERTIES prop value...])
# One GoogleTest executable; its tests are registered with ctest one by one, with PROPERTIES if
# given. Tests run with the repository root as working directory so that they can name scenario
# files as users do.
function(autonomsim_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;PROPERTIES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} autonomsim_flags GTest::gtest_main GTest::gmock)
  if(AUTONOMSIM_SANITIZE)
    # The tests' own code unoptimised under the sanitizers (still instrumented): it is half that
    # build's compile time (a unity batch of stack_tests: 58 s at -O1, 32 s at -O0), and the work
    # a test drives runs in the libraries, which keep -O1 (CI: build 576 -> 487 s, tests 184 ->
    # 188 s). Not in the release build: there it saved 25 s of building and cost 24 s of tests.
    target_compile_options(${name} PRIVATE -O0)
  endif()
  gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                       PROPERTIES ENVIRONMENT "AUTONOMSIM_BIN_DIR=${CMAKE_BINARY_DIR}/bin"
                       ${ARG_PROPERTIES} DISCOVERY_TIMEOUT 60)
endfunction()

# autonomsim_fuzzer(NAME SOURCES src... LIBS lib...)
# One libFuzzer executable (AUTONOMSIM_FUZZ builds only): a member of the fuzz_targets target,
# never of ctest (tools/fuzz.sh runs it). It knows the source tree, for the shipped files it reads.
function(autonomsim_fuzzer name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} autonomsim_flags)
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  target_compile_definitions(${name} PRIVATE AUTONOMSIM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  add_dependencies(fuzz_targets ${name})
endfunction()
