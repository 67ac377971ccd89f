# Fails when a test of a shared unit-test executable is in no ctest entry: each entry runs the
# executable on the suites mm_add_test read from its sources (cmake/MonomeshHelpers.cmake), so a
# TEST it could not read (e.g. a macro split across lines) would never run.
# cmake -DBINARY=EXE -DFILTER=F [-DEMULATOR="CMD ARGS"] -P check_test_filters.cmake
separate_arguments(emulator UNIX_COMMAND "${EMULATOR}")
function(list_tests out)
  execute_process(COMMAND ${emulator} ${BINARY} --gtest_list_tests ${ARGN}
    OUTPUT_VARIABLE listing RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${BINARY} --gtest_list_tests ${ARGN}: exit ${rc}")
  endif()
  # "Suite." lines, then "  Name" lines: the full names.
  string(REPLACE "\n" ";" lines "${listing}")
  set(names "")
  foreach(line IN LISTS lines)
    if(line MATCHES "^([^ ].*\\.)")
      set(suite "${CMAKE_MATCH_1}")
    elseif(line MATCHES "^  ([^ #]+)")
      list(APPEND names "${suite}${CMAKE_MATCH_1}")
    endif()
  endforeach()
  set(${out} "${names}" PARENT_SCOPE)
endfunction()
list_tests(all)
list_tests(covered "--gtest_filter=${FILTER}")
list(REMOVE_ITEM all ${covered})
list(LENGTH covered n)
if(all)
  list(JOIN all ", " missing)
  message(FATAL_ERROR "${BINARY}: in no ctest entry (mm_add_test found no TEST line for them): "
    "${missing}")
endif()
message(STATUS "${BINARY}: all ${n} tests are in a ctest entry")
