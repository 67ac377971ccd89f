# Fails when a pure layer includes a header of a layer above it (docs/architecture.md).
set(rules
  "dataset:capture/|app/|recon/|calib/|spool/"
  "calib:capture/|app/|recon/|spool/"
  "recon:capture/|app/|spool/|session/"
  "spool:capture/|app/|recon/|calib/"
  "synth:capture/|app/|spool/"
  "capture:recon/|app/|spool/|session/"
  "session:capture/|app/|spool/|render/")
set(failures "")
foreach(rule IN LISTS rules)
  string(REPLACE ":" ";" parts "${rule}")
  list(GET parts 0 folder)
  list(GET parts 1 forbidden)
  file(GLOB_RECURSE files "${SOURCE_DIR}/${folder}/*.h" "${SOURCE_DIR}/${folder}/*.cc")
  foreach(f IN LISTS files)
    file(STRINGS "${f}" lines REGEX "^#include \"(${forbidden})")
    foreach(l IN LISTS lines)
      list(APPEND failures "${f}: ${l}")
    endforeach()
  endforeach()
endforeach()
if(failures)
  string(REPLACE ";" "\n" msg "${failures}")
  message(FATAL_ERROR "layer rule broken:\n${msg}")
endif()
message(STATUS "layer rule holds")
