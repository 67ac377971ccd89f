# Helpers shared by every folder: warnings on our own targets, library and test registration,
# and the layer rule.

set(MM_WARNINGS -Wall -Wextra -Wshadow -Wmissing-declarations -Wnon-virtual-dtor -Wpedantic)
if(MM_WERROR)
  list(APPEND MM_WARNINGS -Werror)
endif()
# gcc 12 prints ABI notes for CGAL/Eigen on some targets; they are not about our code.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  list(APPEND MM_WARNINGS -Wno-psabi)
  # gcc 12 at -O3 (the Release presets) warns -Wrestrict inside libstdc++'s std::string
  # operator+ (a false positive, GCC PR 105329), e.g. in firmware-app/app/config.cc; -Werror
  # then breaks the build (Debian 12 has gcc 12.2).
  if(CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    list(APPEND MM_WARNINGS -Wno-restrict)
  endif()
endif()

# Aggregate targets, so a build can ask for exactly what it needs (the cross stage of .ci/run
# builds `mm_libraries monomeshd monomesh mm_unit_tests`, not the integration tests or benchmarks):
#   mm_libraries   every library made by mm_add_library
#   mm_unit_tests  every test executable made by mm_add_test with the label "unit" (the default):
#                  a "<folder>_unit_tests" per folder and the slow unit tests' own
#   mm_fuzzers     every libFuzzer target made by mm_add_fuzzer (the asan preset)
if(NOT TARGET mm_libraries)
  add_custom_target(mm_libraries)
  add_custom_target(mm_unit_tests)
  add_custom_target(mm_fuzzers)
endif()

# Precompiled headers (MM_PCH): every target made by the functions below reads the standard
# library, Eigen, OpenCV's core/imgproc/imgcodecs and nlohmann::json from one of three shared
# .gch files (cmake/mm_pch.h; the tests' cmake/mm_pch_test.h adds GoogleTest) instead of
# parsing them in each unit. Three, because gcc only accepts a .gch built with the same -fPIC /
# PIE setting: libraries (PIC), programs and tests. On by default with the host's gcc; off
# with clang (the asan, tsan and fuzz presets), whose .pch is refused outright on any flag or
# macro difference instead of falling back to the header, and off for cross builds (-DMM_PCH=ON
# turns it on; tried with the aarch64 gcc 12 at -O3: its -Wstringop-overflow false positive
# inside std::string surfaces in capture's batch, and unity builds alone stop at web's batch on
# Eigen's product kernels declared twice). Units built with their own
# code-generation flags (Highway's foreach_target kernels, -ffp-contract=off) keep parsing
# their headers themselves, as do the two units where gcc 12 reports its false positives inside
# libstdc++'s std::string (-Warray-bounds, -Wstringop-overflow) only when <string> comes from
# the .gch (SKIP_PRECOMPILE_HEADERS beside them).
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND NOT CMAKE_CROSSCOMPILING)
  set(_mm_pch_default ON)
else()
  set(_mm_pch_default OFF)
endif()
option(MM_PCH "Precompiled headers for monomesh's targets (gcc)" ${_mm_pch_default})

# _mm_highway_sources_set(SOURCES PROPERTY...): each PROPERTY ON for those of SOURCES that are
# Highway foreach_target kernels (they re-include themselves once per SIMD target with their own
# flags).
function(_mm_highway_sources_set sources)
  foreach(src IN LISTS sources)
    get_filename_component(path ${src} ABSOLUTE)
    if(path MATCHES "\\.cc$" AND EXISTS ${path})
      file(STRINGS ${path} hwy REGEX "foreach_target" LIMIT_COUNT 1)
      if(hwy)
        foreach(property IN LISTS ARGN)
          set_source_files_properties(${src} PROPERTIES ${property} ON)
        endforeach()
      endif()
    endif()
  endforeach()
endfunction()

# _mm_highway_units_set(TARGET PROPERTY): the same for a target's sources.
function(_mm_highway_units_set target property)
  get_target_property(sources ${target} SOURCES)
  _mm_highway_sources_set("${sources}" ${property})
endfunction()

# _mm_pch(TARGET KIND): KIND is lib, exe or test.
function(_mm_pch target kind)
  if(NOT MM_PCH)
    return()
  endif()
  set(donor mm_pch_${kind})
  if(NOT TARGET ${donor})
    add_library(${donor} STATIC ${PROJECT_SOURCE_DIR}/cmake/mm_pch.cc)
    # The consumers' flags: -Wpedantic, for one, changes the predefined macros (a .gch built
    # without it is refused: __cpp_runtime_arrays).
    target_compile_options(${donor} PRIVATE ${MM_WARNINGS})
    target_link_libraries(${donor} PRIVATE Eigen3::Eigen opencv_core opencv_imgproc
      opencv_imgcodecs nlohmann_json::nlohmann_json)
    if(kind STREQUAL "lib")
      set_target_properties(${donor} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    endif()
    if(kind STREQUAL "test")
      target_link_libraries(${donor} PRIVATE GTest::gtest)
      target_precompile_headers(${donor} PRIVATE ${PROJECT_SOURCE_DIR}/cmake/mm_pch_test.h)
    else()
      target_precompile_headers(${donor} PRIVATE ${PROJECT_SOURCE_DIR}/cmake/mm_pch.h)
    endif()
  endif()
  target_precompile_headers(${target} REUSE_FROM ${donor})
  _mm_highway_units_set(${target} SKIP_PRECOMPILE_HEADERS)
endfunction()

# Unity builds (MM_UNITY): a library's or program's units are compiled in batches of 8, one
# translation unit each, so that the templates they share (Eigen, OpenCV, json, spdlog, CLI11)
# are instantiated and optimised once per batch instead of once per unit. Same default as
# MM_PCH (gcc, not cross); the clang presets compile unit by unit, so both ways stay built by CI.
# Highway's foreach_target kernels re-include themselves per target and stay out of the batches;
# a target of one unit is left as it is. Measured: docs/build_times.md.
option(MM_UNITY "Unity builds for monomesh's libraries and programs" ${_mm_pch_default})

function(_mm_unity target)
  if(NOT MM_UNITY)
    return()
  endif()
  get_target_property(sources ${target} SOURCES)
  list(FILTER sources INCLUDE REGEX "\\.cc$")
  list(LENGTH sources units)
  if(units LESS 2)  # One unit gains nothing (and gcc then sees its anonymous types as a header's).
    return()
  endif()
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
  _mm_highway_units_set(${target} SKIP_UNITY_BUILD_INCLUSION)
endfunction()

# mm_add_library(NAME SOURCES ... [PUBLIC_LINK ...] [PRIVATE_LINK ...])
# Headers are included as "<folder>/<file>.h" from the repository root.
function(mm_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_LINK;PRIVATE_LINK" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_compile_options(${name} PRIVATE ${MM_WARNINGS})
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_LINK} PRIVATE ${ARG_PRIVATE_LINK})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  add_dependencies(mm_libraries ${name})
  _mm_pch(${name} lib)
  _mm_unity(${name})
endfunction()

# mm_add_executable(NAME SOURCES ... [LINK ...])
function(mm_add_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINK" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_compile_options(${name} PRIVATE ${MM_WARNINGS})
  target_link_libraries(${name} PRIVATE ${ARG_LINK})
  _mm_pch(${name} exe)
  _mm_unity(${name})
endfunction()

# mm_add_test(FOLDER NAME SOURCES ... [LINK ...] [LABELS ...] [TIMEOUT S] [SLOW] [LOCK ...]
#             [GTEST_FILTER F] [SHARED GROUP] [COST S])
# Registers GoogleTest sources as the ctest test "<folder>/<name>" and sets MM_TEST_TARGET (in
# the caller's scope) to the executable that holds them. A test that needs data it may not find
# exits 77 and is reported as skipped.
# Speed labels (scripts/test.sh --fast runs label "fast"): a unit test is "fast" unless marked
# SLOW; every other test is "slow". LOCK names RESOURCE_LOCKs (mm_test_locks below).
# The fast unit tests of a folder share one executable, "<folder>_unit_tests" (unity-built in
# batches like the libraries: a folder's tests instantiate the same templates, and one link
# replaces one per test); each keeps its own ctest entry, which runs that executable on the
# test's suites (--gtest_filter). A suite name may appear in one of them only (checked here).
# Slow and integration tests keep an executable each ("<folder>_<name>") unless given
# SHARED <group>: then they share "<folder>_<group>" the same way (e.g. the integration tests
# other than daemon_test, which the sanitizer stages build alone). GTEST_FILTER (a negative
# filter, "-Suite.Name") splits a test across ctest entries.
function(mm_add_test folder name)
  cmake_parse_arguments(ARG "SLOW" "TIMEOUT;GTEST_FILTER;SHARED;COST" "SOURCES;LINK;LABELS;LOCK" ${ARGN})
  set(labels unit)
  if(ARG_LABELS)
    set(labels ${ARG_LABELS})
  endif()
  # COST: ctest starts the costliest tests first (scripts/test.sh removes ctest's measured
  # times, Testing/Temporary/CTestCostData.txt, which would replace it). A slow test's COST is
  # its time in seconds on a 2-core machine in a suite run (60 when not given); a test holding
  # the lock "timing" gets 500 more (mm_test_locks).
  set(cost 60)
  if(ARG_COST)
    set(cost ${ARG_COST})
  endif()
  if("unit" IN_LIST labels AND NOT ARG_SLOW)
    list(APPEND labels fast)
    set(cost 1)
    set(ARG_SHARED unit_tests)
  else()
    list(APPEND labels slow)
  endif()
  if(ARG_SHARED)
    set(target ${folder}_${ARG_SHARED})
    set(filter "")
    foreach(src IN LISTS ARG_SOURCES)
      get_filename_component(path ${src} ABSOLUTE)
      file(STRINGS ${path} lines REGEX "^(TEST|TEST_F|TEST_P)\\([A-Za-z0-9_]+,")
      foreach(line IN LISTS lines)
        string(REGEX REPLACE "^[A-Z_]+\\(([A-Za-z0-9_]+),.*" "\\1" suite "${line}")
        get_property(owner GLOBAL PROPERTY MM_TEST_SUITE_${folder}_${suite})
        if(owner AND NOT owner STREQUAL name)
          message(FATAL_ERROR "test suite ${suite} is in ${folder}/${owner} and ${folder}/${name} "
            "(they share ${target}: give one of them another suite name)")
        endif()
        set_property(GLOBAL PROPERTY MM_TEST_SUITE_${folder}_${suite} ${name})
        list(APPEND filter "${suite}.*" "*/${suite}.*")  # TEST_P: Prefix/Suite.Name/N
      endforeach()
    endforeach()
    list(REMOVE_DUPLICATES filter)
    if(NOT filter)
      message(FATAL_ERROR "${folder}/${name}: no TEST, TEST_F or TEST_P found in ${ARG_SOURCES}")
    endif()
    list(JOIN filter ":" filter)
    if(NOT TARGET ${target})
      add_executable(${target})
      target_compile_options(${target} PRIVATE ${MM_WARNINGS})
      target_link_libraries(${target} PRIVATE GTest::gtest GTest::gtest_main)
      target_compile_definitions(${target} PRIVATE
        MM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
        MM_BINARY_DIR="${PROJECT_BINARY_DIR}")
      _mm_pch(${target} test)
      if(MM_UNITY)
        set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
      endif()
    endif()
    if("unit" IN_LIST labels)
      add_dependencies(mm_unit_tests ${target})
    endif()
    set_property(GLOBAL APPEND PROPERTY MM_SHARED_TEST_TARGETS ${target})
    set_property(GLOBAL APPEND PROPERTY MM_SHARED_TEST_FILTER_${target} ${filter})
    target_sources(${target} PRIVATE ${ARG_SOURCES})
    target_link_libraries(${target} PRIVATE ${ARG_LINK})
    _mm_highway_sources_set("${ARG_SOURCES}" SKIP_UNITY_BUILD_INCLUSION SKIP_PRECOMPILE_HEADERS)
    add_test(NAME ${folder}/${name} COMMAND ${target} --gtest_filter=${filter}${ARG_GTEST_FILTER})
  else()
    set(target ${folder}_${name})
    add_executable(${target} ${ARG_SOURCES})
    target_compile_options(${target} PRIVATE ${MM_WARNINGS})
    target_link_libraries(${target} PRIVATE ${ARG_LINK} GTest::gtest GTest::gtest_main)
    target_compile_definitions(${target} PRIVATE
      MM_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
      MM_BINARY_DIR="${PROJECT_BINARY_DIR}")
    _mm_pch(${target} test)
    if(ARG_GTEST_FILTER)
      add_test(NAME ${folder}/${name} COMMAND ${target} --gtest_filter=${ARG_GTEST_FILTER})
    else()
      add_test(NAME ${folder}/${name} COMMAND ${target})
    endif()
    if("unit" IN_LIST labels)
      add_dependencies(mm_unit_tests ${target})
    endif()
  endif()
  set(MM_TEST_TARGET ${target} PARENT_SCOPE)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # Cross builds run each test under an emulator (qemu-aarch64: scalar code ~14x slower than
  # native, SIMD loops ~70-120x): the same test gets 4x the time there.
  if(CMAKE_CROSSCOMPILING AND CMAKE_CROSSCOMPILING_EMULATOR)
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  endif()
  set_tests_properties(${folder}/${name} PROPERTIES
    SKIP_RETURN_CODE 77 TIMEOUT ${ARG_TIMEOUT} LABELS "${labels}" COST ${cost})
  if(ARG_LOCK)
    mm_test_locks(${folder}/${name} ${ARG_LOCK})
  endif()
  if(CMAKE_CROSSCOMPILING AND CMAKE_CROSSCOMPILING_EMULATOR)
    # A test under qemu-user cannot exec an aarch64 program by itself (no binfmt_misc on the
    # build machines): LibcameraSource starts its worker through the emulator too, and tests
    # of what starts arbitrary programs (the hooks) skip where MM_TEST_EMULATOR is set.
    list(JOIN CMAKE_CROSSCOMPILING_EMULATOR " " launcher)
    set_tests_properties(${folder}/${name} PROPERTIES ENVIRONMENT
      "MM_LIBCAMERA_WORKER_LAUNCHER=${launcher};MM_TEST_EMULATOR=${launcher}")
  endif()
endfunction()

# mm_check_shared_test_filters(): a test "repo/test_filters/<target>" per shared test
# executable, failing when one of its tests is in none of its ctest entries
# (tests/check_test_filters.cmake). Called once every folder has added its tests.
function(mm_check_shared_test_filters)
  get_property(targets GLOBAL PROPERTY MM_SHARED_TEST_TARGETS)
  list(REMOVE_DUPLICATES targets)
  list(JOIN CMAKE_CROSSCOMPILING_EMULATOR " " emulator)
  foreach(target IN LISTS targets)
    get_property(filters GLOBAL PROPERTY MM_SHARED_TEST_FILTER_${target})
    list(JOIN filters ":" filter)
    add_test(NAME repo/test_filters/${target}
      COMMAND ${CMAKE_COMMAND} -DBINARY=$<TARGET_FILE:${target}> -DFILTER=${filter}
        "-DEMULATOR=${emulator}" -P ${PROJECT_SOURCE_DIR}/tests/check_test_filters.cmake)
    # Labelled like the executable's tests: `scripts/test.sh --fast` builds the unit tests only.
    if(target MATCHES "_unit_tests$")
      set(labels "unit;fast")
    else()
      set(labels "slow")
    endif()
    set_tests_properties(repo/test_filters/${target} PROPERTIES LABELS "${labels}" TIMEOUT 120)
  endforeach()
endfunction()

# mm_test_locks(TEST LOCK ...): ctest runs tests in parallel (scripts/test.sh: -j over every
# core) except two that hold the same lock:
#   daemon  a monomeshd end to end on a real-time camera, several threads each: two at once
#           starve each other's gate and worker and time out on a 2-core machine
#   timing  the test measures wall-clock intervals or waits on timers of its own
#   quiet   the test may not share the machine with the long walk's daemon
#           (integration/daemon_walk_long_test, which holds only this lock: it has no deadline,
#           so it may run beside the stress test, which holds daemon and timing, or beside any
#           test without a lock). Every test given "timing" holds "quiet" as well.
function(mm_test_locks test)
  get_test_property(${test} RESOURCE_LOCK locks)
  if(NOT locks)
    set(locks "")
  endif()
  list(APPEND locks ${ARGN})
  if("timing" IN_LIST locks)
    list(APPEND locks quiet)
  endif()
  list(REMOVE_DUPLICATES locks)
  set_tests_properties(${test} PROPERTIES RESOURCE_LOCK "${locks}")
  # The tests that hold "timing" run one at a time: ctest starts them before the tests that
  # share the machine freely, which then fill the other core beside them (COST is the order
  # ctest starts tests in; scripts/test.sh drops the measured times so every run keeps it).
  if("timing" IN_LIST locks)
    get_test_property(${test} COST cost)
    if(NOT cost)  # Not set ("NOTFOUND").
      set(cost 0)
    endif()
    if(cost LESS 500)
      math(EXPR cost "${cost} + 500")
      set_tests_properties(${test} PROPERTIES COST ${cost})
    endif()
  endif()
endfunction()

# Collects every target that `target` links, transitively.
function(_mm_collect_links target out)
  set(seen ${${out}})
  get_target_property(links ${target} LINK_LIBRARIES)
  get_target_property(ilinks ${target} INTERFACE_LINK_LIBRARIES)
  foreach(l IN LISTS links ilinks)
    string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" l "${l}")
    if(TARGET ${l} AND NOT l IN_LIST seen)
      list(APPEND seen ${l})
      _mm_collect_links(${l} seen)
    endif()
  endforeach()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

# mm_forbid_link(A B): configure fails if target A links target B, directly or not.
function(mm_forbid_link a b)
  set(all "")
  _mm_collect_links(${a} all)
  if(${b} IN_LIST all)
    message(FATAL_ERROR "Layer rule broken: ${a} links ${b} (see docs/architecture.md)")
  endif()
endfunction()

# mm_forbid_links(A B C ...): mm_forbid_link(A B), mm_forbid_link(A C), ...
function(mm_forbid_links a)
  foreach(b IN LISTS ARGN)
    mm_forbid_link(${a} ${b})
  endforeach()
endfunction()

# mm_add_fuzzer(NAME SOURCES ... [LINK ...] CORPUS DIR)
# A libFuzzer target, made only in the asan preset (clang; MM_FUZZ instruments every target it
# builds with ASan + UBSan and the fuzzer's coverage). DIR holds its seed inputs, in the
# repository. Each target is listed as "name binary corpus" in <build>/fuzz_targets.txt, which
# scripts/fuzz.sh (the fuzz stage of .ci/run) runs for a bounded time.
function(mm_add_fuzzer name)
  if(NOT MM_FUZZ)
    return()
  endif()
  cmake_parse_arguments(ARG "" "CORPUS" "SOURCES;LINK" ${ARGN})
  if(NOT IS_DIRECTORY ${ARG_CORPUS})
    message(FATAL_ERROR "mm_add_fuzzer(${name}): no seed corpus at ${ARG_CORPUS}")
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_compile_options(${name} PRIVATE ${MM_WARNINGS})
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  target_link_libraries(${name} PRIVATE ${ARG_LINK})
  add_dependencies(mm_fuzzers ${name})
  file(APPEND ${PROJECT_BINARY_DIR}/fuzz_targets.txt
       "${name} ${CMAKE_CURRENT_BINARY_DIR}/${name} ${ARG_CORPUS}\n")
endfunction()
