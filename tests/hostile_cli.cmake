# Hostile command lines (issue 16): each once crashed, hung or wrote where it
# should not; each must now end with a clear error. Included from
# tests/CMakeLists.txt.
set(DYPHO_HOSTILE_DIR ${PROJECT_BINARY_DIR}/test_tmp/hostile)
file(MAKE_DIRECTORY ${DYPHO_HOSTILE_DIR})

# --threads is capped at kMaxThreads (common/files.h) in every command.
set(DYPHO_THREADS_CAP "--threads: Value 100000 not in range 0 to 256")
add_test(NAME HostileThreadsRenderDemo
  COMMAND $<TARGET_FILE:dypho> render-demo --out ${DYPHO_HOSTILE_DIR}/demo --threads 100000)
add_test(NAME HostileThreadsRender
  COMMAND $<TARGET_FILE:dypho> render --map ${PROJECT_SOURCE_DIR}/CMakeLists.txt --intrinsics 500,500,320,240,640,480
          --out ${DYPHO_HOSTILE_DIR}/render --threads 100000)
add_test(NAME HostileThreadsMap
  COMMAND $<TARGET_FILE:dypho> map ${DYPHO_HOSTILE_DIR} --out ${DYPHO_HOSTILE_DIR}/map --threads 100000)
add_test(NAME HostileThreadsScore
  COMMAND $<TARGET_FILE:dypho> score ${PROJECT_SOURCE_DIR}/CMakeLists.txt ${DYPHO_HOSTILE_DIR} --threads 100000)
set_tests_properties(HostileThreadsRenderDemo HostileThreadsRender HostileThreadsMap HostileThreadsScore
  PROPERTIES PASS_REGULAR_EXPRESSION "${DYPHO_THREADS_CAP}" TIMEOUT 60)
add_test(NAME HostileThreadsTrack
  COMMAND $<TARGET_FILE:dypho> track ${DYPHO_HOSTILE_DIR} --out ${DYPHO_HOSTILE_DIR}/t.txt --threads 100000)
set_tests_properties(HostileThreadsTrack PROPERTIES PASS_REGULAR_EXPRESSION "not in range 1 to 256" TIMEOUT 60)
add_test(NAME HostileThreadsRunSet
  COMMAND $<TARGET_FILE:dypho> run --out ${DYPHO_HOSTILE_DIR}/run --set mapper.num_threads=100000)
set_tests_properties(HostileThreadsRunSet PROPERTIES
  PASS_REGULAR_EXPRESSION "mapper.num_threads: 100000 is out of range \\[0, 256\\]" TIMEOUT 60)

# An empty output path is an error (it wrote map.ply, report.md, ... into /).
foreach(cmd "run" "map ${DYPHO_HOSTILE_DIR}" "render-demo" "synth" "track ${DYPHO_HOSTILE_DIR}"
            "masks ${DYPHO_HOSTILE_DIR}" "export ${PROJECT_SOURCE_DIR}/CMakeLists.txt")
  string(REGEX REPLACE " .*" "" name ${cmd})
  add_test(NAME HostileEmptyOut_${name} COMMAND sh -c "$<TARGET_FILE:dypho> ${cmd} --out ''")
  set_tests_properties(HostileEmptyOut_${name} PROPERTIES
    PASS_REGULAR_EXPRESSION "--out: an output path must not be empty" TIMEOUT 60)
endforeach()

# `dypho export` of a map with no Gaussians: an error, and no file.
file(WRITE ${DYPHO_HOSTILE_DIR}/empty.splat "")
add_test(NAME HostileExportEmptyMap
  COMMAND sh -c "rm -f '${DYPHO_HOSTILE_DIR}/out.splat'; $<TARGET_FILE:dypho> export '${DYPHO_HOSTILE_DIR}/empty.splat' \
--out '${DYPHO_HOSTILE_DIR}/out.splat'; rc=$?; test -e '${DYPHO_HOSTILE_DIR}/out.splat' && echo 'WROTE A FILE'; \
echo exit code $rc")
set_tests_properties(HostileExportEmptyMap PROPERTIES
  PASS_REGULAR_EXPRESSION "the map has no Gaussians; nothing written.*exit code 2" FAIL_REGULAR_EXPRESSION "WROTE A FILE"
  TIMEOUT 60)

# --out naming an existing folder where a file is expected: the real reason.
file(MAKE_DIRECTORY ${DYPHO_HOSTILE_DIR}/a_folder.ply)
add_test(NAME HostileOutIsAFolder
  COMMAND $<TARGET_FILE:dypho> render-demo --out ${DYPHO_HOSTILE_DIR}/demo2 --width 32 --height 24
          --save-ply ${DYPHO_HOSTILE_DIR}/a_folder.ply)
set_tests_properties(HostileOutIsAFolder PROPERTIES PASS_REGULAR_EXPRESSION "a_folder.ply: Is a directory"
  FAIL_REGULAR_EXPRESSION "Success" TIMEOUT 60)

# A dataset with one corrupt frame late in the sequence (frame 9 of 10).
set(DYPHO_HOSTILE_CLI sh ${CMAKE_CURRENT_LIST_DIR}/hostile_cli.sh $<TARGET_FILE:dypho> ${DYPHO_HOSTILE_DIR})
add_test(NAME HostileDatasetSetup COMMAND ${DYPHO_HOSTILE_CLI} setup)
set_tests_properties(HostileDatasetSetup PROPERTIES FIXTURES_SETUP hostile_ds PASS_REGULAR_EXPRESSION "setup done")
macro(dypho_hostile_case name case pass)
  add_test(NAME ${name} COMMAND ${DYPHO_HOSTILE_CLI} ${case})
  set_tests_properties(${name} PROPERTIES FIXTURES_REQUIRED hostile_ds RESOURCE_LOCK hostile_ds TIMEOUT 300
    PASS_REGULAR_EXPRESSION "${pass}" FAIL_REGULAR_EXPRESSION "LEFT |WROTE INTO")
endmacro()
# The corrupt frame is skipped with a warning and counted; everything else is written.
dypho_hostile_case(HostileMapSkipsCorruptFrame map "unreadable frames [(]skipped[)]: 1.*exit code 0.*outputs written")
dypho_hostile_case(HostileRunSkipsCorruptFrame run "1 unreadable frames skipped.*exit code 0.*outputs written")
# --strict: the run ends there, as Ctrl-C does, with the outputs of the frames before.
dypho_hostile_case(HostileMapStrictStops map-strict "stopped at an unreadable frame.*exit code 2.*outputs written")
dypho_hostile_case(HostileRunStrictStops run-strict "stopped at an unreadable frame.*exit code 2.*outputs written")
# No frame with a pose: a clear error, no map files, no stale outputs of the earlier run.
dypho_hostile_case(HostileRunNoPose run-no-pose "no frame had a pose.*exit code 2.*other files kept")
dypho_hostile_case(HostileMapNoPose map-no-pose "had a pose.*nothing written.*exit code 2.*checked")
# A frame range with no frame to score names the range and --every.
dypho_hostile_case(HostileScoreNoFrame score-no-frame "no frame to score: frames 3 to 3 .*every=10.*exit code 2")
# No command writes inside its input dataset unless asked to.
dypho_hostile_case(HostileTrackIntoDataset track-into-dataset
  "lies inside the input dataset.*exit code 2.*ground truth unchanged")
dypho_hostile_case(HostileMasksIntoDataset masks-into-dataset "lies inside the input dataset.*exit code 2.*checked")

# The parsers fuzzed for 6 s each under ASan and UBSan (tests/fuzz/build.sh:
# clang, parser sources only; about 1.5 min to build from scratch). Skipped
# without clang++.
find_program(DYPHO_CLANGXX clang++)
if(DYPHO_CLANGXX)
  add_test(NAME FuzzParsersShort COMMAND ${CMAKE_CURRENT_LIST_DIR}/fuzz/build.sh ${PROJECT_BINARY_DIR}/fuzz run 6)
  set_tests_properties(FuzzParsersShort PROPERTIES TIMEOUT 900 ENVIRONMENT "CXX_FUZZ=${DYPHO_CLANGXX}"
    PASS_REGULAR_EXPRESSION "fuzz_options: Done" FAIL_REGULAR_EXPRESSION "FINDING|did not build")
else()
  message(STATUS "dypho: clang++ not found: the fuzz targets (tests/fuzz/build.sh) are not registered")
endif()
