# The layer rules of docs/architecture.md at the source level, for every library folder:
#  1. a library's sources include only headers of the folders below it (tests and benchmarks,
#     *_test.cc / *_bench.cc, may use any layer: they link what their CMake rule names);
#  2. firmware-app holds wiring, the daemon loop and the CLI only: no encoder, no report field,
#     no evaluation code (those live in entry/ and eval/).
# The link-level rule is mm_forbid_link in the top CMakeLists.txt.
cmake_policy(SET CMP0007 NEW)
set(all_layers "base/|scale/|dataset/|calib/|spool/|recon/|map/|render/|session/|entry/|eval/|synth/|capture/|web/|app/|cli/")
# folder : the folders it may include (besides itself)
set(rules
  "base:"
  "scale:base/"
  "dataset:base/"
  "calib:base/"
  "spool:base/"
  "recon:base/|calib/"
  "map:base/|calib/|recon/"
  "render:base/|recon/"
  "session:base/|calib/|recon/"
  "entry:base/|scale/|calib/|recon/|map/|render/|spool/|session/"
  "eval:base/|scale/|calib/|dataset/|recon/|map/|render/|entry/|session/"
  "synth:base/|calib/|recon/|render/"
  "capture:base/|dataset/"
  "web:base/|spool/|entry/")
set(failures "")
foreach(rule IN LISTS rules)
  string(REPLACE ":" ";" parts "${rule}")
  list(GET parts 0 folder)
  list(LENGTH parts n)
  set(allowed "${folder}/")
  if(n GREATER 1)
    list(GET parts 1 below)
    if(below)
      set(allowed "${allowed}|${below}")
    endif()
  endif()
  file(GLOB_RECURSE files "${SOURCE_DIR}/${folder}/*.h" "${SOURCE_DIR}/${folder}/*.cc")
  list(FILTER files EXCLUDE REGEX "_(test|bench)\\.cc$")
  if(NOT files)
    list(APPEND failures "${folder}/: no sources found (is the rule table out of date?)")
  endif()
  foreach(f IN LISTS files)
    file(STRINGS "${f}" lines REGEX "^#include \"(${all_layers})")
    foreach(l IN LISTS lines)
      if(NOT l MATCHES "^#include \"(${allowed})")
        list(APPEND failures "${f}: ${l} (${folder} may include ${allowed})")
      endif()
    endforeach()
  endforeach()
endforeach()

# firmware-app: wiring only.
set(app_forbidden
  "Encode(Glb|Ply|Obj|Mtl|PointsPly|ColmapText)\\(|cv::imencode\\("  # entry/ encodes
  "report(\\.|->)?(\\[\"|at\\(\"|value\\(\")"                # report fields by key
  "\"(mesh_vertices|relative_pose|keyframes|timings_s|source_time_s)\""
  "RotationErrorDeg\\(|DirectionErrorDeg\\(|Trajectory::"    # evaluation against ground truth
  "#include \"(dataset/|entry/mesh_io|eval/mesh_checks)")
file(GLOB_RECURSE app_files "${SOURCE_DIR}/firmware-app/*.h" "${SOURCE_DIR}/firmware-app/*.cc")
list(FILTER app_files EXCLUDE REGEX "_test\\.cc$")
foreach(f IN LISTS app_files)
  foreach(pattern IN LISTS app_forbidden)
    file(STRINGS "${f}" lines REGEX "${pattern}")
    foreach(l IN LISTS lines)
      string(STRIP "${l}" l)
      list(APPEND failures "${f}: ${l} (firmware-app is wiring only: entry/ and eval/ hold this)")
    endforeach()
  endforeach()
endforeach()

# JSON text for output only through JsonText (entry/json_text.h): nlohmann's dump() throws on a
# string that is not UTF-8 (a frame file name, a client's bytes), which ended the daemon.
set(json_files "")
foreach(folder base dataset calib spool recon render session entry eval synth capture firmware-app)
  file(GLOB_RECURSE found "${SOURCE_DIR}/${folder}/*.h" "${SOURCE_DIR}/${folder}/*.cc")
  list(APPEND json_files ${found})
endforeach()
list(FILTER json_files EXCLUDE REGEX "(_test\\.cc|/entry/json_text\\.cc)$")
foreach(f IN LISTS json_files)
  file(STRINGS "${f}" lines REGEX "\\.dump\\(")
  foreach(l IN LISTS lines)
    string(STRIP "${l}" l)
    list(APPEND failures "${f}: ${l} (serialize JSON with JsonText, entry/json_text.h)")
  endforeach()
endforeach()

if(failures)
  string(REPLACE ";" "\n" msg "${failures}")
  message(FATAL_ERROR "layer rule broken:\n${msg}")
endif()
message(STATUS "layer rule holds")
