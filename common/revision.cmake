# Run at build time (common/CMakeLists.txt, target rectify_revision): writes
# OUT from IN with the source's git revision, so that the revision every
# summary.json and map set records is the one built, not the one configured.
# configure_file leaves OUT untouched when nothing changed: no rebuild then.
execute_process(COMMAND git describe --always --dirty --tags
  WORKING_DIRECTORY ${SOURCE_DIR} OUTPUT_VARIABLE RECTIFY_REVISION
  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE git_result)
if(NOT git_result EQUAL 0 OR RECTIFY_REVISION STREQUAL "")
  set(RECTIFY_REVISION "unknown")
endif()
configure_file(${IN} ${OUT} @ONLY)
